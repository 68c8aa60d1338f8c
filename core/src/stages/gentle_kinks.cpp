// Splitting pipes that overlap at a gentle bend (see gentle_kinks.h).

#include "stages/gentle_kinks.h"

#include "angles.h"
#include "segment_distance.h"
#include "stages/segment_axis.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>

namespace piperun {

namespace {

constexpr double kMinKinkDeg = 2.0;    // Gentler, the two are one pipe measured twice (merge joins within 3°).
constexpr double kMaxKinkDeg = 25.0;   // Steeper bends leave the band within a few radii: the elbows find them.
constexpr int kRefits = 2;             // Rounds of (split the inliers at the corner, refit both axes).
constexpr int kFitSteps = 8;           // Gauss–Newton steps of one axis fit.
constexpr std::size_t kMinFitPoints = 12;  // A kept side fits its axis on at least this many inliers.
constexpr double kMinHandedOverShare = 0.5;  // The inliers a pipe gives up lie on the other's surface in this share.

struct Line {
  Eigen::Vector3d point;
  Eigen::Vector3d direction;  // Unit.
};

/// The axis at radius r that minimises the squared distances of `points` from the cylinder's
/// surface, from `line` (Gauss–Newton; points farther than `band` from the surface at a step are
/// left out of it); nullopt when too few points fix it.
std::optional<Line> fitAxisAtRadius(const PointCloud& cloud, const std::vector<std::uint32_t>& points, Line line,
                                    double r, double band) {
  for (int step = 0; step < kFitSteps; ++step) {
    const Eigen::Vector3d e1 = line.direction.unitOrthogonal();
    const Eigen::Vector3d e2 = line.direction.cross(e1);
    Eigen::Matrix4d normal = Eigen::Matrix4d::Zero();
    Eigen::Vector4d gradient = Eigen::Vector4d::Zero();
    std::size_t used = 0;
    for (std::uint32_t i : points) {
      const Eigen::Vector3d w = cloud.positions[i].cast<double>() - line.point;
      const double t = w.dot(line.direction);
      const Eigen::Vector3d radial = w - t * line.direction;
      const double distance = radial.norm();
      const double residual = distance - r;
      if (std::fabs(residual) > band || distance < 1e-9) continue;
      const Eigen::Vector3d n = radial / distance;
      // Moving the axis point by e, or tilting the direction by e (at t along it), moves the axis
      // away from the point by n·e, or t n·e.
      const Eigen::Vector4d jacobian(-n.dot(e1), -n.dot(e2), -t * n.dot(e1), -t * n.dot(e2));
      normal += jacobian * jacobian.transpose();
      gradient += jacobian * residual;
      ++used;
    }
    if (used < kMinFitPoints) return std::nullopt;
    const Eigen::LDLT<Eigen::Matrix4d> solver(normal);
    if (solver.info() != Eigen::Success || !solver.isPositive()) return std::nullopt;
    const Eigen::Vector4d change = -solver.solve(gradient);
    if (!change.allFinite()) return std::nullopt;
    line.point += change(0) * e1 + change(1) * e2;
    line.direction = (line.direction + change(2) * e1 + change(3) * e2).normalized();
  }
  return line;
}

/// Where along `line` the point lies.
double along(const Line& line, const Eigen::Vector3d& point) { return (point - line.point).dot(line.direction); }

/// One pipe of a kinked pair: its axis and which side of the corner it keeps.
struct Leg {
  Line axis;
  bool keepsLow = true;  // The part before the corner (towards its start), or after it.
  std::vector<std::uint32_t> kept;
  std::vector<std::uint32_t> givenUp;

  bool keeps(double t, double corner) const { return keepsLow ? t <= corner : t >= corner; }
};

/// Splits `pipe`'s inliers at `corner` (along `leg.axis`).
void splitInliers(const PointCloud& cloud, const PipeSegment& pipe, double corner, Leg& leg) {
  leg.kept.clear();
  leg.givenUp.clear();
  for (std::uint32_t i : pipe.inliers) {
    (leg.keeps(along(leg.axis, cloud.positions[i].cast<double>()), corner) ? leg.kept : leg.givenUp).push_back(i);
  }
}

/// Whether most of `points` lie within `band` of the surface of radius r around `line`.
bool mostlyOnSurface(const PointCloud& cloud, const std::vector<std::uint32_t>& points, const Line& line, double r,
                     double band) {
  const auto on = std::count_if(points.begin(), points.end(), [&](std::uint32_t i) {
    return std::fabs(distanceToLine(cloud.positions[i].cast<double>(), line.point, line.direction) - r) <= band;
  });
  return static_cast<double>(on) >= kMinHandedOverShare * static_cast<double>(points.size());
}

}  // namespace

std::size_t splitAtGentleKinks(const PointCloud& cloud, std::vector<PipeSegment>& pipes, const JointsParams& params) {
  const double band = params.supportDistance;
  std::size_t splits = 0;
  for (std::size_t a = 0; a < pipes.size(); ++a) {
    for (std::size_t b = a + 1; b < pipes.size(); ++b) {
      const std::array<PipeSegment*, 2> pair{&pipes[a], &pipes[b]};
      const double smaller = std::min(pair[0]->radius, pair[1]->radius);
      const double larger = std::max(pair[0]->radius, pair[1]->radius);
      if (smaller < params.minRadiusRatio * larger) continue;
      const double minLength = params.minPipeDiameters * 2.0 * larger;
      if ((pair[0]->end - pair[0]->start).norm() < minLength || (pair[1]->end - pair[1]->start).norm() < minLength) {
        continue;
      }
      if (segmentDistance(pair[0]->start, pair[0]->end, pair[1]->start, pair[1]->end) > larger) continue;
      const double skewLimit = std::max(params.minSkewDistance, params.maxSkewRadii * smaller);

      std::array<Leg, 2> legs;
      for (int k = 0; k < 2; ++k) legs[k].axis = {pair[k]->start, unitAxis(*pair[k])};
      std::array<double, 2> corner{};
      bool kinked = true;
      for (int refit = 0; refit <= kRefits && kinked; ++refit) {
        const double cosine = std::fabs(legs[0].axis.direction.dot(legs[1].axis.direction));
        const double angle = degrees(std::acos(std::min(1.0, cosine)));
        const auto parameters = closestLineParameters(legs[0].axis.point, legs[0].axis.direction,
                                                      legs[1].axis.point, legs[1].axis.direction);
        if (angle < kMinKinkDeg || angle > kMaxKinkDeg || !parameters) {
          kinked = false;
          break;
        }
        corner = {parameters->first, parameters->second};
        const Eigen::Vector3d onFirst = legs[0].axis.point + corner[0] * legs[0].axis.direction;
        const Eigen::Vector3d onSecond = legs[1].axis.point + corner[1] * legs[1].axis.direction;
        if ((onFirst - onSecond).norm() > skewLimit) {
          kinked = false;
          break;
        }
        if (refit == kRefits) break;
        for (int k = 0; k < 2; ++k) {
          const PipeSegment& other = *pair[1 - k];
          legs[k].keepsLow = along(legs[k].axis, 0.5 * (other.start + other.end)) > corner[k];
          splitInliers(cloud, *pair[k], corner[k], legs[k]);
        }
        if (refit == 0) {
          // One pipe passes the corner by more than a radius (else the elbows join them), and each
          // keeps a pipe's length on its side.
          bool passes = false;
          for (int k = 0; k < 2; ++k) {
            const double start = along(legs[k].axis, pair[k]->start);
            const double end = along(legs[k].axis, pair[k]->end);
            const double r = pair[k]->radius;
            passes = passes || (legs[k].keepsLow ? end > corner[k] + r : start < corner[k] - r);
            const double keptLength = legs[k].keepsLow ? std::min(end, corner[k]) - start : end - std::max(start, corner[k]);
            if (keptLength < minLength) kinked = false;
          }
          if (!passes) kinked = false;
        }
        for (int k = 0; k < 2 && kinked; ++k) {
          const auto fitted = fitAxisAtRadius(cloud, legs[k].kept, legs[k].axis, pair[k]->radius, band);
          if (!fitted) {
            kinked = false;
            break;
          }
          legs[k].axis.point = fitted->point;
          legs[k].axis.direction =
              fitted->direction.dot(legs[k].axis.direction) >= 0.0 ? fitted->direction : Eigen::Vector3d(-fitted->direction);
        }
      }
      if (!kinked) continue;
      // What each gives up is the other's leg: on its surface.
      for (int k = 0; k < 2; ++k) splitInliers(cloud, *pair[k], corner[k], legs[k]);
      bool handedOver = true;
      for (int k = 0; k < 2; ++k) {
        if (!legs[k].givenUp.empty() &&
            !mostlyOnSurface(cloud, legs[k].givenUp, legs[1 - k].axis, pair[1 - k]->radius, band)) {
          handedOver = false;
        }
      }
      if (!handedOver) continue;
      for (int k = 0; k < 2; ++k) {
        PipeSegment& pipe = *pair[k];
        const Line& axis = legs[k].axis;
        const Eigen::Vector3d cornerPoint = axis.point + corner[k] * axis.direction;
        const double start = along(axis, pipe.start);
        const double end = along(axis, pipe.end);
        pipe.start = legs[k].keepsLow ? axis.point + start * axis.direction : cornerPoint;
        pipe.end = legs[k].keepsLow ? cornerPoint : axis.point + end * axis.direction;
        // An end short of the corner stays where it was found.
        if (legs[k].keepsLow && end < corner[k]) pipe.end = axis.point + end * axis.direction;
        if (!legs[k].keepsLow && start > corner[k]) pipe.start = axis.point + start * axis.direction;
      }
      for (int k = 0; k < 2; ++k) {
        std::vector<std::uint32_t> inliers = legs[k].kept;
        for (std::uint32_t i : legs[1 - k].givenUp) {
          const double distance = distanceToLine(cloud.positions[i].cast<double>(), legs[k].axis.point, legs[k].axis.direction);
          if (std::fabs(distance - pair[k]->radius) <= band) inliers.push_back(i);
        }
        std::sort(inliers.begin(), inliers.end());
        inliers.erase(std::unique(inliers.begin(), inliers.end()), inliers.end());
        pair[k]->inliers = std::move(inliers);
      }
      ++splits;
    }
  }
  return splits;
}

}  // namespace piperun
