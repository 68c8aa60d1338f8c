#include "piperun/error.h"
#include "piperun/eval/evaluation.h"
#include "piperun/io/network_io.h"
#include "piperun/pipeline.h"
#include "piperun/synth/scene_generator.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <atomic>
#include <thread>

namespace piperun {
namespace {

// One small generated scene shared by the tests (generation costs more than a test should).
const GeneratedScene& scene() {
  static const GeneratedScene generated = [] {
    SceneParams params;
    params.seed = 11;
    params.densityScale = 0.5;
    return generateScene(params);
  }();
  return generated;
}

std::shared_ptr<const PointCloud> sceneCloud() {
  static const auto cloud = std::make_shared<const PointCloud>(scene().cloud.clone());
  return cloud;
}

TEST(Pipeline, RunsEveryStageAndFindsPipes) {
  Pipeline pipeline(sceneCloud());
  for (Stage stage : kAllStages) EXPECT_FALSE(pipeline.isFresh(stage));
  pipeline.run();
  for (Stage stage : kAllStages) EXPECT_TRUE(pipeline.isFresh(stage)) << stageName(stage);
  const PipeNetwork network = pipeline.network();
  EXPECT_NO_THROW(network.validate());
  ASSERT_GT(network.pipes.size(), 3u);
  const EvaluationResult figures = evaluateNetwork(scene().truth, network);
  EXPECT_GT(figures.precision, 0.7) << formatEvaluation(figures);
  EXPECT_GT(figures.recall, 0.5) << formatEvaluation(figures);
}

TEST(Pipeline, ChangingAStageMarksItAndLaterStagesStale) {
  Pipeline pipeline(sceneCloud());
  pipeline.run();
  const auto preprocessed = pipeline.preprocessResult();
  PipelineParams params = pipeline.params();
  params.extents.minArcDeg += 5.0;
  pipeline.setParams(params);
  EXPECT_TRUE(pipeline.isFresh(Stage::Preprocess));
  EXPECT_TRUE(pipeline.isFresh(Stage::Placement));
  EXPECT_FALSE(pipeline.isFresh(Stage::Extents));
  EXPECT_FALSE(pipeline.isFresh(Stage::Merge));
  pipeline.run();
  EXPECT_TRUE(pipeline.isFresh(Stage::Merge));
  EXPECT_EQ(pipeline.preprocessResult(), preprocessed);  // not recomputed

  params.placement.minInliers += 10;
  pipeline.setParams(params);
  EXPECT_TRUE(pipeline.isFresh(Stage::Directions));
  EXPECT_FALSE(pipeline.isFresh(Stage::Placement));
  // A stale stage keeps showing its previous result until it runs again.
  EXPECT_NE(pipeline.mergeResult(), nullptr);
}

TEST(Pipeline, RunUntilAStageLeavesTheRestStale) {
  Pipeline pipeline(sceneCloud());
  pipeline.run(Progress::none(), Stage::Directions);
  EXPECT_TRUE(pipeline.isFresh(Stage::Directions));
  EXPECT_FALSE(pipeline.isFresh(Stage::Placement));
  EXPECT_EQ(pipeline.mergeResult(), nullptr);
  ASSERT_NE(pipeline.tileResults(), nullptr);
  std::size_t directions = 0;
  for (const auto& tile : *pipeline.tileResults()) directions += tile.rounds.at(0).directions.directions.size();
  EXPECT_GT(directions, 0u);
  pipeline.run();
  EXPECT_TRUE(pipeline.isFresh(Stage::Merge));
}

TEST(Pipeline, CancelFromAnotherThreadStops) {
  Pipeline pipeline(sceneCloud());
  std::atomic<bool> started{false};
  Progress progress([&](const std::string&, double) { started = true; });
  std::thread canceller([&] {
    while (!started) std::this_thread::yield();
    progress.cancel();
  });
  EXPECT_THROW(pipeline.run(progress), Cancelled);
  canceller.join();
  EXPECT_FALSE(pipeline.isFresh(Stage::Merge));
  // A new progress runs to the end.
  pipeline.run();
  EXPECT_TRUE(pipeline.isFresh(Stage::Merge));
}

TEST(Pipeline, CancelDuringTheTilesKeepsThePreprocessedPoints) {
  Pipeline pipeline(sceneCloud());
  Progress progress([&](const std::string& task, double) {
    if (task == "tiles") progress.cancel();
  });
  EXPECT_THROW(pipeline.run(progress), Cancelled);
  EXPECT_TRUE(pipeline.isFresh(Stage::Preprocess));
  EXPECT_FALSE(pipeline.isFresh(Stage::Merge));
  const auto preprocessed = pipeline.preprocessResult();
  pipeline.run();
  EXPECT_EQ(pipeline.preprocessResult(), preprocessed);
  EXPECT_TRUE(pipeline.isFresh(Stage::Merge));
}

TEST(Pipeline, SameNetworkForOneAndTwoThreads) {
  std::string one, two;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    Pipeline pipeline(sceneCloud());
    pipeline.run();
    one = networkToJson(pipeline.network());
  }
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    Pipeline pipeline(sceneCloud());
    pipeline.run();
    two = networkToJson(pipeline.network());
  }
  EXPECT_EQ(one, two);
}

TEST(Pipeline, SeedChangesOnlyWhatIsRandom) {
  PipelineParams params;
  params.seed = 99;
  Pipeline a(sceneCloud(), params);
  Pipeline b(sceneCloud(), params);
  a.run();
  b.run();
  EXPECT_EQ(networkToJson(a.network()), networkToJson(b.network()));
}

}  // namespace
}  // namespace piperun
