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
  PointCloud cloud;
  PointChunk chunk;
  chunk.positions = {{1.0, 2.0, 3.0}, {1.5, 2.0, 3.0}, {1.0, 2.5, 3.0}};
  cloud.append(chunk);
  const auto path = temporaryPath("scan.ply");
  writePointCloud(path, cloud);

  const Document document = Document::open(path);
  ASSERT_TRUE(document.hasPipeline());
  ASSERT_TRUE(document.input());
  EXPECT_EQ(document.input()->size(), 3u);
  for (Stage stage : kAllStages) EXPECT_FALSE(document.pipeline()->isFresh(stage)) << stageName(stage);
  EXPECT_TRUE(document.network().pipes.empty());
  std::filesystem::remove(path);
}

TEST(Document, UnreadableFileIsAnInputError) {
  EXPECT_THROW(Document::open(temporaryPath("missing.ply")), InputError);
  EXPECT_THROW(Document::open(temporaryPath("missing.json")), InputError);
}

}  // namespace
}  // namespace piperun::ui
