#include "points_near.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <iterator>
#include <random>
#include <utility>
#include <vector>

namespace piperun {
namespace {

/// Random points in a 6 m box around the origin, some of them negative on every axis.
PointCloud randomCloud(std::size_t count, std::uint32_t seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<float> coordinate(-3.0F, 3.0F);
  PointCloud cloud;
  for (std::size_t i = 0; i < count; ++i) cloud.positions.emplace_back(coordinate(random), coordinate(random), coordinate(random));
  return cloud;
}

/// The points within `reach` of the segment from a to b, by looking at every point.
std::vector<std::uint32_t> nearByEveryPoint(const PointCloud& cloud, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                            double reach) {
  std::vector<std::uint32_t> near;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (pointSegmentDistance(cloud.positions[i].cast<double>(), a, b) <= reach) near.push_back(static_cast<std::uint32_t>(i));
  }
  return near;
}

TEST(PointsNear, ACubeVisitsItsCellsPayloadsInCellOrderWhateverItsSize) {
  // A few pipes' worth of payloads in a grid of 0.25 m cells, some cells holding several.
  HashGrid grid(0.25);
  std::mt19937 random(11);
  std::uniform_int_distribution<int> coordinate(-12, 12);
  for (std::uint32_t value = 0; value < 60; ++value) {
    grid.insert(Eigen::Vector3i(coordinate(random), coordinate(random), coordinate(random)), value);
  }
  // Every cell of the cube in x, y, z order, as a cell-by-cell walk gives them.
  const auto expected = [&](const Eigen::Vector3d& p, double reach) {
    std::vector<std::uint32_t> values;
    grid.forEachCellInCube(p, reach, [&](const Eigen::Vector3i& cell) {
      if (const auto* bucket = grid.find(cell)) values.insert(values.end(), bucket->begin(), bucket->end());
    });
    return values;
  };
  // A cube of fewer cells than the grid fills, and cubes of far more (read from the filled cells).
  for (const double reach : {0.3, 2.0, 5.0}) {
    const Eigen::Vector3d p(0.4, -0.7, 0.1);
    std::vector<std::uint32_t> visited;
    grid.forEachInCube(p, reach, [&](std::uint32_t value) { visited.push_back(value); });
    EXPECT_EQ(visited, expected(p, reach)) << "reach " << reach;
    if (reach == 5.0) {
      EXPECT_EQ(visited.size(), 60U);
    }
  }
}

TEST(PointsNear, ASegmentFindsEveryPointWithinItsReachAndNoOther) {
  const PointCloud cloud = randomCloud(20000, 7);
  const PointCells cells(cloud, 0.25);
  struct Case {
    Eigen::Vector3d a, b;
    double reach;
  };
  // Diagonal and axis-aligned, reaching wider and narrower than a cell, a point, and one past the
  // points' box.
  const std::vector<Case> cases = {
      {{-2.5, -2.0, -1.0}, {2.0, 2.5, 1.5}, 0.1},  {{-2.5, -2.0, -1.0}, {2.0, 2.5, 1.5}, 0.6},
      {{0.0, -3.0, 0.3}, {0.0, 3.0, 0.3}, 0.05},   {{1.1, 1.1, 1.1}, {1.1, 1.1, 1.1}, 0.4},
      {{2.5, 2.5, 2.5}, {4.0, 2.5, 2.5}, 0.7},     {{-0.13, 0.2, -0.26}, {-0.12, 0.21, -0.24}, 0.3},
  };
  for (const Case& c : cases) {
    const auto expected = nearByEveryPoint(cloud, c.a, c.b, c.reach);
    ASSERT_FALSE(expected.empty());
    EXPECT_EQ(pointsNearSegment(cells, c.a, c.b, c.reach, [](std::size_t) { return true; }), expected);
    // Only the points `keep` accepts.
    std::vector<std::uint32_t> even;
    std::copy_if(expected.begin(), expected.end(), std::back_inserter(even), [](std::uint32_t i) { return i % 2 == 0; });
    EXPECT_EQ(pointsNearSegment(cells, c.a, c.b, c.reach, [](std::size_t i) { return i % 2 == 0; }), even);
  }
}

TEST(PointsNear, SpheresHoldTheirPointsInIndexOrder) {
  const PointCloud cloud = randomCloud(5000, 3);
  // One sphere reaching past the points' box, one holding none of them.
  const std::vector<std::pair<Eigen::Vector3d, double>> spheres = {{{0.0, 0.0, 0.0}, 0.5},
                                                                    {{2.9, -2.9, 0.0}, 0.8},
                                                                    {{0.2, 0.1, 0.0}, 0.3},
                                                                    {{9.0, 9.0, 9.0}, 0.5}};
  const auto keep = [](std::size_t i) { return i % 3 != 0; };
  const auto inside = pointsInSpheres(cloud, spheres, 0.25, keep);
  // The same from the cloud filed by cells once.
  EXPECT_EQ(pointsInSpheres(PointCells(cloud, 0.25), spheres, keep), inside);
  ASSERT_EQ(inside.size(), spheres.size());
  EXPECT_TRUE(inside.back().empty());
  for (std::size_t s = 0; s + 1 < spheres.size(); ++s) {
    std::vector<std::uint32_t> expected;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      if (i % 3 != 0 && (cloud.positions[i].cast<double>() - spheres[s].first).norm() <= spheres[s].second) {
        expected.push_back(static_cast<std::uint32_t>(i));
      }
    }
    ASSERT_FALSE(expected.empty());
    EXPECT_EQ(inside[s], expected);
  }
}

}  // namespace
}  // namespace piperun
