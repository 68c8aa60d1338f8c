#pragma once
// The axis of a found pipe segment, distances from a line, whether a segment lies inside a pipe's
// tube and the closest points of two lines, shared by the merge and joints stages.

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <optional>
#include <utility>

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

/// Whether two pipes are as thick: radii within `share` of the larger, or within 3 mm.
inline bool radiiAgree(double a, double b, double share) {
  constexpr double kMinRadiusGap = 0.003;  // (m) below this, the fits of few points differ by noise
  return std::abs(a - b) <= std::max(kMinRadiusGap, share * std::max(a, b));
}

/// Whether the middle of `piece` lies inside the tube of `pipe` (within its radius of the axis,
/// between its ends).
inline bool middleInsideTube(const PipeSegment& piece, const PipeSegment& pipe) {
  const Eigen::Vector3d middle = 0.5 * (piece.start + piece.end);
  const Eigen::Vector3d axis = pipe.end - pipe.start;
  const double along = (middle - pipe.start).dot(axis) / axis.squaredNorm();
  return along >= 0.0 && along <= 1.0 && (middle - pipe.start - along * axis).norm() < pipe.radius;
}

/// Parameters (along each line) of the closest points of two lines p + s·u and q + t·v (unit
/// directions); nullopt when they are parallel.
inline std::optional<std::pair<double, double>> closestLineParameters(const Eigen::Vector3d& p, const Eigen::Vector3d& u,
                                                                      const Eigen::Vector3d& q, const Eigen::Vector3d& v) {
  const double b = u.dot(v);
  const double denominator = 1.0 - b * b;
  if (denominator < 1e-9) return std::nullopt;
  const Eigen::Vector3d w = p - q;
  const double d = u.dot(w);
  const double e = v.dot(w);
  return std::make_pair((b * e - d) / denominator, (e - b * d) / denominator);
}

}  // namespace piperun
