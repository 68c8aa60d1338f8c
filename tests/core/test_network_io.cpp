#include "piperun/error.h"
#include "piperun/io/network_io.h"
#include "piperun/io/output_path.h"
#include "test_util.h"

#include <gtest/gtest.h>

namespace piperun {
namespace {

using test::TempDir;

PipeNetwork sampleNetwork() {
  PipeNetwork network;
  Pipe a;
  a.id = 1;
  a.radius = 0.05;
  a.start = {0, 0, 0};
  a.end = {2, 0, 0};
  a.fitRms = 0.0015;
  a.inlierCount = 1234;
  a.confidence = 0.9;
  a.runId = 0;
  Pipe b = a;
  b.id = 2;
  b.start = {2.1, 0.1, 0};
  b.end = {2.1, 2, 0};
  b.status = PipeStatus::Proposed;
  Pipe c = a;
  c.id = 3;
  c.radius = 0.0254;
  c.start = {1, 0, 0.05};
  c.end = {1, 0, 1};
  c.runId = -1;
  c.status = PipeStatus::Deleted;
  network.pipes = {a, b, c};
  Joint elbow;
  elbow.id = 10;
  elbow.type = JointType::Elbow;
  elbow.pipeIds = {1, 2};
  elbow.radius = 0.05;
  elbow.bendRadius = 0.1;
  elbow.axis = sampleArc({2, 0.1, 0}, {2, 0, 0}, {2.1, 0.1, 0}, 0.01);
  elbow.confidence = 0.75;
  elbow.status = JointStatus::Proposed;
  Joint tee;
  tee.id = 11;
  tee.type = JointType::Tee;
  tee.pipeIds = {1, 3};
  tee.radius = 0.0254;
  tee.axis = {{1, 0, 0}, {1, 0, 0.05}};
  tee.status = JointStatus::Rejected;
  network.joints = {elbow, tee};
  network.runs = {Run{0, {1, 2}, {10}}};
  return network;
}

TEST(NetworkJson, RoundTripKeepsEveryField) {
  TempDir dir;
  const PipeNetwork network = sampleNetwork();
  writeNetwork(dir / "net.json", network, {{"source", "scan.e57"}});
  NetworkMetadata metadata;
  const PipeNetwork back = readNetwork(dir / "net.json", &metadata);
  EXPECT_EQ(metadata.at("source"), "scan.e57");
  ASSERT_EQ(back.pipes.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    const Pipe& p = network.pipes[i];
    const Pipe& q = back.pipes[i];
    EXPECT_EQ(p.id, q.id);
    EXPECT_EQ(p.radius, q.radius);
    EXPECT_EQ(p.start, q.start);
    EXPECT_EQ(p.end, q.end);
    EXPECT_EQ(p.fitRms, q.fitRms);
    EXPECT_EQ(p.inlierCount, q.inlierCount);
    EXPECT_EQ(p.confidence, q.confidence);
    EXPECT_EQ(p.runId, q.runId);
    EXPECT_EQ(p.status, q.status);
  }
  ASSERT_EQ(back.joints.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const Joint& p = network.joints[i];
    const Joint& q = back.joints[i];
    EXPECT_EQ(p.id, q.id);
    EXPECT_EQ(p.type, q.type);
    EXPECT_EQ(p.pipeIds, q.pipeIds);
    EXPECT_EQ(p.radius, q.radius);
    EXPECT_EQ(p.axis, q.axis);
    EXPECT_EQ(p.bendRadius, q.bendRadius);
    EXPECT_EQ(p.confidence, q.confidence);
    EXPECT_EQ(p.status, q.status);
  }
  ASSERT_EQ(back.runs.size(), 1u);
  EXPECT_EQ(back.runs[0].pipeIds, (std::vector<int>{1, 2}));
  EXPECT_EQ(back.runs[0].jointIds, (std::vector<int>{10}));
}

TEST(NetworkJson, DocumentHasTheRequiredTopLevelFields) {
  const std::string text = networkToJson(sampleNetwork());
  for (const char* field : {"\"format\": \"piperun-network\"", "\"version\": 1", "\"units\": \"m\"", "\"pipes\"",
                            "\"joints\"", "\"runs\"", "\"axis\"", "\"radius\""}) {
    EXPECT_NE(text.find(field), std::string::npos) << field;
  }
}

TEST(NetworkJson, ElbowAxisIsSampledEveryCentimetre) {
  const PipeNetwork network = sampleNetwork();
  const Joint& elbow = network.joints[0];
  for (std::size_t i = 1; i < elbow.axis.size(); ++i) EXPECT_LE((elbow.axis[i] - elbow.axis[i - 1]).norm(), 0.01 + 1e-12);
  for (const auto& p : elbow.axis) EXPECT_NEAR((p - Eigen::Vector3d(2, 0.1, 0)).norm(), 0.1, 1e-12);
}

TEST(NetworkJson, MinimalDocumentUsesDefaults) {
  const auto network = networkFromJson(
      R"({"format":"piperun-network","version":1,"units":"m",
          "pipes":[{"id":4,"radius":0.1,"axis":[[0,0,0],[0,0,1]]}],
          "joints":[{"id":5,"radius":0.1,"axis":[[0,0,1],[0,0.05,1.1],[0,0.1,1.1]]}],"runs":[]})",
      "mem.json");
  ASSERT_EQ(network.pipes.size(), 1u);
  EXPECT_EQ(network.pipes[0].status, PipeStatus::Accepted);
  EXPECT_EQ(network.pipes[0].runId, -1);
  EXPECT_EQ(network.joints[0].type, JointType::Elbow);
}

void expectInputError(const std::string& text, const std::string& location, const std::string& words) {
  try {
    networkFromJson(text, "net.json");
    FAIL() << "accepted: " << text;
  } catch (const InputError& error) {
    EXPECT_EQ(error.location(), location) << error.what();
    EXPECT_NE(std::string(error.what()).find(words), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("net.json"), std::string::npos);
  }
}

TEST(NetworkJson, MalformedDocumentsNameThePlace) {
  expectInputError("{\"format\": ", "byte 11", "invalid JSON");
  expectInputError("[1,2]", "/", "expected a JSON object");
  expectInputError(R"({"format":"other","version":1,"pipes":[]})", "/format", "piperun-network");
  expectInputError(R"({"format":"piperun-network","version":7,"pipes":[]})", "/version",
                   "unsupported piperun-network version 7");
  expectInputError(R"({"format":"piperun-network","version":1,"units":"mm","pipes":[]})", "/units", "metres");
  expectInputError(R"({"format":"piperun-network","version":1,"pipes":[{"id":1,"axis":[[0,0,0],[1,0,0]]}]})",
                   "/pipes/0", "missing required field \"radius\"");
  expectInputError(R"({"format":"piperun-network","version":1,"pipes":[{"id":1,"radius":-2,"axis":[[0,0,0],[1,0,0]]}]})",
                   "/pipes/0/radius", "positive");
  expectInputError(R"({"format":"piperun-network","version":1,"pipes":[{"id":1,"radius":1,"axis":[[0,0,0],[1,"a",0]]}]})",
                   "/pipes/0/axis/1/1", "expected a number");
  expectInputError(R"({"format":"piperun-network","version":1,"pipes":[{"id":1,"radius":1,"axis":[[0,0,0]]}]})",
                   "/pipes/0/axis", "two points");
  expectInputError(R"({"format":"piperun-network","version":1,"pipes":[],
                       "joints":[{"id":1,"radius":1,"type":"bend","axis":[[0,0,0],[1,0,0]]}]})",
                   "/joints/0/type", "elbow");
  expectInputError(R"({"format":"piperun-network","version":1,"pipes":[],
                       "joints":[{"id":1,"radius":1,"pipes":[9],"axis":[[0,0,0],[1,0,0]]}]})",
                   "/", "unknown pipe 9");
  expectInputError(R"({"format":"piperun-network","version":1,"pipes":[
                       {"id":1,"radius":1,"axis":[[0,0,0],[1,0,0]]},{"id":1,"radius":1,"axis":[[0,0,0],[1,0,0]]}]})",
                   "/", "duplicate pipe id 1");
}

TEST(NetworkJson, WriteIsAtomicAndReportsUnwritablePaths) {
  TempDir dir;
  writeNetwork(dir / "net.json", sampleNetwork());
  const auto before = test::readFile(dir / "net.json");
  EXPECT_THROW(writeNetwork(dir / "absent" / "net.json", sampleNetwork()), OutputError);
  EXPECT_EQ(test::readFile(dir / "net.json"), before);
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(dir.path())) ++files;
  EXPECT_EQ(files, 1u);  // no temporary left behind
}

TEST(OutputPath, AFileOrFolderThatCannotBeWrittenIsNamedBeforeAnythingIsWritten) {
  TempDir dir;
  const auto fileCount = [&] {
    std::size_t files = 0;
    for ([[maybe_unused]] const auto& entry : std::filesystem::recursive_directory_iterator(dir.path())) ++files;
    return files;
  };
  EXPECT_NO_THROW(requireWritableFile(dir / "net.json"));
  EXPECT_EQ(fileCount(), 0u);  // the probe is gone
  const auto messageOf = [](const auto& check) -> std::string {
    try {
      check();
    } catch (const OutputError& error) {
      return error.what();
    }
    return "no error";
  };
  EXPECT_EQ(messageOf([&] { requireWritableFile(dir / "absent" / "net.json"); }),
            (dir / "absent" / "net.json").string() + ": cannot create: no folder " + (dir / "absent").string());
  EXPECT_EQ(messageOf([&] { requireWritableFile(dir.path()); }), dir.path().string() + ": cannot create: it is a folder");

  test::writeFile(dir / "scan.ply", "ply");
  EXPECT_EQ(messageOf([&] { requireWritableFile(dir / "scan.ply" / "net.json"); }),
            (dir / "scan.ply" / "net.json").string() + ": cannot create: " + (dir / "scan.ply").string() +
                " is not a folder");
  EXPECT_NE(messageOf([&] { requireWritableFolder(dir / "scan.ply" / "stages"); }), "no error");
  // A folder is made with its parents, and left empty.
  EXPECT_NO_THROW(requireWritableFolder(dir / "stages" / "run 1"));
  EXPECT_TRUE(std::filesystem::is_directory(dir / "stages" / "run 1"));
  EXPECT_TRUE(std::filesystem::is_empty(dir / "stages" / "run 1"));
}

TEST(NetworkJson, RunFigures) {
  const PipeNetwork network = sampleNetwork();
  EXPECT_NEAR(runLength(network, network.runs[0]), 2.0 + 1.9 + network.joints[0].length(), 1e-9);
  EXPECT_EQ(runNominalRadius(network, network.runs[0]), 0.05);
}

}  // namespace
}  // namespace piperun
