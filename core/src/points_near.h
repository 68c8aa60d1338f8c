#pragma once
// Points and payloads near places: a uniform hash grid of integer payloads, and the points of a
// cloud inside each of a set of spheres from one pass over the cloud. Shared by the joints stage
// (pipe ends, hypotheses, completions) and the merge stage (the points past pipe ends).

#include "piperun/point_cloud.h"

#include "cell_table.h"
#include "segment_distance.h"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

namespace piperun {

/// Uniform hash grid of integer payloads (pipes by axis samples, points by position).
class HashGrid {
 public:
  explicit HashGrid(double cellSize) : cell_(cellSize) {}

  double cellSize() const { return cell_; }
  Eigen::Vector3i cellOf(const Eigen::Vector3d& p) const { return (p / cell_).array().floor().cast<int>(); }
  void insert(const Eigen::Vector3i& cell, std::uint32_t value) {
    const std::uint32_t id = cellIds_.insert(cellKey(cell));
    if (id == buckets_.size()) buckets_.emplace_back();
    auto& bucket = buckets_[id];
    if (bucket.empty() || bucket.back() != value) bucket.push_back(value);
  }
  const std::vector<std::uint32_t>* find(const Eigen::Vector3i& cell) const {
    const std::int64_t id = cellIds_.find(cellKey(cell));
    return id < 0 ? nullptr : &buckets_[static_cast<std::size_t>(id)];
  }
  /// Calls visitCell(cell) for every cell overlapping the cube of half-size `reach` around `p`.
  template <class VisitCell>
  void forEachCellInCube(const Eigen::Vector3d& p, double reach, VisitCell&& visitCell) const {
    const Eigen::Vector3i low = cellOf(p - Eigen::Vector3d::Constant(reach));
    const Eigen::Vector3i high = cellOf(p + Eigen::Vector3d::Constant(reach));
    for (int x = low.x(); x <= high.x(); ++x) {
      for (int y = low.y(); y <= high.y(); ++y) {
        for (int z = low.z(); z <= high.z(); ++z) visitCell(Eigen::Vector3i(x, y, z));
      }
    }
  }
  /// Calls visit(value) for the payloads of every cell overlapping the cube of half-size `reach`
  /// around `p` (a value may come several times).
  template <class Visit>
  void forEachInCube(const Eigen::Vector3d& p, double reach, Visit&& visit) const {
    forEachCellInCube(p, reach, [&](const Eigen::Vector3i& cell) {
      if (const auto* bucket = find(cell)) {
        for (std::uint32_t value : *bucket) visit(value);
      }
    });
  }

 private:
  double cell_;
  CellTable cellIds_;                                // cell key → index into buckets_
  std::vector<std::vector<std::uint32_t>> buckets_;  // the payloads of each cell, in insertion order
};

/// For each sphere (centre, radius), the points of the cloud inside it that `keep` accepts, in
/// index order, from one pass over the cloud through a grid of the spheres.
template <class Keep>
std::vector<std::vector<std::uint32_t>> pointsInSpheres(const PointCloud& cloud,
                                                        const std::vector<std::pair<Eigen::Vector3d, double>>& spheres,
                                                        double cellSize, Keep&& keep) {
  std::vector<std::vector<std::uint32_t>> inside(spheres.size());
  if (spheres.empty()) return inside;
  HashGrid grid(cellSize);
  for (std::size_t s = 0; s < spheres.size(); ++s) {
    const auto& [center, reach] = spheres[s];
    grid.forEachCellInCube(center, reach,
                           [&](const Eigen::Vector3i& cell) { grid.insert(cell, static_cast<std::uint32_t>(s)); });
  }
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d p = cloud.positions[i].cast<double>();
    const auto* bucket = grid.find(grid.cellOf(p));
    if (!bucket || !keep(i)) continue;
    for (std::uint32_t s : *bucket) {
      const auto& [center, reach] = spheres[s];
      if ((p - center).squaredNorm() <= reach * reach) inside[s].push_back(static_cast<std::uint32_t>(i));
    }
  }
  return inside;
}

/// The points of `cloud` filed in `grid` (by position) within `reach` of the segment from a to b,
/// in index order.
inline std::vector<std::uint32_t> pointsNearSegment(const HashGrid& grid, const PointCloud& cloud, const Eigen::Vector3d& a,
                                                    const Eigen::Vector3d& b, double reach) {
  // The cells of the capsule's bounding box whose centre lies within the reach and half a cell's
  // diagonal of the segment: every cell that can hold a point within the reach, each read once.
  const double cellSize = grid.cellSize();
  const Eigen::Vector3d margin = Eigen::Vector3d::Constant(reach);
  const Eigen::Vector3i low = grid.cellOf(a.cwiseMin(b) - margin);
  const Eigen::Vector3i high = grid.cellOf(a.cwiseMax(b) + margin);
  const double cellReach = reach + 0.5 * std::sqrt(3.0) * cellSize;
  std::vector<std::uint32_t> near;
  for (int x = low.x(); x <= high.x(); ++x) {
    for (int y = low.y(); y <= high.y(); ++y) {
      for (int z = low.z(); z <= high.z(); ++z) {
        const Eigen::Vector3d center = (Eigen::Vector3d(x, y, z).array() + 0.5).matrix() * cellSize;
        if (pointSegmentDistance(center, a, b) > cellReach) continue;
        const auto* bucket = grid.find(Eigen::Vector3i(x, y, z));
        if (!bucket) continue;
        for (std::uint32_t i : *bucket) {
          if (pointSegmentDistance(cloud.positions[i].cast<double>(), a, b) <= reach) near.push_back(i);
        }
      }
    }
  }
  std::sort(near.begin(), near.end());
  return near;
}

}  // namespace piperun
