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

/// Every point's list as visited, k per point in point order, with their squared distances.
struct VisitedLists {
  int k = 0;
  std::vector<std::uint32_t> indices;
  std::vector<float> squaredDistances;
  std::vector<int> visits;  ///< Times each point was visited.
};

VisitedLists visitAll(const std::vector<Eigen::Vector3f>& points, int k, double spacing, Progress& progress,
                      const char* task = "test", double from = 0.0, double to = 1.0) {
  VisitedLists lists;
  lists.k = neighborListSize(points.size(), k);
  const auto size = static_cast<std::size_t>(lists.k);
  lists.indices.resize(points.size() * size);
  lists.squaredDistances.resize(points.size() * size);
  lists.visits.resize(points.size());
  visitNearestNeighbors(points, k, spacing, progress, task, from, to,
                        [&](std::uint32_t point, const std::uint32_t* neighbors, const float* squaredDistances) {
                          std::copy_n(neighbors, size, lists.indices.begin() + static_cast<std::ptrdiff_t>(point * size));
                          std::copy_n(squaredDistances, size,
                                      lists.squaredDistances.begin() + static_cast<std::ptrdiff_t>(point * size));
                          ++lists.visits[point];  // each point is visited by one thread, once
                        });
  return lists;
}

VisitedLists visitAll(const std::vector<Eigen::Vector3f>& points, int k, double spacing) {
  return visitAll(points, k, spacing, Progress::none());
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
    const VisitedLists lists = visitAll(points, 16, spacing);
    ASSERT_EQ(lists.k, 16);
    EXPECT_EQ(lists.indices, expected) << "spacing " << spacing;
    EXPECT_EQ(lists.visits, std::vector<int>(points.size(), 1)) << "spacing " << spacing;
  }
}

TEST(NearestNeighbors, SquaredDistancesAreThoseOfTheListedPoints) {
  const std::vector<Eigen::Vector3f> points = mixedCloud(11);
  const VisitedLists lists = visitAll(points, 8, 0.01);
  ASSERT_EQ(lists.k, 8);
  for (std::size_t i = 0; i < points.size(); ++i) {
    for (std::size_t j = 0; j < 8; ++j) {
      const std::uint32_t neighbor = lists.indices[i * 8 + j];
      ASSERT_NEAR(lists.squaredDistances[i * 8 + j], (points[neighbor] - points[i]).squaredNorm(), 1e-6f)
          << "point " << i << ", neighbour " << j;
      if (j > 0) {
        ASSERT_LE(lists.squaredDistances[i * 8 + j - 1], lists.squaredDistances[i * 8 + j]);
      }
    }
  }
}

TEST(NearestNeighbors, SameListsWithOneAndTwoThreads) {
  std::vector<Eigen::Vector3f> points = mixedCloud(3);
  // Many exact ties (a lattice) make the order of equal distances matter.
  for (int x = 0; x < 30; ++x) {
    for (int y = 0; y < 30; ++y) points.emplace_back(10.0f + 0.01f * static_cast<float>(x), 0.01f * static_cast<float>(y), 0.0f);
  }
  VisitedLists one, two;
  {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one = visitAll(points, 16, 0.01);
  }
  {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    two = visitAll(points, 16, 0.01);
  }
  EXPECT_EQ(one.indices, two.indices);
  EXPECT_EQ(one.squaredDistances, two.squaredDistances);
  EXPECT_EQ(one.indices, bruteForceLists(points, 16));
}

TEST(NearestNeighbors, SmallCloudsAskForAtMostTheOtherPoints) {
  const std::vector<Eigen::Vector3f> three = {{0, 0, 0}, {1, 0, 0}, {0, 3, 0}};
  const VisitedLists lists = visitAll(three, 16, 0.01);
  EXPECT_EQ(lists.k, 2);
  EXPECT_EQ(lists.indices, (std::vector<std::uint32_t>{1, 2, 0, 2, 0, 1}));
  EXPECT_EQ(lists.squaredDistances, (std::vector<float>{1, 9, 1, 10, 9, 10}));

  const std::vector<Eigen::Vector3f> same(5, Eigen::Vector3f(1, 2, 3));  // all points coincide
  const VisitedLists coincident = visitAll(same, 3, 0.01);
  EXPECT_EQ(coincident.indices, (std::vector<std::uint32_t>{1, 2, 3, 0, 2, 3, 0, 1, 3, 0, 1, 2, 0, 1, 2}));

  const VisitedLists single = visitAll({{0, 0, 0}}, 16, 0.01);
  EXPECT_EQ(single.k, 0);
  EXPECT_EQ(single.visits, std::vector<int>{0});
  EXPECT_EQ(neighborListSize(0, 16), 0);
  EXPECT_EQ(neighborListSize(20, 0), 0);
}

TEST(NearestNeighbors, RefusesNonFinitePositions) {
  std::vector<Eigen::Vector3f> points = mixedCloud(3);
  points[17] = Eigen::Vector3f(std::nanf(""), 0.0f, 0.0f);
  EXPECT_THROW(visitAll(points, 16, 0.01), std::invalid_argument);
  points[17] = Eigen::Vector3f(std::numeric_limits<float>::infinity(), 0.0f, 0.0f);
  EXPECT_THROW(visitAll(points, 16, 0.01), std::invalid_argument);
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
  visitAll(points, 16, 0.01, progress, "search", 0.2, 0.6);
  EXPECT_NEAR(last, 0.6, 1e-9);

  Progress cancelled;
  cancelled.cancel();
  EXPECT_THROW(visitAll(points, 16, 0.01, cancelled, "search"), Cancelled);
}

}  // namespace
}  // namespace piperun
