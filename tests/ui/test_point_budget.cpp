#include "point_budget.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>

namespace piperun::ui {
namespace {

/// `count` points spread evenly at random over the box [0, size]^3.
std::vector<Eigen::Vector3f> randomPoints(std::size_t count, float size, unsigned seed = 3) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<float> coordinate(0.0f, size);
  std::vector<Eigen::Vector3f> points(count);
  for (auto& p : points) p = {coordinate(random), coordinate(random), coordinate(random)};
  return points;
}

std::size_t sum(const std::vector<std::uint32_t>& counts) {
  return std::accumulate(counts.begin(), counts.end(), std::size_t{0});
}

std::uint32_t size(const PointCells::Cell& cell) { return cell.end - cell.begin; }

/// A camera at `eye` looking along +x with a 90-degree field both ways: its four side planes.
ViewVolume lookingAlongX(const Eigen::Vector3d& eye) {
  ViewVolume view;
  view.eye = eye;
  const Eigen::Vector3d normals[4] = {{1, 1, 0}, {1, -1, 0}, {1, 0, 1}, {1, 0, -1}};
  for (int side = 0; side < 4; ++side) {
    const Eigen::Vector3d n = normals[side].normalized();
    view.planes.emplace_back(n.x(), n.y(), n.z(), -n.dot(eye));
  }
  return view;
}

TEST(FilePointCells, FilesEveryFinitePointOnceInsideItsCellsBounds) {
  std::vector<Eigen::Vector3f> points = randomPoints(20000, 10.0f);
  points[5] = Eigen::Vector3f(std::numeric_limits<float>::quiet_NaN(), 1.0f, 1.0f);
  points[9] = Eigen::Vector3f(1.0f, std::numeric_limits<float>::infinity(), 1.0f);
  const PointCells filed = filePointCells(points);

  ASSERT_EQ(filed.order.size(), points.size() - 2);
  std::vector<int> seen(points.size(), 0);
  for (const auto& cell : filed.cells) {
    ASSERT_LT(cell.begin, cell.end);
    for (std::uint32_t i = cell.begin; i < cell.end; ++i) {
      const Eigen::Vector3f& p = points[filed.order[i]];
      EXPECT_TRUE((p.array() >= cell.min.array()).all() && (p.array() <= cell.max.array()).all());
      ++seen[filed.order[i]];
    }
  }
  EXPECT_EQ(seen[5], 0);
  EXPECT_EQ(seen[9], 0);
  seen[5] = seen[9] = 1;
  EXPECT_TRUE(std::all_of(seen.begin(), seen.end(), [](int times) { return times == 1; }));
  // 10 m / 128 is under the smallest cell, so the cells are 0.25 m: 40 across.
  EXPECT_LE(filed.cells.size(), 40u * 40u * 40u);
  EXPECT_GT(filed.cells.size(), 40u * 40u * 40u / 5);
}

TEST(FilePointCells, ACellsFirstPointsSpreadOverIt) {
  // One cell of points lying in index order along x: its first tenth must not be its first stretch.
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < 1000; ++i) points.emplace_back(0.0002f * static_cast<float>(i), 0.0f, 0.0f);
  const PointCells filed = filePointCells(points);
  ASSERT_EQ(filed.cells.size(), 1u);
  float low = 1.0f, high = 0.0f, mean = 0.0f;
  for (int i = 0; i < 100; ++i) {
    const float x = points[filed.order[static_cast<std::size_t>(i)]].x();
    low = std::min(low, x);
    high = std::max(high, x);
    mean += x / 100.0f;
  }
  EXPECT_LT(low, 0.02f);
  EXPECT_GT(high, 0.18f);
  EXPECT_NEAR(mean, 0.1f, 0.02f);
}

TEST(FilePointCells, SameOrderWhateverTheThreadCount) {
  const std::vector<Eigen::Vector3f> points = randomPoints(200000, 40.0f);
  const PointCells many = filePointCells(points);
  PointCells one;
  tbb::task_arena(1).execute([&] { one = filePointCells(points); });
  EXPECT_EQ(many.order, one.order);
  ASSERT_EQ(many.cells.size(), one.cells.size());
  for (std::size_t c = 0; c < many.cells.size(); ++c) EXPECT_EQ(many.cells[c].begin, one.cells[c].begin);
}

TEST(PointsToDraw, EveryPointWhenTheyFitTheBudget) {
  const PointCells filed = filePointCells(randomPoints(5000, 4.0f));
  const std::vector<std::uint32_t> counts = pointsToDraw(filed, nullptr, 5000);
  for (std::size_t c = 0; c < counts.size(); ++c) EXPECT_EQ(counts[c], size(filed.cells[c]));
}

TEST(PointsToDraw, WithoutAViewTheSameShareOfEveryCell) {
  const PointCells filed = filePointCells(randomPoints(100000, 4.0f));
  const std::vector<std::uint32_t> counts = pointsToDraw(filed, nullptr, 25000);
  const std::size_t drawn = sum(counts);
  EXPECT_LE(drawn, 25000u);
  EXPECT_GT(drawn, 24000u);
  const double share = static_cast<double>(drawn) / 100000.0;
  for (std::size_t c = 0; c < counts.size(); ++c)
    EXPECT_NEAR(counts[c], share * size(filed.cells[c]), 1.0) << "cell " << c;
}

TEST(PointsToDraw, OnlyCellsInViewAndTheNearOnesDensest) {
  // A 20 m cube, the eye at its middle of the low-x face looking along +x: the cells behind it
  // (x < 0 is empty) and beside its field are out of view.
  const std::vector<Eigen::Vector3f> points = randomPoints(400000, 20.0f);
  const PointCells filed = filePointCells(points);
  const ViewVolume view = lookingAlongX({0.0, 10.0, 10.0});
  const std::vector<std::uint32_t> counts = pointsToDraw(filed, &view, 50000);
  EXPECT_LE(sum(counts), 50000u);
  EXPECT_GT(sum(counts), 48000u);

  double nearShare = 0.0, farShare = 0.0;
  std::size_t nearCells = 0, farCells = 0;
  for (std::size_t c = 0; c < counts.size(); ++c) {
    const PointCells::Cell& cell = filed.cells[c];
    const Eigen::Vector3f centre = 0.5f * (cell.min + cell.max);
    // Wholly beside the field (|y - 10| > x + a cell's width): nothing drawn.
    if (std::abs(centre.y() - 10.0f) > centre.x() + 0.5f || std::abs(centre.z() - 10.0f) > centre.x() + 0.5f) {
      EXPECT_EQ(counts[c], 0u) << "cell at " << centre.transpose();
      continue;
    }
    if (std::abs(centre.y() - 10.0f) > 1.0f || std::abs(centre.z() - 10.0f) > 1.0f) continue;
    const double share = static_cast<double>(counts[c]) / size(cell);
    if (centre.x() > 2.0f && centre.x() < 3.0f) {
      nearShare += share;
      ++nearCells;
    } else if (centre.x() > 16.0f && centre.x() < 17.0f) {
      farShare += share;
      ++farCells;
    }
  }
  ASSERT_GT(nearCells, 0u);
  ASSERT_GT(farCells, 0u);
  nearShare /= static_cast<double>(nearCells);
  farShare /= static_cast<double>(farCells);
  // Shares fall with the square of the distance: about (16.5 / 2.5)^2 = 44 times, unless near is whole.
  EXPECT_GT(nearShare, 10.0 * farShare);
  EXPECT_GT(farShare, 0.0);
}

TEST(PointsToDraw, NothingOfCellsAClipHides) {
  // The frustum's sides and a clip's face (z <= 5): the whole budget goes to the cells below it.
  const std::vector<Eigen::Vector3f> points = randomPoints(100000, 20.0f);
  const PointCells filed = filePointCells(points);
  ViewVolume view = lookingAlongX({-30.0, 10.0, 10.0});
  view.planes.emplace_back(0.0, 0.0, -1.0, 5.0);
  const std::vector<std::uint32_t> counts = pointsToDraw(filed, &view, 20000);
  std::size_t below = 0;
  for (std::size_t c = 0; c < counts.size(); ++c) {
    if (filed.cells[c].min.z() > 5.0f) {
      EXPECT_EQ(counts[c], 0u);
    } else if (filed.cells[c].max.z() <= 5.0f) {
      below += counts[c];
    }
  }
  EXPECT_GT(below, 18000u);
}

TEST(PointsToDraw, EveryPointInViewWhenTheyFit) {
  const PointCells filed = filePointCells(randomPoints(100000, 20.0f));
  const ViewVolume view = lookingAlongX({-30.0, 10.0, 10.0});  // The whole cube in view.
  const std::vector<std::uint32_t> counts = pointsToDraw(filed, &view, 100000);
  EXPECT_EQ(sum(counts), 100000u);
}

TEST(PointsToDraw, EveryPointInViewAndNoOtherWhenTheyFit) {
  // The eye in the middle of the cube looking along +x: about a quarter of it in view, under the budget.
  const std::vector<Eigen::Vector3f> points = randomPoints(100000, 20.0f);
  const PointCells filed = filePointCells(points);
  const ViewVolume view = lookingAlongX({10.0, 10.0, 10.0});
  const std::vector<std::uint32_t> counts = pointsToDraw(filed, &view, 60000);
  std::size_t inView = 0;
  for (std::size_t c = 0; c < counts.size(); ++c) {
    const bool outside = std::any_of(view.planes.begin(), view.planes.end(), [&](const Eigen::Vector4d& plane) {
      Eigen::Vector3d corner;
      for (int axis = 0; axis < 3; ++axis)
        corner[axis] = plane[axis] >= 0.0 ? filed.cells[c].max[axis] : filed.cells[c].min[axis];
      return plane.head<3>().dot(corner) + plane[3] < 0.0;
    });
    EXPECT_EQ(counts[c], outside ? 0u : size(filed.cells[c])) << "cell " << c;
    if (!outside) inView += size(filed.cells[c]);
  }
  EXPECT_GT(inView, 10000u);
  EXPECT_LT(inView, 60000u);
  EXPECT_EQ(sum(counts), inView);
}

TEST(PointsToDraw, NothingFiledNothingDrawn) {
  const PointCells filed = filePointCells({});
  EXPECT_TRUE(filed.cells.empty());
  const ViewVolume view = lookingAlongX({0.0, 0.0, 0.0});
  EXPECT_TRUE(pointsToDraw(filed, &view, 10).empty());
}

}  // namespace
}  // namespace piperun::ui
