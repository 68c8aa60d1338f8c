#include "point_measures.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

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


TEST(StrayPoints, AreThePointsWithFewNeighboursAndTheInvalidOnes) {
  PointChunk chunk;
  for (int i = 0; i <= 100; ++i)
    for (int j = 0; j <= 100; ++j) chunk.positions.push_back({0.01 * i, 0.01 * j, 0.0});  // A 1 m wall.
  const std::size_t wall = chunk.positions.size();
  for (int k = 0; k < 5; ++k) chunk.positions.push_back({0.5 * k, 3.0, 2.0});  // Alone in the air.
  chunk.positions.push_back({0.0, 5.0, 1.0});  // A pair.
  chunk.positions.push_back({0.01, 5.0, 1.0});
  chunk.positions.push_back(Eigen::Vector3d::Constant(std::nan("")));
  PointCloud cloud;
  cloud.append(chunk);

  const std::vector<bool> stray = strayPoints(cloud, 0.05, 2);
  EXPECT_EQ(std::count(stray.begin(), stray.begin() + static_cast<std::ptrdiff_t>(wall), true), 0);
  for (std::size_t k = wall; k < cloud.size(); ++k) EXPECT_TRUE(stray[k]) << k;
  // With one neighbour enough, the pair stays.
  const std::vector<bool> lenient = strayPoints(cloud, 0.05, 1);
  EXPECT_FALSE(lenient[wall + 5]);
  EXPECT_FALSE(lenient[wall + 6]);
  EXPECT_TRUE(lenient[wall]);
}

/// A 10 m x 10 m room: a floor of points every 2 cm at z = 0 and four walls of points every 10 cm.
PointChunk roomPoints(double wallHeight) {
  PointChunk chunk;
  for (int i = 0; i <= 500; ++i)
    for (int j = 0; j <= 500; ++j) chunk.positions.push_back({0.02 * i, 0.02 * j, 0.0});
  for (int i = 0; i <= 100; ++i)
    for (int k = 1; 0.1 * k <= wallHeight; ++k)
      for (const Eigen::Vector3d& point : {Eigen::Vector3d(0.1 * i, 0.0, 0.1 * k), Eigen::Vector3d(0.1 * i, 10.0, 0.1 * k),
                                           Eigen::Vector3d(0.0, 0.1 * i, 0.1 * k), Eigen::Vector3d(10.0, 0.1 * i, 0.1 * k)})
        chunk.positions.push_back(point);
  return chunk;
}

PipeNetwork pipeAtHeight(double z) {
  PipeNetwork network;
  Pipe pipe;
  pipe.id = 1;
  pipe.radius = 0.1;
  pipe.start = {2.0, 5.0, z};
  pipe.end = {8.0, 5.0, z};
  network.pipes.push_back(pipe);
  return network;
}

TEST(CeilingHeight, IsALittleOverTheNetworkUnderARoof) {
  PointChunk chunk = roomPoints(4.0);
  for (int i = 0; i <= 500; ++i)
    for (int j = 0; j <= 500; ++j) chunk.positions.push_back({0.02 * i, 0.02 * j, 4.0});
  chunk.positions.push_back(Eigen::Vector3d::Constant(std::nan("")));  // Readers may keep invalid points.
  PointCloud cloud;
  cloud.append(chunk);
  const auto height = ceilingHeight(cloud, pipeAtHeight(2.0), UpAxis::PlusZ);
  ASSERT_TRUE(height.has_value());
  EXPECT_NEAR(*height, 2.0 + 0.1 + kCeilingMargin, 1e-9);  // The pipe's top and the margin.
  EXPECT_FALSE(ceilingHeight(cloud, pipeAtHeight(3.9), UpAxis::PlusZ).has_value());  // Nothing but the roof's edge above 4.25 m.
  EXPECT_FALSE(ceilingHeight(cloud, PipeNetwork{}, UpAxis::PlusZ).has_value());
}

TEST(CeilingHeight, IsMeasuredAlongTheUpAxis) {
  // The roofed room and its pipe turned so that each axis is up: the same height along it.
  PointChunk room = roomPoints(4.0);
  for (int i = 0; i <= 500; ++i)
    for (int j = 0; j <= 500; ++j) room.positions.push_back({0.02 * i, 0.02 * j, 4.0});
  for (const std::string& name : upAxisNames()) {
    const UpAxis up = upAxisFromString(name);
    const Eigen::Matrix3d turn = turnZUpTo(up);
    PointChunk turned = room;
    for (Eigen::Vector3d& p : turned.positions) p = turn * p;
    PointCloud cloud;
    cloud.append(turned);
    PipeNetwork network = pipeAtHeight(2.0);
    network.pipes[0].start = turn * network.pipes[0].start;
    network.pipes[0].end = turn * network.pipes[0].end;
    const auto height = ceilingHeight(cloud, network, up);
    ASSERT_TRUE(height.has_value()) << name;
    EXPECT_NEAR(*height, 2.0 + 0.1 + kCeilingMargin, 1e-9) << name;
    EXPECT_NEAR(heightAlong(up, turn * Eigen::Vector3d(1, 2, 3)), 3.0, 1e-12) << name;
  }
}

TEST(CeilingHeight, WallsAndScatteredOutliersAreNoCeiling) {
  PointChunk chunk = roomPoints(4.0);
  std::mt19937 random(7);
  std::uniform_real_distribution<double> across(0.0, 10.0), up(0.0, 4.0);
  // 2 % outliers through the room: above the pipe, one or more in most cells of the footprint.
  const std::size_t surfacePoints = chunk.positions.size();
  for (std::size_t i = 0; i < surfacePoints / 50; ++i)
    chunk.positions.push_back({across(random), across(random), up(random)});
  PointCloud cloud;
  cloud.append(chunk);
  EXPECT_FALSE(ceilingHeight(cloud, pipeAtHeight(2.0), UpAxis::PlusZ).has_value());
}

}  // namespace
}  // namespace piperun::ui
