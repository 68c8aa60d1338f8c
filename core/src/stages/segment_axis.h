#pragma once
// The axis of a found pipe segment and distances from a line, shared by the merge and joints stages.

#include <Eigen/Core>

#include "piperun/stages/extents.h"

namespace piperun {

/// Unit vector from the segment's start to its end (+z for a degenerate segment).
inline Eigen::Vector3d unitAxis(const PipeSegment& segment) {
  const Eigen::Vector3d d = segment.end - segment.start;
  const double length = d.norm();
  return length > 0.0 ? Eigen::Vector3d(d / length) : Eigen::Vector3d::UnitZ();
}

/// Distance of `p` from the line through `origin` along the unit `axis`.
inline double distanceToLine(const Eigen::Vector3d& p, const Eigen::Vector3d& origin, const Eigen::Vector3d& axis) {
  const Eigen::Vector3d offset = p - origin;
  return (offset - offset.dot(axis) * axis).norm();
}

}  // namespace piperun
