#pragma once
// Carrying a found pipe's end on along its axis over the scan's surface points: the merge stage's
// end extension (see merge.cpp), also applied by the joints stage to a completed leg that ran to
// the completion's length.

#include <Eigen/Core>

#include <cstdint>
#include <vector>

#include "piperun/point_cloud.h"
#include "piperun/stages/extents.h"
#include "piperun/stages/merge.h"

namespace piperun {

/// The band around a pipe's surface its points lie in: three times its RMS offset, at least 6 mm.
double surfaceBand(const PipeSegment& pipe);

/// How far past `end` (along the unit `outward`, at most `limit`) the pipe's surface carries on
/// over the points `nearby` (near the end; those `claimed` by a pipe count only as clutter), and
/// those points (appended to `surface`); 0 when it does not.
double extension(const PointCloud& cloud, const PipeSegment& pipe, const Eigen::Vector3d& end,
                 const Eigen::Vector3d& outward, double limit, const std::vector<std::uint32_t>& nearby,
                 const std::vector<char>& claimed, const MergeParams& params, std::vector<std::uint32_t>& surface);

/// How far the axis may run from `end` along `outward` (up to `reach`) before it enters the tube of
/// another of `pipes` than `self`.
double reachBeforeOtherPipes(const std::vector<PipeSegment>& pipes, std::size_t self, const Eigen::Vector3d& end,
                             const Eigen::Vector3d& outward, double reach);

}  // namespace piperun
