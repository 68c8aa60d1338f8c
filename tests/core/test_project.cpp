// Project files: exact round trips, changed scans, autosave, atomic saves under SIGKILL, nominal sizes.

#include "io/atomic_file.h"
#include "piperun/edit/bill_of_materials.h"
#include "piperun/edit/command_interpreter.h"
#include "piperun/edit/project.h"
#include "piperun/error.h"
#include "piperun/io/network_io.h"
#include "piperun/params.h"
#include "piperun/resources.h"
#include "test_util.h"

#include <gtest/gtest.h>

#include <csignal>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <thread>

namespace piperun {
namespace {

// A grid of pipes in rows joined by boundary joints: `count` pipes, every other gap joined.
PipeNetwork gridNetwork(int count) {
  PipeNetwork network;
  for (int i = 0; i < count; ++i) {
    Pipe pipe;
    pipe.id = i + 1;
    const double x = (i % 50) * 1.0, y = (i / 50) * 0.5;
    pipe.start = {x, y, 1.0};
    pipe.end = {x + 0.9, y, 1.0};
    pipe.radius = 0.02 + 0.001 * (i % 7);
    pipe.fitRms = 0.0015;
    pipe.inlierCount = 500 + i;
    pipe.confidence = 0.3 + 0.1 * (i % 7);
    pipe.status = pipe.confidence >= 0.5 ? PipeStatus::Accepted : PipeStatus::Proposed;
    network.pipes.push_back(pipe);
  }
  for (int i = 0; i + 1 < count; i += 2) {
    if ((i + 1) % 50 == 0) continue;
    Joint joint;
    joint.id = count + 1 + i;
    joint.type = JointType::Boundary;
    joint.pipeIds = {i + 1, i + 2};
    joint.radius = network.pipes[static_cast<std::size_t>(i)].radius;
    joint.axis = {network.pipes[static_cast<std::size_t>(i)].end, network.pipes[static_cast<std::size_t>(i) + 1].start};
    joint.confidence = 0.7;
    joint.status = i % 4 == 0 ? JointStatus::Accepted : JointStatus::Proposed;
    network.joints.push_back(joint);
  }
  return network;
}

Project reviewedProject(const std::filesystem::path& scan) {
  test::writeFile(scan, "ply\nformat ascii 1.0\nelement vertex 0\nend_header\n");
  Project project;
  project.scanPath = std::filesystem::absolute(scan);
  project.scanHash = hashFile(scan);
  project.params.placement.centerBandwidth = 0.0125;
  project.params.seed = 7;
  project.freshStages = {true, true, true, false, false, false};
  project.edits = EditSession(gridNetwork(12));
  CommandInterpreter interpreter(project, nullptr);
  interpreter.setAutosaveInterval(0);
  for (const char* line : {"joint 13 reject", "joint 15 accept", "pipe 4 delete", "pipe 1 split 0.25 0 1", "pipe 2 snap",
                           "pipe 5 radius 0.0333", "undo"}) {
    interpreter.execute(line);
  }
  return project;
}

TEST(ProjectFile, IsNamedByItsExtensionInAnyCase) {
  EXPECT_TRUE(isProjectFile("site/pump room.piperun"));
  EXPECT_TRUE(isProjectFile("PUMP.PipeRun"));
  EXPECT_FALSE(isProjectFile("pump.piperun.autosave"));
  EXPECT_FALSE(isProjectFile("pump.json"));
  EXPECT_FALSE(isProjectFile("piperun"));
  EXPECT_TRUE(isNetworkFile("out/NET.JSON"));
  EXPECT_FALSE(isNetworkFile("pump.piperun"));
  EXPECT_FALSE(isNetworkFile("scan.ply"));
}

TEST(ProjectFile, ReopensExactlyWithHistoryParametersAndStages) {
  test::TempDir dir;
  Project project = reviewedProject(dir / "scan.ply");
  saveProject(dir / "review.piperun", project);
  EXPECT_EQ(project.file, dir / "review.piperun");

  const OpenedProject opened = openProject(dir / "review.piperun");
  EXPECT_TRUE(opened.warnings.empty());
  const Project& reopened = opened.project;
  EXPECT_EQ(networkToJson(reopened.edits.network()), networkToJson(project.edits.network()));
  EXPECT_EQ(networkToJson(reopened.edits.base()), networkToJson(project.edits.base()));
  EXPECT_EQ(paramsToJson(reopened.params), paramsToJson(project.params));
  EXPECT_EQ(reopened.freshStages, project.freshStages);
  EXPECT_EQ(reopened.scanPath, project.scanPath);
  EXPECT_EQ(reopened.edits.position(), 5u);
  ASSERT_EQ(reopened.edits.steps().size(), 6u);  // the undone step can be redone after reopening
  EXPECT_EQ(projectToJson(reopened), projectToJson(project));

  EditSession a = project.edits, b = reopened.edits;
  a.redo();
  b.redo();
  EXPECT_EQ(networkToJson(b.network()), networkToJson(a.network()));
  EXPECT_EQ(b.network().findPipe(5)->radius, 0.0333);
}

TEST(ProjectFile, KeepsTheScansUnitAndReadsProjectsWithoutOneAsMetres) {
  test::TempDir dir;
  Project project = reviewedProject(dir / "scan.ply");
  project.scanUnits = "us-ft";
  saveProject(dir / "review.piperun", project);
  EXPECT_EQ(openProject(dir / "review.piperun").project.scanUnits, "us-ft");

  // Projects saved before scans had a unit hold none: their scans were read as metres.
  std::string text = projectToJson(project);
  const std::size_t units = text.find(",\n  \"units\": \"us-ft\"");
  ASSERT_NE(units, std::string::npos) << text;
  text.erase(units, std::string(",\n  \"units\": \"us-ft\"").size());
  EXPECT_EQ(projectFromJson(text, "old.piperun").scanUnits, "m");

  std::string unknown = projectToJson(project);
  unknown.replace(unknown.find("\"us-ft\""), 7, "\"yards\"");
  try {
    projectFromJson(unknown, "p.piperun");
    FAIL() << "accepted an unknown unit";
  } catch (const InputError& error) {
    EXPECT_EQ(error.location(), "/scan/units") << error.what();
    EXPECT_NE(std::string(error.what()).find("\"mm\""), std::string::npos) << error.what();
  }
}

TEST(ProjectFile, ChangedOrMissingScanWarnsAndStillOpens) {
  test::TempDir dir;
  Project project = reviewedProject(dir / "scan.ply");
  saveProject(dir / "review.piperun", project);
  test::writeFile(dir / "scan.ply", "ply\nformat ascii 1.0\nelement vertex 1\nend_header\n0 0 0\n");
  OpenedProject opened = openProject(dir / "review.piperun");
  ASSERT_EQ(opened.warnings.size(), 1u);
  EXPECT_NE(opened.warnings[0].find("changed since the project was saved"), std::string::npos) << opened.warnings[0];
  EXPECT_EQ(networkToJson(opened.project.edits.network()), networkToJson(project.edits.network()));

  std::filesystem::remove(dir / "scan.ply");
  opened = openProject(dir / "review.piperun");
  ASSERT_EQ(opened.warnings.size(), 1u);
  EXPECT_NE(opened.warnings[0].find("not found"), std::string::npos) << opened.warnings[0];
}

TEST(ProjectFile, MalformedDocumentsNameTheValue) {
  test::TempDir dir;
  Project project = reviewedProject(dir / "scan.ply");
  std::string text = projectToJson(project);
  const auto expectError = [&](const std::string& document, const std::string& location) {
    try {
      projectFromJson(document, "p.piperun");
      FAIL() << "accepted a document with a bad " << location;
    } catch (const InputError& error) {
      EXPECT_EQ(error.location(), location) << error.what();
    }
  };
  std::string badVersion = text;
  badVersion.replace(badVersion.find("\"version\": 1"), 12, "\"version\": 9");
  expectError(badVersion, "/version");
  std::string badRadius = text;
  badRadius.insert(badRadius.find("\"radius\": ", badRadius.find("\"joints\"", badRadius.find("\"network\""))) + 10, "-");
  expectError(badRadius, "/network/joints/0/radius");
  std::string badCommand = text;
  badCommand.replace(badCommand.find("joint 13 reject"), 15, "joint 13 frob  ");
  expectError(badCommand, "/history/steps/0/command");
}

TEST(ProjectFile, AutosavesEveryFewEditsAndReportsANewerAutosave) {
  test::TempDir dir;
  Project project = reviewedProject(dir / "scan.ply");
  saveProject(dir / "review.piperun", project);
  // Make the project file clearly older than anything written next.
  std::filesystem::last_write_time(dir / "review.piperun",
                                   std::filesystem::file_time_type::clock::now() - std::chrono::hours(1));
  CommandInterpreter interpreter(project, nullptr);
  interpreter.setAutosaveInterval(3);
  const std::filesystem::path sidecar = dir / "review.piperun.autosave";
  EXPECT_EQ(autosavePath(project), sidecar);
  interpreter.execute("joint 17 reject");
  interpreter.execute("pipe 9 delete");
  EXPECT_FALSE(std::filesystem::exists(sidecar));
  interpreter.execute("undo");
  ASSERT_TRUE(std::filesystem::exists(sidecar));

  const OpenedProject opened = openProject(dir / "review.piperun");
  ASSERT_TRUE(opened.newerAutosave.has_value());
  EXPECT_EQ(*opened.newerAutosave, sidecar);
  const OpenedProject recovered = openProject(sidecar);
  EXPECT_EQ(networkToJson(recovered.project.edits.network()), networkToJson(project.edits.network()));

  interpreter.execute("save " + (dir / "review.piperun").string());
  EXPECT_FALSE(std::filesystem::exists(sidecar)) << "a save makes the autosave obsolete";
}

TEST(ProjectFile, TheReviewedNetworkExportsFromTheCommandAndReadsBackWithoutItsScan) {
  test::TempDir dir;
  Project project = reviewedProject(dir / "scan.ply");  // joint 13 rejected, pipe 4 deleted
  saveProject(dir / "review.piperun", project);
  CommandInterpreter interpreter(project, nullptr);
  const CommandOutcome outcome = interpreter.execute("export " + (dir / "review.csv").string());
  EXPECT_EQ(outcome.message, "exported " + (dir / "review.csv").string() + " (csv)");
  EXPECT_FALSE(outcome.networkChanged);
  const std::string csv = test::readFile(dir / "review.csv");
  EXPECT_EQ(csv.find("\n4,pipe,"), std::string::npos) << "the deleted pipe is exported";
  EXPECT_EQ(csv.find("\n13,boundary,"), std::string::npos) << "the rejected joint is exported";
  EXPECT_NE(csv.find("\n5,pipe,"), std::string::npos);
  EXPECT_NE(csv.find("\n8,pipe,"), std::string::npos) << "the proposed pipe 8 is left out of the full export";
  EXPECT_THROW(interpreter.execute("export " + (dir / "review.stl").string()), CommandError);
  EXPECT_THROW(interpreter.execute("export"), CommandError);
  EXPECT_THROW(interpreter.execute("export " + (dir / "review.csv").string() + " proposed"), CommandError);

  // What is accepted only: no proposed element is left.
  const CommandOutcome accepted = interpreter.execute("export " + (dir / "accepted.csv").string() + " accepted");
  EXPECT_EQ(accepted.message, "exported " + (dir / "accepted.csv").string() + " (csv, accepted only)");
  const std::string acceptedCsv = test::readFile(dir / "accepted.csv");
  EXPECT_EQ(acceptedCsv.find(",proposed,"), std::string::npos);
  EXPECT_EQ(acceptedCsv.find("\n8,pipe,"), std::string::npos);
  EXPECT_NE(acceptedCsv.find("\n5,pipe,"), std::string::npos);
  EXPECT_NE(csv.find(",proposed,"), std::string::npos);

  // Read back as saved, even with its scan gone.
  std::filesystem::remove(dir / "scan.ply");
  const Project read = readProject(dir / "review.piperun");
  EXPECT_EQ(networkToJson(read.edits.network()), networkToJson(project.edits.network()));
  EXPECT_EQ(read.file, dir / "review.piperun");
}

// A child process saves two different large projects over one file in a loop and is killed at
// several moments: the file must always read back as one of the two, complete. The child writes
// the documents saveProject() writes, serialised once, so that it spends its time writing.
TEST(ProjectFile, KillDuringSaveLeavesTheOldOrTheNewFile) {
  test::TempDir dir;
  const std::filesystem::path path = dir / "big.piperun";
  Project first, second;
  first.edits = EditSession(gridNetwork(3000));
  second.edits = EditSession(gridNetwork(3000));
  second.edits.apply(Edit{EditKind::DeletePipe, 3, 0, 0, 0.0, {}, {}}, {});
  const std::string firstNetwork = networkToJson(first.edits.network());
  const std::string secondNetwork = networkToJson(second.edits.network());
  saveProject(path, first);
  const std::string documents[2] = {projectToJson(second), projectToJson(first)};

  int killedMidWrite = 0;
  for (int attempt = 0; attempt < 5; ++attempt) {
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      for (int k = 0;; ++k) io::writeFileAtomically(path, documents[k % 2]);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(30 + 17 * attempt));
    ASSERT_EQ(kill(child, SIGKILL), 0);
    int status = 0;
    ASSERT_EQ(waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFSIGNALED(status));
    // The killed save's temporary file shows the kill landed inside a write.
    const std::filesystem::path temporary = path.string() + ".tmp-" + std::to_string(child);
    if (std::filesystem::exists(temporary)) {
      ++killedMidWrite;
      std::filesystem::remove(temporary);
    }
    const std::string network = networkToJson(openProject(path).project.edits.network());
    EXPECT_TRUE(network == firstNetwork || network == secondNetwork) << "attempt " << attempt;
  }
  EXPECT_GT(killedMidWrite, 0) << "no kill landed during a write";
}

TEST(NominalSizes, ShippedTableIsFoundAndSnapsToTheNearestSize) {
  const std::filesystem::path table = findResource("nominal_pipe_sizes.csv");
  EXPECT_TRUE(std::filesystem::is_regular_file(table));
  const NominalSizes sizes = NominalSizes::read(table);
  EXPECT_GE(sizes.sizes().size(), 25u);
  EXPECT_EQ(sizes.nearest(0.057).nps, "4");  // OD 114.3 mm
  EXPECT_EQ(sizes.nearest(0.057).dn, 100);
  EXPECT_EQ(sizes.nearest(0.0167).nps, "1");  // OD 33.4 mm
  EXPECT_EQ(sizes.nearest(5.0).nps, sizes.sizes().back().nps);

  test::TempDir dir;
  test::writeFile(dir / "sizes.csv", "nps,dn,od_mm\n1,25,33.4\n2,50,sixty\n");
  try {
    NominalSizes::read(dir / "sizes.csv");
    FAIL();
  } catch (const InputError& error) {
    EXPECT_EQ(error.location(), "line 3");
  }
}

TEST(NominalSizes, BillOfMaterialsCountsEachSizeAndEachRun) {
  // A 6" pipe turns into an 8" one (proposed); a deleted 6" pipe and a rejected 2" tee count nowhere.
  PipeNetwork network;
  network.pipes = {test::makePipe(1, 0.0843, {0, 0, 0}, {2, 0, 0}),
                   test::makePipe(2, 0.1095, {2.3, 0.3, 0}, {2.3, 1.3, 0}, -1, PipeStatus::Proposed),
                   test::makePipe(3, 0.0843, {0, 5, 0}, {1, 5, 0}, -1, PipeStatus::Deleted)};
  Joint elbow;
  elbow.id = 4;
  elbow.pipeIds = {1, 2};
  elbow.radius = 0.0843;
  elbow.axis = sampleArc({2, 0.3, 0}, {2, 0, 0}, {2.3, 0.3, 0}, 0.01);
  Joint tee;
  tee.id = 5;
  tee.type = JointType::Tee;
  tee.status = JointStatus::Rejected;
  tee.pipeIds = {1, 3};
  tee.radius = 0.03;
  tee.axis = {{1, 0, 0}, {1, 0.1, 0}};
  network.joints = {elbow, tee};
  network.runs = {piperun::Run{1, {1, 2}, {4}}};
  const NominalSizes sizes = NominalSizes::shipped();

  const std::vector<SizeTally> tallies = tallyBySize(network, sizes);
  ASSERT_EQ(tallies.size(), 2u);
  EXPECT_EQ(tallies[0].size.dn, 150);
  EXPECT_EQ(tallies[0].pipes, 1);
  EXPECT_DOUBLE_EQ(tallies[0].pipeLength, 2.0);
  EXPECT_EQ(tallies[0].elbows, 1);
  EXPECT_EQ(tallies[0].elbows90, 1);  // the 90° fitting
  EXPECT_EQ(tallies[0].elbows45, 0);
  EXPECT_EQ(tallies[0].tees, 0);
  EXPECT_EQ(tallies[0].proposed, 0);
  EXPECT_EQ(tallies[1].size.nps, "8");
  EXPECT_EQ(tallies[1].pipes, 1);
  EXPECT_EQ(tallies[1].proposed, 1);

  const std::vector<RunSummary> runs = summarizeRuns(network, sizes);
  ASSERT_EQ(runs.size(), 1u);
  EXPECT_EQ(runs[0].id, 1);
  EXPECT_DOUBLE_EQ(runs[0].length, runLength(network, network.runs[0]));
  EXPECT_EQ(runs[0].size.dn, 150);  // 2 m and the elbow of 6" against 1 m of 8"
  EXPECT_EQ(runs[0].pipes, 2);
  EXPECT_EQ(runs[0].elbows, 1);
  EXPECT_EQ(runs[0].proposed, 1);
}

TEST(NominalSizes, ResourceFolderCanBeSetByEnvironment) {
  test::TempDir dir;
  test::writeFile(dir / "nominal_pipe_sizes.csv", "nps,dn,od_mm\n2,50,60.3\n");
  setenv("PIPERUN_RESOURCE_DIR", dir.path().c_str(), 1);
  const NominalSizes sizes = NominalSizes::shipped();
  unsetenv("PIPERUN_RESOURCE_DIR");
  ASSERT_EQ(sizes.sizes().size(), 1u);
  EXPECT_EQ(sizes.nearest(0.01).nps, "2");
  EXPECT_THROW(findResource("no_such_file.csv"), InputError);
}

}  // namespace
}  // namespace piperun
