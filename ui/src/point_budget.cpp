#include "point_budget.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace piperun::ui {

namespace {

constexpr std::uint32_t kNoCell = std::numeric_limits<std::uint32_t>::max();
/// Cells along the bounds' longest side.
constexpr float kCellsAcross = 128.0f;
/// Cells nearer the eye than this draw as densely as at this distance (m): no share is unbounded.
constexpr double kNearestDistance = 0.5;

/// SplitMix64: a small generator whose stream depends only on its seed (each cell seeds its own).
struct SplitMix {
  std::uint64_t state;
  std::uint64_t next() {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
};

bool boxOutside(const PointCells::Cell& cell, const Eigen::Vector4d& plane) {
  // The box corner farthest along the plane's inward normal.
  Eigen::Vector3d corner;
  for (int axis = 0; axis < 3; ++axis) corner[axis] = plane[axis] >= 0.0 ? cell.max[axis] : cell.min[axis];
  return plane.head<3>().dot(corner) + plane[3] < 0.0;
}

double distanceToBox(const PointCells::Cell& cell, const Eigen::Vector3d& point) {
  const Eigen::Vector3d low = cell.min.cast<double>(), high = cell.max.cast<double>();
  return (point.cwiseMax(low).cwiseMin(high) - point).norm();
}

}  // namespace

PointCells filePointCells(const std::vector<Eigen::Vector3f>& positions, float minCell) {
  PointCells filed;
  Eigen::Vector3f low = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector3f high = -low;
  for (const auto& p : positions) {
    if (!p.allFinite()) continue;
    low = low.cwiseMin(p);
    high = high.cwiseMax(p);
  }
  if ((low.array() > high.array()).any()) return filed;  // No finite point.
  const float cell = std::max((high - low).maxCoeff() / kCellsAcross, minCell);
  const Eigen::Vector3i dims = ((high - low) / cell).cast<int>() + Eigen::Vector3i::Ones();

  std::vector<std::uint32_t> cellOf(positions.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, positions.size(), 1 << 16),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t i = range.begin(); i != range.end(); ++i) {
                        const Eigen::Vector3f& p = positions[i];
                        if (!p.allFinite()) {
                          cellOf[i] = kNoCell;
                          continue;
                        }
                        const Eigen::Vector3i c =
                            ((p - low) / cell).cast<int>().cwiseMin(dims - Eigen::Vector3i::Ones());
                        cellOf[i] = static_cast<std::uint32_t>((c.z() * dims.y() + c.y()) * dims.x() + c.x());
                      }
                    });

  // Counting sort by cell: the cells in index order, each cell's points in point order.
  std::vector<std::uint32_t> start(static_cast<std::size_t>(dims.prod()) + 1, 0);
  for (const std::uint32_t c : cellOf)
    if (c != kNoCell) ++start[c + 1];
  for (std::size_t c = 1; c < start.size(); ++c) start[c] += start[c - 1];
  filed.order.resize(start.back());
  std::vector<std::uint32_t> next(start.begin(), start.end() - 1);
  for (std::size_t i = 0; i < cellOf.size(); ++i)
    if (cellOf[i] != kNoCell) filed.order[next[cellOf[i]]++] = static_cast<std::uint32_t>(i);
  // Assigning {} would keep their memory.
  cellOf = std::vector<std::uint32_t>();
  next = std::vector<std::uint32_t>();

  for (std::size_t c = 0; c + 1 < start.size(); ++c)
    if (start[c + 1] > start[c]) {
      PointCells::Cell cell;
      cell.begin = start[c];
      cell.end = start[c + 1];
      filed.cells.push_back(cell);
    }

  // Shuffle each cell (its own generator, seeded by its place) and take its points' bounds.
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, filed.cells.size(), 16),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t c = range.begin(); c != range.end(); ++c) {
                        PointCells::Cell& entry = filed.cells[c];
                        SplitMix random{entry.begin};
                        for (std::uint32_t i = entry.end - 1; i > entry.begin; --i) {
                          const auto j =
                              static_cast<std::uint32_t>(entry.begin + random.next() % (i - entry.begin + 1));
                          std::swap(filed.order[i], filed.order[j]);
                        }
                        entry.min = entry.max = positions[filed.order[entry.begin]];
                        for (std::uint32_t i = entry.begin + 1; i < entry.end; ++i) {
                          entry.min = entry.min.cwiseMin(positions[filed.order[i]]);
                          entry.max = entry.max.cwiseMax(positions[filed.order[i]]);
                        }
                      }
                    });
  return filed;
}

std::vector<std::uint32_t> pointsToDraw(const PointCells& cells, const ViewVolume* view, std::size_t budget) {
  const std::size_t count = cells.cells.size();
  // Each cell's weight: 0 out of view, else 1 / distance^2 (1 without a perspective eye).
  std::vector<double> weight(count, 1.0);
  std::uint64_t inView = 0;
  for (std::size_t c = 0; c < count; ++c) {
    const PointCells::Cell& cell = cells.cells[c];
    if (view) {
      if (std::any_of(view->planes.begin(), view->planes.end(),
                      [&](const Eigen::Vector4d& plane) { return boxOutside(cell, plane); })) {
        weight[c] = 0.0;
        continue;
      }
      if (view->perspective) weight[c] = 1.0 / std::pow(std::max(distanceToBox(cell, view->eye), kNearestDistance), 2);
    }
    inView += cell.end - cell.begin;
  }

  std::vector<std::uint32_t> drawn(count, 0);
  auto share = [&](double scale) {
    std::uint64_t total = 0;
    for (std::size_t c = 0; c < count; ++c) {
      const std::uint32_t size = cells.cells[c].end - cells.cells[c].begin;
      const double share = weight[c] > 0.0 ? std::min(1.0, scale * weight[c]) : 0.0;  // Out of view: none.
      drawn[c] = static_cast<std::uint32_t>(std::min<double>(size, std::floor(size * share)));
      total += drawn[c];
    }
    return total;
  };
  if (inView <= budget) {
    share(std::numeric_limits<double>::infinity());
    return drawn;
  }
  // The largest scale whose shares fit the budget, by bisection (the total grows with the scale).
  double highestWeight = 0.0;
  for (const double w : weight) highestWeight = std::max(highestWeight, w);
  double fits = 0.0, exceeds = 1.0 / highestWeight;
  while (share(exceeds) <= budget) exceeds *= 2.0;
  for (int step = 0; step < 60; ++step) {
    const double middle = 0.5 * (fits + exceeds);
    (share(middle) <= budget ? fits : exceeds) = middle;
  }
  share(fits);
  return drawn;
}

}  // namespace piperun::ui
