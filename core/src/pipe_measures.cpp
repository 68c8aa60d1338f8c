#include "piperun/pipe_measures.h"

#include "angles.h"
#include "segment_distance.h"

#include <algorithm>
#include <cmath>

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

PipesApart pipesApart(const Pipe& a, const Pipe& b) {
  PipesApart apart;
  apart.axisDistance = segmentDistance(a.start, a.end, b.start, b.end);
  apart.clearance = apart.axisDistance - a.radius - b.radius;
  const double cosine = std::min(1.0, std::abs(a.direction().dot(b.direction())));
  apart.angleDegrees = std::acos(cosine) / kDegree;
  return apart;
}

}  // namespace piperun
