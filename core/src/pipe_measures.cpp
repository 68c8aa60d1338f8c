#include "piperun/pipe_measures.h"

#include "angles.h"
#include "segment_distance.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace piperun {

double PipeLie::slopePercent() const { return 100.0 * std::tan(slopeDegrees * kDegree); }

PipeLie pipeLie(const Pipe& pipe, UpAxis up) {
  PipeLie lie;
  const double startHeight = heightAlong(up, pipe.start), endHeight = heightAlong(up, pipe.end);
  lie.lowHeight = std::min(startHeight, endHeight);
  lie.highHeight = std::max(startHeight, endHeight);
  const double length = pipe.length();
  if (length > 0.0) lie.slopeDegrees = std::asin(std::min(1.0, (lie.highHeight - lie.lowHeight) / length)) / kDegree;
  return lie;
}

TubeHeights tubeHeights(const std::vector<Eigen::Vector3d>& axis, double radius, UpAxis up) {
  TubeHeights heights{std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
  const Eigen::Vector3d upward = upVector(up);
  // Each segment, or the one point alone (a circle of unknown tilt: level taken).
  for (std::size_t k = 0; k == 0 || k + 1 < axis.size(); ++k) {
    const Eigen::Vector3d& a = axis[k];
    const Eigen::Vector3d& b = axis[std::min(k + 1, axis.size() - 1)];
    const double length = (b - a).norm();
    const double rise = length > 0.0 ? (b - a).dot(upward) / length : 0.0;  // sine of the segment's slope
    const double reach = radius * std::sqrt(std::max(0.0, 1.0 - rise * rise));
    heights.lowest = std::min(heights.lowest, std::min(heightAlong(up, a), heightAlong(up, b)) - reach);
    heights.highest = std::max(heights.highest, std::max(heightAlong(up, a), heightAlong(up, b)) + reach);
  }
  return heights;
}

PipesApart pipesApart(const Pipe& a, const Pipe& b) {
  PipesApart apart;
  apart.axisDistance = segmentDistance(a.start, a.end, b.start, b.end);
  apart.clearance = apart.axisDistance - a.radius - b.radius;
  const double cosine = std::min(1.0, std::abs(a.direction().dot(b.direction())));
  apart.angleDegrees = std::acos(cosine) / kDegree;
  return apart;
}

}  // namespace piperun
