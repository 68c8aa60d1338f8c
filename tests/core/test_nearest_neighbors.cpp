#include "nearest_neighbors.h"

#include "piperun/error.h"
#include "piperun/progress.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <random>
#include <utility>
#include <vector>

namespace piperun {
namespace {

/// Every point's k nearest by brute force, sorted by (squared distance, index), itself left out.
std::vector<std::uint32_t> bruteForceLists(const std::vector<Eigen::Vector3f>& positions, std::size_t k) {
  std::vector<std::uint32_t> lists;
  std::vector<std::pair<float, std::uint32_t>> scored;
  for (std::size_t i = 0; i < positions.size(); ++i) {
    scored.clear();
    for (std::size_t j = 0; j < positions.size(); ++j) {
      if (j != i) scored.emplace_back((positions[j] - positions[i]).squaredNorm(), static_cast<std::uint32_t>(j));
    }
    std::partial_sort(scored.begin(), scored.begin() + static_cast<std::ptrdiff_t>(k), scored.end());
    for (std::size_t j = 0; j < k; ++j) lists.push_back(scored[j].second);
  }
  return lists;
}

/// A scan-like cloud: a dense curved sheet, a sparse far patch, exact duplicates and scattered
/// outliers, so every level of the search is exercised.
std::vector<Eigen::Vector3f> mixedCloud(std::uint32_t seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::normal_distribution<float> noise(0.0f, 0.001f);
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < 2500; ++i) {  // a quarter cylinder of 0.3 m radius, 1 m long, 1 cm spacing
    const float angle = 1.57f * unit(random), along = unit(random);
    points.emplace_back(along, 0.3f * std::cos(angle) + noise(random), 0.3f * std::sin(angle) + noise(random));
  }
  for (int i = 0; i < 300; ++i) points.emplace_back(3.0f + unit(random), 2.0f + unit(random), 0.0f);  // 6 cm spacing
  for (int i = 0; i < 50; ++i) points.push_back(points[static_cast<std::size_t>(i) * 7]);             // duplicates
  for (int i = 0; i < 40; ++i) points.emplace_back(5.0f * unit(random), 4.0f * unit(random), 3.0f * unit(random));
  return points;
}

TEST(NearestNeighbors, ListsMatchBruteForceWhateverTheCellSize) {
  const std::vector<Eigen::Vector3f> points = mixedCloud(7);
  const std::vector<std::uint32_t> expected = bruteForceLists(points, 16);
  // The spacing only sizes the cells: far too small or too large, the lists stay exact.
  for (const double spacing : {0.01, 0.0005, 0.5, 10.0}) {
    const NeighborLists lists = findNearestNeighbors(points, 16, 8, spacing, Progress::none(), "test", 0.0, 1.0);
    ASSERT_EQ(lists.k, 16);
    EXPECT_EQ(lists.indices, expected) << "spacing " << spacing;
  }
}

TEST(NearestNeighbors, MeanDistanceIsOverTheFirstNeighbours) {
  const std::vector<Eigen::Vector3f> points = mixedCloud(11);
  const NeighborLists lists = findNearestNeighbors(points, 16, 5, 0.01, Progress::none(), "test", 0.0, 1.0);
  ASSERT_EQ(lists.meanDistance.size(), points.size());
  for (std::size_t i = 0; i < points.size(); i += 37) {
    float sum = 0.0f;
    for (std::size_t j = 0; j < 5; ++j) sum += (points[lists.indices[i * 16 + j]] - points[i]).norm();
    EXPECT_NEAR(lists.meanDistance[i], sum / 5.0f, 1e-6f) << "point " << i;
  }
}

TEST(NearestNeighbors, SameListsWithOneAndTwoThreads) {
  std::vector<Eigen::Vector3f> points = mixedCloud(3);
  // Many exact ties (a lattice) make the order of equal distances matter.
  for (int x = 0; x < 30; ++x) {
    for (int y = 0; y < 30; ++y) points.emplace_back(10.0f + 0.01f * static_cast<float>(x), 0.01f * static_cast<float>(y), 0.0f);
  }
  NeighborLists one, two;
  {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one = findNearestNeighbors(points, 16, 8, 0.01, Progress::none(), "test", 0.0, 1.0);
  }
  {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    two = findNearestNeighbors(points, 16, 8, 0.01, Progress::none(), "test", 0.0, 1.0);
  }
  EXPECT_EQ(one.indices, two.indices);
  EXPECT_EQ(one.meanDistance, two.meanDistance);
  EXPECT_EQ(one.indices, bruteForceLists(points, 16));
}

TEST(NearestNeighbors, SmallCloudsAskForAtMostTheOtherPoints) {
  const std::vector<Eigen::Vector3f> three = {{0, 0, 0}, {1, 0, 0}, {0, 3, 0}};
  const NeighborLists lists = findNearestNeighbors(three, 16, 8, 0.01, Progress::none(), "test", 0.0, 1.0);
  EXPECT_EQ(lists.k, 2);
  EXPECT_EQ(lists.meanOf, 2);
  EXPECT_EQ(lists.indices, (std::vector<std::uint32_t>{1, 2, 0, 2, 0, 1}));
  EXPECT_FLOAT_EQ(lists.meanDistance[2], 0.5f * (3.0f + std::sqrt(10.0f)));

  const std::vector<Eigen::Vector3f> same(5, Eigen::Vector3f(1, 2, 3));  // all points coincide
  const NeighborLists coincident = findNearestNeighbors(same, 3, 0, 0.01, Progress::none(), "test", 0.0, 1.0);
  EXPECT_EQ(coincident.indices, (std::vector<std::uint32_t>{1, 2, 3, 0, 2, 3, 0, 1, 3, 0, 1, 2, 0, 1, 2}));
  EXPECT_TRUE(coincident.meanDistance.empty());

  EXPECT_TRUE(findNearestNeighbors({{0, 0, 0}}, 16, 8, 0.01, Progress::none(), "test", 0.0, 1.0).indices.empty());
}

TEST(NearestNeighbors, RefusesNonFinitePositions) {
  std::vector<Eigen::Vector3f> points = mixedCloud(3);
  points[17] = Eigen::Vector3f(std::nanf(""), 0.0f, 0.0f);
  EXPECT_THROW(findNearestNeighbors(points, 16, 8, 0.01, Progress::none(), "test", 0.0, 1.0), std::invalid_argument);
  points[17] = Eigen::Vector3f(std::numeric_limits<float>::infinity(), 0.0f, 0.0f);
  EXPECT_THROW(findNearestNeighbors(points, 16, 8, 0.01, Progress::none(), "test", 0.0, 1.0), std::invalid_argument);
}

TEST(NearestNeighbors, ReportsProgressAndCanBeCancelled) {
  const std::vector<Eigen::Vector3f> points = mixedCloud(5);
  double last = -1.0;
  Progress progress([&](const std::string& task, double fraction) {
    EXPECT_EQ(task, "search");
    EXPECT_GE(fraction, 0.2);
    EXPECT_LE(fraction, 0.6 + 1e-12);
    last = fraction;
  });
  findNearestNeighbors(points, 16, 8, 0.01, progress, "search", 0.2, 0.6);
  EXPECT_NEAR(last, 0.6, 1e-9);

  Progress cancelled;
  cancelled.cancel();
  EXPECT_THROW(findNearestNeighbors(points, 16, 8, 0.01, cancelled, "search", 0.0, 1.0), Cancelled);
}

}  // namespace
}  // namespace piperun
