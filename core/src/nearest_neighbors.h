#pragma once
// Exact k nearest neighbours of every point of a cloud, found in a grid of cubic cells.
//
// Scans are surfaces sampled at a known spacing, so the neighbours of almost every point lie in the
// 3 × 3 × 3 cells around it when the cell edge is a few spacings. A point's list is accepted when
// its k-th neighbour is nearer than the block's nearest face (nothing outside can be nearer);
// otherwise the block grows until that holds, so the lists are exact for any cloud. Candidates of a
// cell are gathered once for all its points. Lists are sorted by (distance, index): the same for
// any thread count.
//
// Each list is handed to a visitor as soon as it is settled and is not kept: the lists of a site
// scan (k indices a point) would outweigh the scan itself.

#include "piperun/progress.h"

#include <Eigen/Core>

#include <cstdint>
#include <functional>
#include <vector>

namespace piperun {

/// Takes one point's k nearest neighbours, nearest first and the point itself left out, and their
/// squared distances. Called once for every point, from several threads at once.
using NeighborVisitor =
    std::function<void(std::uint32_t point, const std::uint32_t* neighbors, const float* squaredDistances)>;

/// Neighbours in each list when k are asked of `points` points: k, at most points − 1 (0 when there
/// are fewer than two points).
int neighborListSize(std::size_t points, int k);

/// Finds the neighborListSize(positions.size(), k) nearest neighbours of every point and hands each
/// point's list to `visit` (nothing is visited when that size is 0). The positions must be finite
/// (std::invalid_argument otherwise). `spacing` (> 0) is the typical distance between neighbouring
/// points; it sets the cell size, so it affects speed only, never the lists. Reports progress under
/// `task` from `progressFrom` to `progressTo`; checks for cancellation.
void visitNearestNeighbors(const std::vector<Eigen::Vector3f>& positions, int k, double spacing, Progress& progress,
                           const char* task, double progressFrom, double progressTo, const NeighborVisitor& visit);

}  // namespace piperun
