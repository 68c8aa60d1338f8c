#include "point_measures.h"

#include <gtest/gtest.h>

#include <cmath>

namespace piperun::ui {
namespace {

TEST(SurfaceDistances, MeasuresFromThePipeSurfaceAndNamesThePipe) {
  PipeNetwork network;
  Pipe pipe;
  pipe.id = 7;
  pipe.radius = 0.1;
  pipe.start = {100.0, 0.0, 0.0};
  pipe.end = {102.0, 0.0, 0.0};
  network.pipes.push_back(pipe);

  PointCloud cloud;
  PointChunk chunk;
  chunk.positions = {{101.0, 0.0, 0.105}, {101.0, 0.098, 0.0}, {101.0, 0.0, 0.5}};
  cloud.append(chunk);

  const SurfaceDistances result = surfaceDistances(cloud, network, 0.02);
  EXPECT_NEAR(result.distance[0], 0.005, 1e-5);
  EXPECT_NEAR(result.distance[1], 0.002, 1e-5);
  EXPECT_EQ(result.element[0], 7);
  EXPECT_EQ(result.element[1], 7);
  EXPECT_TRUE(std::isinf(result.distance[2]));  // Beyond the reach.
  EXPECT_EQ(result.element[2], -1);
}

TEST(NearestKeptPoint, FindsTheClosestKeptPointWithinReach) {
  PointCloud input, kept;
  PointChunk chunk;
  chunk.positions = {{0.0, 0.0, 0.0}, {1.0, 0.0, 0.0}, {5.0, 5.0, 5.0}};
  input.append(chunk);
  chunk.positions = {{1.004, 0.0, 0.0}, {0.003, 0.0, 0.0}, {0.0, 0.009, 0.0}};
  kept.append(chunk);

  const std::vector<int> nearest = nearestKeptPoint(input, kept, 0.02);
  EXPECT_EQ(nearest, (std::vector<int>{1, 0, -1}));
}

}  // namespace
}  // namespace piperun::ui
