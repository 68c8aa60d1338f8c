#pragma once
// Exact k nearest neighbours of every point of a cloud, found in a grid of cubic cells.
//
// Scans are surfaces sampled at a known spacing, so the neighbours of almost every point lie in the
// 3 × 3 × 3 cells around it when the cell edge is a few spacings. A point's list is accepted when
// its k-th neighbour is nearer than the block's nearest face (nothing outside can be nearer);
// otherwise the block grows until that holds, so the lists are exact for any cloud. Candidates of a
// cell are gathered once for all its points. Lists are sorted by (distance, index): the same for
// any thread count.

#include "piperun/progress.h"

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace piperun {

struct NeighborLists {
  int k = 0;                           ///< Neighbours per point: the k asked, at most n − 1.
  std::vector<std::uint32_t> indices;  ///< k per point, nearest first, the point itself left out.
  int meanOf = 0;                      ///< Neighbours averaged in meanDistance (0: not computed).
  std::vector<float> meanDistance;     ///< Mean distance to the first meanOf neighbours.
};

/// The k nearest neighbours of every point; the positions must be finite (std::invalid_argument
/// otherwise). `spacing` (> 0) is the typical distance between neighbouring points; it sets the
/// cell size, so it affects speed only, never the result.
/// Reports progress under `task` from `progressFrom` to `progressTo`; checks for cancellation.
NeighborLists findNearestNeighbors(const std::vector<Eigen::Vector3f>& positions, int k, int meanOf, double spacing,
                                   Progress& progress, const char* task, double progressFrom, double progressTo);

}  // namespace piperun
