#include "point_measures.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <utility>

namespace piperun::ui {

namespace {

double distanceToSegment(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double lengthSquared = ab.squaredNorm();
  const double t = lengthSquared > 0.0 ? std::clamp((p - a).dot(ab) / lengthSquared, 0.0, 1.0) : 0.0;
  return (p - (a + t * ab)).norm();
}

/// A pipe or joint as an axis polyline with a radius and a box that bounds everything in reach.
struct Surface {
  int id = 0;
  double radius = 0.0;
  std::vector<Eigen::Vector3d> axis;
  BoundingBox reachBox;
};

std::int64_t cellKey(const Eigen::Vector3i& cell) {
  // 21 bits per axis: scans up to ~2 million cells across.
  return (static_cast<std::int64_t>(cell.x() & 0x1FFFFF) << 42) |
         (static_cast<std::int64_t>(cell.y() & 0x1FFFFF) << 21) | static_cast<std::int64_t>(cell.z() & 0x1FFFFF);
}

}  // namespace

SurfaceDistances surfaceDistances(const PointCloud& cloud, const PipeNetwork& network, double reach) {
  std::vector<Surface> surfaces;
  for (const auto& pipe : network.pipes) surfaces.push_back({pipe.id, pipe.radius, {pipe.start, pipe.end}, {}});
  for (const auto& joint : network.joints) surfaces.push_back({joint.id, joint.radius, joint.axis, {}});
  for (auto& surface : surfaces) {
    for (const auto& point : surface.axis) surface.reachBox.extend(point);
    const Eigen::Vector3d margin = Eigen::Vector3d::Constant(surface.radius + reach);
    surface.reachBox.min -= margin;
    surface.reachBox.max += margin;
  }

  SurfaceDistances result;
  result.distance.assign(cloud.size(), std::numeric_limits<float>::infinity());
  result.element.assign(cloud.size(), -1);
  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, cloud.size(), 4096), [&](const tbb::blocked_range<std::size_t>& range) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          const Eigen::Vector3d p = cloud.worldPosition(i);
          double best = reach;
          int bestId = -1;
          for (const auto& surface : surfaces) {
            if ((p.array() < surface.reachBox.min.array()).any() || (p.array() > surface.reachBox.max.array()).any())
              continue;
            double axisDistance = std::numeric_limits<double>::infinity();
            for (std::size_t k = 0; k + 1 < surface.axis.size(); ++k)
              axisDistance = std::min(axisDistance, distanceToSegment(p, surface.axis[k], surface.axis[k + 1]));
            const double distance = std::abs(axisDistance - surface.radius);
            if (distance <= best) {
              best = distance;
              bestId = surface.id;
            }
          }
          if (bestId >= 0) {
            result.distance[i] = static_cast<float>(best);
            result.element[i] = bestId;
          }
        }
      });
  return result;
}

std::vector<int> nearestKeptPoint(const PointCloud& input, const PointCloud& preprocessed, double reach) {
  std::vector<int> nearest(input.size(), -1);
  if (preprocessed.empty() || !(reach > 0.0)) return nearest;
  // Hash grid of the kept points with cells of `reach`: the nearest one within reach is in the 27
  // cells around the query's cell.
  const Eigen::Vector3d origin = preprocessed.origin;
  auto cellOf = [&](const Eigen::Vector3d& world) {
    return Eigen::Vector3i(((world - origin) / reach).array().floor().cast<int>());
  };
  std::unordered_map<std::int64_t, std::vector<int>> grid;
  for (std::size_t k = 0; k < preprocessed.size(); ++k)
    grid[cellKey(cellOf(preprocessed.worldPosition(k)))].push_back(static_cast<int>(k));

  tbb::parallel_for(
      tbb::blocked_range<std::size_t>(0, input.size(), 4096), [&](const tbb::blocked_range<std::size_t>& range) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          const Eigen::Vector3d p = input.worldPosition(i);
          const Eigen::Vector3i cell = cellOf(p);
          double best = reach * reach;
          for (int dx = -1; dx <= 1; ++dx)
            for (int dy = -1; dy <= 1; ++dy)
              for (int dz = -1; dz <= 1; ++dz) {
                const auto found = grid.find(cellKey(cell + Eigen::Vector3i(dx, dy, dz)));
                if (found == grid.end()) continue;
                for (int k : found->second) {
                  const double d = (preprocessed.worldPosition(static_cast<std::size_t>(k)) - p).squaredNorm();
                  // Ties go to the lower index so the result does not depend on the grid's order.
                  if (d < best || (d == best && nearest[i] >= 0 && k < nearest[i])) {
                    best = d;
                    nearest[i] = k;
                  }
                }
              }
        }
      });
  return nearest;
}

std::vector<bool> strayPoints(const PointCloud& cloud, double cell, int minNeighbours) {
  std::vector<bool> stray(cloud.size(), true);
  const BoundingBox bounds = cloud.boundingBox();  // Of the finite points.
  if (!(cell > 0.0) || bounds.empty()) return stray;
  // Cells numbered in (x, y, z) order with a cell of margin all round: the cells of a 3 x 3 x 3
  // block with the same x and y are three consecutive numbers.
  const Eigen::Vector3d low = bounds.min - cloud.origin;  // In the positions' frame.
  const Eigen::Array3i size = ((bounds.max - bounds.min) / cell).array().floor().cast<int>() + 3;
  std::vector<std::pair<std::int64_t, std::uint32_t>> entries;  // (cell number, point)
  entries.reserve(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!cloud.positions[i].allFinite()) continue;
    const Eigen::Array3i c = ((cloud.positions[i].cast<double>() - low) / cell).array().floor().cast<int>() + 1;
    entries.emplace_back((static_cast<std::int64_t>(c.x()) * size.y() + c.y()) * size.z() + c.z(),
                         static_cast<std::uint32_t>(i));
  }
  tbb::parallel_sort(entries.begin(), entries.end());  // (cell, point) pairs are distinct: one order.

  std::vector<std::int64_t> cells;
  std::vector<std::uint32_t> counts;
  for (const auto& entry : entries) {
    if (cells.empty() || cells.back() != entry.first) {
      cells.push_back(entry.first);
      counts.push_back(0);
    }
    ++counts.back();
  }
  // Each block, column by column: as the cells' numbers grow so does the first number of each of
  // the nine (dx, dy) columns around them, so one cursor per column walks the cells once.
  std::vector<std::uint32_t> blocks(cells.size(), 0);
  for (int dx = -1; dx <= 1; ++dx) {
    for (int dy = -1; dy <= 1; ++dy) {
      const std::int64_t offset = (static_cast<std::int64_t>(dx) * size.y() + dy) * size.z();
      std::size_t cursor = 0;
      for (std::size_t k = 0; k < cells.size(); ++k) {
        const std::int64_t first = cells[k] + offset - 1;
        while (cursor < cells.size() && cells[cursor] < first) ++cursor;
        for (std::size_t m = cursor; m < cells.size() && cells[m] <= first + 2; ++m) blocks[k] += counts[m];
      }
    }
  }
  std::size_t k = 0;
  for (const auto& [number, point] : entries) {
    while (cells[k] != number) ++k;
    stray[point] = static_cast<int>(blocks[k]) - 1 < minNeighbours;
  }
  return stray;
}

std::optional<double> ceilingHeight(const PointCloud& cloud, const PipeNetwork& network, UpAxis up) {
  const auto heightOf = [&](const Eigen::Vector3d& p) { return heightAlong(up, p); };
  double top = -std::numeric_limits<double>::infinity();
  for (const auto& pipe : network.pipes) top = std::max(top, std::max(heightOf(pipe.start), heightOf(pipe.end)) + pipe.radius);
  for (const auto& joint : network.joints)
    for (const auto& point : joint.axis) top = std::max(top, heightOf(point) + joint.radius);
  if (!std::isfinite(top) || cloud.empty()) return std::nullopt;
  const double height = top + kCeilingMargin;

  const BoundingBox bounds = cloud.boundingBox();  // Of the finite points.
  if (bounds.empty()) return std::nullopt;
  // The footprint: the two axes across the up one.
  const int across = (upIndex(up) + 1) % 3, along = (upIndex(up) + 2) % 3;
  const Eigen::Vector3d size = bounds.size();
  const double cell = std::max(0.25, std::max(size[across], size[along]) / 64.0);
  const int columns = static_cast<int>(size[across] / cell) + 1, rows = static_cast<int>(size[along] / cell) + 1;
  // Per cell: its points, and those above the height. Scattered outliers over the network are no ceiling.
  std::vector<std::array<std::uint32_t, 2>> counts(static_cast<std::size_t>(columns) * static_cast<std::size_t>(rows));
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d p = cloud.worldPosition(i);
    if (!p.allFinite()) continue;
    const int column = std::min(columns - 1, static_cast<int>((p[across] - bounds.min[across]) / cell));
    const int row = std::min(rows - 1, static_cast<int>((p[along] - bounds.min[along]) / cell));
    auto& count = counts[static_cast<std::size_t>(row) * static_cast<std::size_t>(columns) + static_cast<std::size_t>(column)];
    ++count[0];
    if (heightOf(p) > height) ++count[1];
  }
  const auto occupied = std::count_if(counts.begin(), counts.end(), [](const auto& count) { return count[0] > 0; });
  const auto covered = std::count_if(counts.begin(), counts.end(), [](const auto& count) {
    return count[0] > 0 && static_cast<double>(count[1]) >= kCeilingShare * count[0];
  });
  if (occupied == 0 || 2 * covered < occupied) return std::nullopt;
  return height;
}

}  // namespace piperun::ui
