#include "piperun/pipe_measures.h"

#include "angles.h"
#include "segment_distance.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>

namespace piperun {

double PipeLie::slopePercent() const { return 100.0 * std::tan(slopeDegrees * kDegree); }

PipeLie pipeLie(const Eigen::Vector3d& start, const Eigen::Vector3d& end, UpAxis up) {
  PipeLie lie;
  const double startHeight = heightAlong(up, start), endHeight = heightAlong(up, end);
  lie.lowHeight = std::min(startHeight, endHeight);
  lie.highHeight = std::max(startHeight, endHeight);
  const double length = (end - start).norm();
  if (length > 0.0) lie.slopeDegrees = std::asin(std::min(1.0, (lie.highHeight - lie.lowHeight) / length)) / kDegree;
  return lie;
}

PipeLie pipeLie(const Pipe& pipe, UpAxis up) { return pipeLie(pipe.start, pipe.end, up); }

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

double Bend::angleDegrees() const { return angle / kDegree; }

std::optional<Bend> bendOf(const std::vector<Eigen::Vector3d>& arc) {
  if (arc.size() < 3) return std::nullopt;
  const Eigen::Vector3d& a = arc.front();
  const Eigen::Vector3d& m = arc[arc.size() / 2];
  const Eigen::Vector3d& b = arc.back();
  // Circumcentre of a, m, b.
  const Eigen::Vector3d ab = m - a;
  const Eigen::Vector3d ac = b - a;
  const Eigen::Vector3d normal = ab.cross(ac);
  if (normal.norm() <= 1e-9 * ab.norm() * ac.norm()) return std::nullopt;
  Bend bend;
  bend.centre =
      a + (ac.squaredNorm() * normal.cross(ab) + ab.squaredNorm() * ac.cross(normal)) / (2.0 * normal.squaredNorm());
  const Eigen::Vector3d fromCentre = a - bend.centre;
  bend.axis = fromCentre.cross(m - bend.centre).normalized();
  bend.radius = fromCentre.norm();
  bend.angle = std::atan2(fromCentre.cross(b - bend.centre).dot(bend.axis), fromCentre.dot(b - bend.centre));
  if (bend.angle <= 0.0) bend.angle += 2.0 * kPi;
  return bend;
}

ElbowAngle elbowAngleOf(double degrees) {
  constexpr double kTolerance = 7.5;
  if (std::abs(degrees - 90.0) <= kTolerance) return ElbowAngle::Ninety;
  if (std::abs(degrees - 45.0) <= kTolerance) return ElbowAngle::FortyFive;
  return ElbowAngle::Other;
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
