#pragma once
// Bounds of a large set of positions, found in parallel (a serial pass over millions of points
// held one core while the other waited).

#include "piperun/point_cloud.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <cstddef>
#include <vector>

namespace piperun {

/// The bounding box of the finite positions for which keep(i) holds, and how many there are.
struct CountedBounds {
  BoundingBox box;
  std::size_t count = 0;
};

template <typename Keep>
CountedBounds finiteBounds(const std::vector<Eigen::Vector3f>& positions, Keep keep) {
  constexpr std::size_t kChunk = std::size_t{1} << 16;
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, positions.size(), kChunk), CountedBounds{},
      [&](const tbb::blocked_range<std::size_t>& range, CountedBounds bounds) {
        Eigen::Array3f low = bounds.box.min.cast<float>().array(), high = bounds.box.max.cast<float>().array();
        for (std::size_t i = range.begin(); i < range.end(); ++i) {
          const Eigen::Vector3f& p = positions[i];
          if (!p.allFinite() || !keep(i)) continue;
          low = low.min(p.array());
          high = high.max(p.array());
          ++bounds.count;
        }
        if (bounds.count > 0) {
          bounds.box.extend(low.cast<double>().matrix());
          bounds.box.extend(high.cast<double>().matrix());
        }
        return bounds;
      },
      [](CountedBounds a, const CountedBounds& b) {
        a.box.extend(b.box);
        a.count += b.count;
        return a;
      });
}

/// The bounding box of all finite positions.
inline CountedBounds finiteBounds(const std::vector<Eigen::Vector3f>& positions) {
  return finiteBounds(positions, [](std::size_t) { return true; });
}

}  // namespace piperun
