#pragma once
// Points and payloads near places: a uniform hash grid of integer payloads; the points of a cloud
// inside each of a set of spheres, from one pass over the cloud (for one search); and a cloud's
// points filed by cell once, for the many searches of the joints stage (spheres round hypotheses
// and ends, capsules round pipes). Shared by the joints stage and the merge stage (the points past
// pipe ends).

#include "piperun/point_cloud.h"

#include "bounds.h"
#include "cell_table.h"
#include "segment_distance.h"
#include "sort_by_key.h"

#include <Eigen/Core>
#include <tbb/parallel_for.h>

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
    if (id == buckets_.size()) {
      buckets_.emplace_back();
      cells_.push_back(cell);
    }
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
  /// around `p` (a value may come several times), cell by cell in x, y, z order.
  template <class Visit>
  void forEachInCube(const Eigen::Vector3d& p, double reach, Visit&& visit) const {
    const Eigen::Vector3i low = cellOf(p - Eigen::Vector3d::Constant(reach));
    const Eigen::Vector3i high = cellOf(p + Eigen::Vector3d::Constant(reach));
    const double cubeCells = ((high - low).cast<double>().array() + 1.0).prod();
    if (cubeCells <= static_cast<double>(cells_.size())) {
      forEachCellInCube(p, reach, [&](const Eigen::Vector3i& cell) {
        if (const auto* bucket = find(cell)) {
          for (std::uint32_t value : *bucket) visit(value);
        }
      });
      return;
    }
    // A cube of more cells than the grid fills (a thick pipe's reach over a few pipes' axes): the
    // filled cells inside it, in the same order.
    std::vector<std::uint32_t> inside;
    for (std::uint32_t id = 0; id < cells_.size(); ++id) {
      if ((cells_[id].array() >= low.array()).all() && (cells_[id].array() <= high.array()).all()) inside.push_back(id);
    }
    std::sort(inside.begin(), inside.end(), [&](std::uint32_t a, std::uint32_t b) {
      return std::lexicographical_compare(cells_[a].data(), cells_[a].data() + 3, cells_[b].data(), cells_[b].data() + 3);
    });
    for (std::uint32_t id : inside) {
      for (std::uint32_t value : buckets_[id]) visit(value);
    }
  }

 private:
  double cell_;
  CellTable cellIds_;                                // cell key → index into buckets_
  std::vector<std::vector<std::uint32_t>> buckets_;  // the payloads of each cell, in insertion order
  std::vector<Eigen::Vector3i> cells_;               // the cell of each bucket
};

/// Cubic cells over the bounding box of a set of points, numbered row by row along x, then y, then z:
/// a row of cells is one range of numbers, and grouping by number splits the box along z.
class CellNumbering {
 public:
  CellNumbering(const std::vector<Eigen::Vector3f>& positions, double cellSize) : cell_(cellSize) {
    if (positions.empty()) return;
    // The cells of the box's corners bound every point's cell (floor is monotonic).
    const BoundingBox box = finiteBounds(positions).box;
    low_ = cellOf(box.min);
    size_ = (cellOf(box.max) - low_).cast<std::int64_t>().array() + 1;
  }

  double cellSize() const { return cell_; }
  Eigen::Vector3i cellOf(const Eigen::Vector3d& p) const { return (p / cell_).array().floor().cast<int>(); }
  /// The box's lowest and highest cells.
  Eigen::Vector3i lowest() const { return low_; }
  Eigen::Vector3i highest() const { return (low_.cast<std::int64_t>().array() + size_ - 1).matrix().cast<int>(); }
  bool contains(const Eigen::Vector3i& cell) const {
    const Eigen::Array3<std::int64_t> offset = (cell - low_).cast<std::int64_t>().array();
    return (offset >= 0).all() && (offset < size_).all();
  }
  std::uint64_t numberOf(const Eigen::Vector3i& cell) const {
    const Eigen::Array3<std::int64_t> offset = (cell - low_).cast<std::int64_t>().array();
    return static_cast<std::uint64_t>((offset.z() * size_.y() + offset.y()) * size_.x() + offset.x());
  }

 private:
  double cell_;
  Eigen::Vector3i low_ = Eigen::Vector3i::Zero();                           // the box's lowest cell
  Eigen::Array3<std::int64_t> size_ = Eigen::Array3<std::int64_t>::Zero();  // cells along each axis
};

/// The points of a cloud filed by cell once, for searches that each look at a few places: a scan's
/// millions of points are passed over once, not once a search. Cells are numbered row by row over
/// the cloud's bounding box (CellNumbering), so a row of cells is one range of the sorted numbers.
class PointCells {
 public:
  PointCells(const PointCloud& cloud, double cellSize) : cloud_(&cloud), numbering_(cloud.positions, cellSize) {
    if (cloud.size() == 0) return;
    cells_ = groupItemsByKey(cloud.size(), [&](std::size_t i) {
      return numbering_.numberOf(numbering_.cellOf(cloud.positions[i].cast<double>()));
    });
  }

  const PointCloud& cloud() const { return *cloud_; }
  double cellSize() const { return numbering_.cellSize(); }
  Eigen::Vector3i cellOf(const Eigen::Vector3d& p) const { return numbering_.cellOf(p); }

  /// Calls visit(i) for every point in the cells from `low` to `high` (inclusive), row by row.
  template <class Visit>
  void forEachInCells(Eigen::Vector3i low, Eigen::Vector3i high, Visit&& visit) const {
    if (cells_.keys.empty()) return;
    low = low.cwiseMax(numbering_.lowest());
    high = high.cwiseMin(numbering_.highest());
    if ((low.array() > high.array()).any()) return;
    const auto& numbers = cells_.keys;
    for (int z = low.z(); z <= high.z(); ++z) {
      for (int y = low.y(); y <= high.y(); ++y) {
        const std::uint64_t last = numbering_.numberOf(Eigen::Vector3i(high.x(), y, z));
        auto cell = std::lower_bound(numbers.begin(), numbers.end(), numbering_.numberOf(Eigen::Vector3i(low.x(), y, z)));
        for (; cell != numbers.end() && *cell <= last; ++cell) {
          const auto g = static_cast<std::size_t>(cell - numbers.begin());
          for (std::uint32_t j = cells_.begins[g]; j < cells_.begins[g + 1]; ++j) visit(cells_.items[j]);
        }
      }
    }
  }

 private:
  const PointCloud* cloud_;
  CellNumbering numbering_;
  KeyGroups cells_;  // the points by cell number, in index order within a cell
};

/// For each sphere (centre, radius), the points of `cells`' cloud inside it that `keep` accepts, in
/// index order.
template <class Keep>
std::vector<std::vector<std::uint32_t>> pointsInSpheres(const PointCells& cells,
                                                        const std::vector<std::pair<Eigen::Vector3d, double>>& spheres,
                                                        Keep&& keep) {
  std::vector<std::vector<std::uint32_t>> inside(spheres.size());
  const PointCloud& cloud = cells.cloud();
  tbb::parallel_for(std::size_t{0}, spheres.size(), [&](std::size_t s) {
    const auto& [center, reach] = spheres[s];
    const Eigen::Vector3d corner = Eigen::Vector3d::Constant(reach);
    cells.forEachInCells(cells.cellOf(center - corner), cells.cellOf(center + corner), [&](std::uint32_t i) {
      if ((cloud.positions[i].cast<double>() - center).squaredNorm() <= reach * reach && keep(i)) inside[s].push_back(i);
    });
    std::sort(inside[s].begin(), inside[s].end());
  });
  return inside;
}

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

/// The points of `cells`' cloud that `keep` accepts within `reach` of the segment from a to b, in
/// index order. The segment is looked along in pieces about as long as the reach, each through the
/// cells of its own box: one box round a long diagonal segment would hold far more than the capsule.
template <class Keep>
std::vector<std::uint32_t> pointsNearSegment(const PointCells& cells, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                             double reach, Keep&& keep) {
  const Eigen::Vector3d margin = Eigen::Vector3d::Constant(reach);
  const double step = std::max(reach, cells.cellSize());
  const int pieces = std::max(1, static_cast<int>(std::ceil((b - a).norm() / step)));
  std::vector<std::uint32_t> near;
  for (int k = 0; k < pieces; ++k) {
    const Eigen::Vector3d from = a + (b - a) * (static_cast<double>(k) / pieces);
    const Eigen::Vector3d to = a + (b - a) * (static_cast<double>(k + 1) / pieces);
    cells.forEachInCells(cells.cellOf(from.cwiseMin(to) - margin), cells.cellOf(from.cwiseMax(to) + margin),
                         [&](std::uint32_t i) {
                           if (pointSegmentDistance(cells.cloud().positions[i].cast<double>(), a, b) <= reach && keep(i)) {
                             near.push_back(i);
                           }
                         });
  }
  std::sort(near.begin(), near.end());
  near.erase(std::unique(near.begin(), near.end()), near.end());
  return near;
}

}  // namespace piperun
