#pragma once
// The axis of a found pipe segment, shared by the merge and joints stages.

#include <Eigen/Core>

#include "piperun/stages/extents.h"

namespace piperun {

/// Unit vector from the segment's start to its end (+z for a degenerate segment).
inline Eigen::Vector3d unitAxis(const PipeSegment& segment) {
  const Eigen::Vector3d d = segment.end - segment.start;
  const double length = d.norm();
  return length > 0.0 ? Eigen::Vector3d(d / length) : Eigen::Vector3d::UnitZ();
}

}  // namespace piperun
