#include "piperun/spacing.h"

#include "cell_table.h"
#include "piperun/io/point_reader.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <utility>
#include <vector>

namespace piperun {

namespace {
Eigen::Vector3i cellOf(const Eigen::Vector3f& p, float cell) { return (p / cell).array().floor().cast<int>(); }
}  // namespace

double estimatePointSpacing(const PointCloud& cloud, std::size_t samples) {
  const std::size_t n = cloud.size();
  if (n < 2 || samples == 0) return 0.0;
  samples = std::min(samples, n);

  // Cell size: a few times the spacing points would have if they filled the box's largest face
  // (scans are surfaces, not volumes), so a 3x3x3 block of cells almost always holds the neighbour.
  const Eigen::Vector3d size = cloud.boundingBox().size();
  std::array<double, 3> sides = {size.x(), size.y(), size.z()};
  std::sort(sides.begin(), sides.end());
  const double face = std::max(sides[1] * sides[2], 1e-12);
  const auto cell = static_cast<float>(std::max(3.0 * std::sqrt(face / static_cast<double>(n)), 1e-6));

  std::vector<std::size_t> queries(samples);
  for (std::size_t k = 0; k < samples; ++k) queries[k] = k * n / samples;

  // Index only the points in the 27 cells around each query point. The cells are numbered first;
  // the pass over every point runs in parallel chunks whose finds are appended in chunk order.
  CellTable cellIds;
  for (std::size_t q : queries) {
    const Eigen::Vector3i center = cellOf(cloud.positions[q], cell);
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) cellIds.insert(cellKey(center + Eigen::Vector3i(dx, dy, dz)));
      }
    }
  }
  constexpr std::size_t kChunk = 1 << 16;
  std::vector<std::vector<std::pair<std::uint32_t, std::uint32_t>>> found((n + kChunk - 1) / kChunk);
  tbb::parallel_for(std::size_t{0}, found.size(), [&](std::size_t chunk) {
    for (std::size_t i = chunk * kChunk; i < std::min(n, (chunk + 1) * kChunk); ++i) {
      const std::int64_t id = cellIds.find(cellKey(cellOf(cloud.positions[i], cell)));
      if (id >= 0) found[chunk].emplace_back(static_cast<std::uint32_t>(id), static_cast<std::uint32_t>(i));
    }
  });
  // The finds grouped by cell (a counting sort), in point order within a cell.
  std::vector<std::uint32_t> cellStart(cellIds.size() + 1, 0);
  for (const auto& part : found) {
    for (const auto& [id, i] : part) ++cellStart[id + 1];
  }
  for (std::size_t c = 0; c < cellIds.size(); ++c) cellStart[c + 1] += cellStart[c];
  std::vector<std::uint32_t> members(cellStart.back());
  std::vector<std::uint32_t> next(cellStart.begin(), cellStart.end() - 1);
  for (const auto& part : found) {
    for (const auto& [id, i] : part) members[next[id]++] = i;
  }

  std::vector<float> nearest(samples, std::numeric_limits<float>::infinity());
  tbb::parallel_for(std::size_t{0}, samples, [&](std::size_t k) {
    const std::size_t q = queries[k];
    const Eigen::Vector3f& p = cloud.positions[q];
    const Eigen::Vector3i center = cellOf(p, cell);
    float best = std::numeric_limits<float>::infinity();
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          const auto id = static_cast<std::size_t>(cellIds.find(cellKey(center + Eigen::Vector3i(dx, dy, dz))));
          for (std::uint32_t e = cellStart[id]; e < cellStart[id + 1]; ++e) {
            const std::uint32_t i = members[e];
            if (i == q) continue;
            const float d = (cloud.positions[i] - p).squaredNorm();
            // Exact duplicates (several returns of one spot) say nothing about spacing.
            if (d > 0.0f) best = std::min(best, d);
          }
        }
      }
    }
    nearest[k] = best;
  });
  std::vector<double> distances;
  distances.reserve(samples);
  for (const float best : nearest) {
    if (std::isfinite(best)) distances.push_back(std::sqrt(static_cast<double>(best)));
  }
  if (distances.empty()) return 0.0;
  const auto middle = distances.begin() + static_cast<std::ptrdiff_t>(distances.size() / 2);
  std::nth_element(distances.begin(), middle, distances.end());
  return *middle;
}

std::optional<std::string> sparseScanWarning(double spacing) {
  if (!(spacing > kMaxPlausibleSpacing)) return std::nullopt;
  std::string units;
  for (const std::string& unit : lengthUnitNames()) {
    if (unit != "m") units += (units.empty() ? "" : ", ") + unit;
  }
  char distance[32];
  std::snprintf(distance, sizeof distance, "%.3g", spacing);
  return std::string("the scan's points lie ") + distance +
         " m apart (median nearest-neighbour distance), far too sparse to show pipes: if its coordinates are not "
         "in metres, give their unit with --units (" + units + ")";
}

}  // namespace piperun
