#pragma once
// Pipes that overlap at a gentle bend, or run across one, split at its corner before the joints stage.

#include <Eigen/Core>

#include "piperun/point_cloud.h"
#include "piperun/stages/extents.h"
#include "piperun/stages/joints.h"
#include "points_near.h"

#include <cstddef>
#include <vector>

namespace piperun {

/// What splitAtGentleKinks did.
struct GentleKinks {
  std::size_t splitPairs = 0;  ///< Pairs of found pipes split at a gentle bend.
  std::size_t legsFound = 0;   ///< Legs found beyond a bend that one pipe was fitted across.
};

/// A level pipe turning onto a slope by a few degrees stays within a cylinder's support band for a
/// long way past the bend, so the extents carry one pipe across it, its axis fitted through both
/// legs, and the leg beyond is found overlapping it (or the two legs overlap each other). No joint
/// joins such a pair: the corner lies behind an end, and the blended axis turns by less than the
/// bend. Each pair of pipes of alike radii whose axes meet (within the skew limit) at 2–25°, one
/// of them passing the corner, is split there: each keeps its inliers on its own side of the
/// corner, its axis refitted on them at its radius, and ends at the corner of the refitted axes;
/// the inliers it gives up go to the other pipe where they lie on its surface. Then each end of a
/// pipe looks for the leg beyond such a bend that no stage found, along one of `directions` (the
/// network's) or the level direction under one sloping gently (across the unit `up`), from its own
/// inliers and the points no pipe explains; a leg found is split from the pipe in the same way and
/// appended to `pipes` (not when `params.maxCompletionLength` is 0, which turns the searches for
/// missed pipes off). `cells`: the scan's points filed by cell.
GentleKinks splitAtGentleKinks(const PointCells& cells, std::vector<PipeSegment>& pipes,
                               const std::vector<Eigen::Vector3d>& directions, const Eigen::Vector3d& up,
                               const JointsParams& params);

}  // namespace piperun
