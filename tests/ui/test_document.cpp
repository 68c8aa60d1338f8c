#include "piperun/ui/document.h"

#include "piperun/error.h"
#include "piperun/io/network_io.h"
#include "piperun/io/point_writer.h"

#include <gtest/gtest.h>

#include <filesystem>

namespace piperun::ui {
namespace {

std::filesystem::path temporaryPath(const std::string& name) {
  return std::filesystem::temp_directory_path() / ("piperun_ui_document_" + name);
}

/// A three-point scan written to a temporary PLY file named `name`.
std::filesystem::path writeSmallScan(const std::string& name) {
  PointCloud cloud;
  PointChunk chunk;
  chunk.positions = {{1.0, 2.0, 3.0}, {1.005, 2.0, 3.0}, {1.0, 2.005, 3.0}};
  cloud.append(chunk);
  const auto path = temporaryPath(name);
  writePointCloud(path, cloud);
  return path;
}

TEST(Document, OpensANetworkWithoutPipeline) {
  PipeNetwork network;
  Pipe pipe;
  pipe.id = 1;
  pipe.radius = 0.05;
  pipe.end = {1.0, 0.0, 0.0};
  network.pipes.push_back(pipe);
  const auto path = temporaryPath("network.json");
  writeNetwork(path, network);

  const Document document = Document::open(path);
  EXPECT_FALSE(document.hasPipeline());
  EXPECT_FALSE(document.input());
  ASSERT_EQ(document.network().pipes.size(), 1u);
  EXPECT_DOUBLE_EQ(document.network().pipes[0].radius, 0.05);
  EXPECT_EQ(document.path(), path);
  std::filesystem::remove(path);
}

TEST(Document, OpensAScanWithAStalePipeline) {
  const auto path = writeSmallScan("scan.ply");

  const Document document = Document::open(path);
  ASSERT_TRUE(document.hasPipeline());
  ASSERT_TRUE(document.input());
  EXPECT_EQ(document.input()->size(), 3u);
  for (Stage stage : kAllStages) EXPECT_FALSE(document.pipeline()->isFresh(stage)) << stageName(stage);
  EXPECT_TRUE(document.network().pipes.empty());
  std::filesystem::remove(path);
}

PipeNetwork twoPipesAndAJoint() {
  PipeNetwork network;
  for (int id : {1, 2}) {
    Pipe pipe;
    pipe.id = id;
    pipe.radius = 0.05;
    pipe.start = {id - 1.0, 0.0, 0.0};
    pipe.end = {id * 1.0, 0.0, 0.0};
    network.pipes.push_back(pipe);
  }
  Joint joint;
  joint.id = 3;
  joint.type = JointType::Boundary;
  joint.radius = 0.05;
  joint.pipeIds = {1, 2};
  joint.axis = {{0.9, 0.0, 0.0}, {1.1, 0.0, 0.0}};
  network.joints.push_back(joint);
  return network;
}

TEST(Document, ReopensASavedReviewWithItsHistory) {
  Document document = Document::fromNetwork(twoPipesAndAJoint(), temporaryPath("review.json"));
  EditContext context;
  document.project().edits.apply(*parseEdit({"joint", "3", "reject"}), context);
  document.project().edits.apply(*parseEdit({"pipe", "2", "delete"}), context);
  ASSERT_EQ(document.network().runs.size(), 1u);  // Pipe 2 left pipe 1's run with the joint.
  const auto path = temporaryPath("review.piperun");
  saveProject(path, document.project());

  Document reopened = Document::open(path);
  EXPECT_EQ(reopened.path(), path);
  EXPECT_FALSE(reopened.hasPipeline());
  EXPECT_FALSE(reopened.freshThrough());
  EXPECT_TRUE(reopened.warnings().empty());
  EXPECT_FALSE(reopened.newerAutosave());
  EXPECT_EQ(reopened.network().findJoint(3)->status, JointStatus::Rejected);
  EXPECT_EQ(reopened.network().findPipe(2)->status, PipeStatus::Deleted);
  ASSERT_EQ(reopened.project().edits.position(), 2u);
  reopened.project().edits.undo();
  EXPECT_EQ(reopened.network().findPipe(2)->status, PipeStatus::Accepted);
  std::filesystem::remove(path);
}

TEST(Document, ProjectWithItsScanRecomputesTheStagesThatWereFresh) {
  const auto scan = writeSmallScan("project_scan.ply");
  Document document = Document::open(scan);
  Project& project = document.project();
  project.params.placement.centerBandwidth = 0.02;
  project.freshStages = {true, true, false, false, false, false};
  const auto path = temporaryPath("scan.piperun");
  saveProject(path, project);

  const Document reopened = Document::open(path);
  ASSERT_TRUE(reopened.hasPipeline());
  EXPECT_EQ(reopened.input()->size(), 3u);
  EXPECT_EQ(reopened.pipeline()->params().placement.centerBandwidth, 0.02);
  EXPECT_EQ(reopened.freshThrough(), Stage::Directions);
  EXPECT_TRUE(reopened.warnings().empty());
  std::filesystem::remove(path);
  std::filesystem::remove(scan);
}

TEST(Document, AScanInMillimetresIsReadAsMetresAndItsProjectKeepsTheUnit) {
  // The small scan written in millimetres: read as metres its points lie 5 m apart.
  PointCloud cloud;
  PointChunk chunk;
  chunk.positions = {{1000.0, 2000.0, 3000.0}, {1005.0, 2000.0, 3000.0}, {1000.0, 2005.0, 3000.0}};
  cloud.append(chunk);
  const auto scan = temporaryPath("scan_mm.ply");
  writePointCloud(scan, cloud);

  const Document asMetres = Document::open(scan);
  ASSERT_EQ(asMetres.warnings().size(), 1u);
  EXPECT_NE(asMetres.warnings()[0].find("give their unit with --units"), std::string::npos) << asMetres.warnings()[0];

  Document document = Document::open(scan, Progress::none(), "mm");
  EXPECT_TRUE(document.warnings().empty());
  EXPECT_TRUE(document.input()->worldPosition(1).isApprox(Eigen::Vector3d(1.005, 2.0, 3.0), 1e-6));
  EXPECT_EQ(document.project().scanUnits, "mm");
  const auto path = temporaryPath("scan_mm.piperun");
  saveProject(path, document.project());

  const Document reopened = Document::open(path);
  EXPECT_TRUE(reopened.warnings().empty());
  EXPECT_TRUE(reopened.input()->worldPosition(2).isApprox(Eigen::Vector3d(1.0, 2.005, 3.0), 1e-6));
  EXPECT_THROW(Document::open(scan, Progress::none(), "furlong"), InputError);
  std::filesystem::remove(path);
  std::filesystem::remove(scan);
}

TEST(Document, TheUpAxisGivenOrRecordedIsTheDocumentsAndItsProjectKeepsIt) {
  // A scan opened with y up: its pipeline's parameter, recorded by its project and read back.
  const auto scan = writeSmallScan("scan_up.ply");
  EXPECT_EQ(Document::open(scan).pipeline()->params().up, UpAxis::PlusZ);
  Document document = Document::open(scan, Progress::none(), "", UpAxis::PlusY);
  EXPECT_EQ(document.pipeline()->params().up, UpAxis::PlusY);
  EXPECT_EQ(document.project().params.up, UpAxis::PlusY);
  const auto project = temporaryPath("scan_up.piperun");
  saveProject(project, document.project());
  EXPECT_EQ(Document::open(project, Progress::none(), "", UpAxis::MinusX).project().params.up, UpAxis::PlusY);

  // A network takes the axis `piperun reconstruct --up` recorded, unless one is given.
  const auto network = temporaryPath("network_up.json");
  writeNetwork(network, PipeNetwork{}, {{"up", "-y"}});
  EXPECT_EQ(Document::open(network).project().params.up, UpAxis::MinusY);
  EXPECT_EQ(Document::open(network, Progress::none(), "", UpAxis::PlusX).project().params.up, UpAxis::PlusX);
  writeNetwork(network, PipeNetwork{}, {{"up", "north"}});
  EXPECT_THROW(Document::open(network), InputError);
  for (const auto& path : {scan, project, network}) std::filesystem::remove(path);
}

TEST(Document, UnreadableFileIsAnInputError) {
  EXPECT_THROW(Document::open(temporaryPath("missing.ply")), InputError);
  EXPECT_THROW(Document::open(temporaryPath("missing.json")), InputError);
  EXPECT_THROW(Document::open(temporaryPath("missing.piperun")), InputError);
}

}  // namespace
}  // namespace piperun::ui
