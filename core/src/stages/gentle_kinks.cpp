// Splitting pipes at gentle bends, and the legs beyond them no stage found (see gentle_kinks.h).

#include "stages/gentle_kinks.h"

#include "angles.h"
#include "points_near.h"
#include "segment_distance.h"
#include "stages/section_runs.h"
#include "stages/segment_axis.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <tbb/parallel_for.h>

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
constexpr double kMaxOvershoot = 1.0;  // A pipe fitted across a bend passes its corner by at most this (m)...
constexpr double kCornerStep = 0.01;   // ...looked for in steps of this (m).
constexpr double kLegNormalAngleDeg = 40.0;  // A point on the leg beyond has its normal this close to radial.
constexpr double kSectionLength = 0.04;      // The leg's points cover at least
constexpr int kMinLegSections = 3;           // this many sections of this length, with gaps of at
constexpr std::size_t kMaxLegGapSections = 3;  // most this many (as a completed leg's).
constexpr double kMaxClutterShare = 0.5;     // Clutter (see isClutter) around a leg, against its inliers.

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

/// Splits `first` and `second` at the corner of their axes when they overlap at a gentle bend (see
/// splitAtGentleKinks); whether they were.
bool splitPair(const PointCloud& cloud, PipeSegment& first, PipeSegment& second, const JointsParams& params) {
  const double band = params.supportDistance;
  const std::array<PipeSegment*, 2> pair{&first, &second};
  const double smaller = std::min(pair[0]->radius, pair[1]->radius);
  const double larger = std::max(pair[0]->radius, pair[1]->radius);
  if (smaller < params.minRadiusRatio * larger) return false;
  const double minLength = params.minPipeDiameters * 2.0 * larger;
  if ((pair[0]->end - pair[0]->start).norm() < minLength || (pair[1]->end - pair[1]->start).norm() < minLength) {
    return false;
  }
  if (segmentDistance(pair[0]->start, pair[0]->end, pair[1]->start, pair[1]->end) > larger) return false;
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
  if (!kinked) return false;
  // What each gives up is the other's leg: on its surface.
  for (int k = 0; k < 2; ++k) splitInliers(cloud, *pair[k], corner[k], legs[k]);
  bool handedOver = true;
  for (int k = 0; k < 2; ++k) {
    if (!legs[k].givenUp.empty() &&
        !mostlyOnSurface(cloud, legs[k].givenUp, legs[1 - k].axis, pair[1 - k]->radius, band)) {
      handedOver = false;
    }
  }
  if (!handedOver) return false;
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
  return true;
}

/// The leg beyond a gentle bend that `pipe` was fitted across, at its end `side`, when no pipe was
/// found there: along one of `directions` at 2–25° from the pipe's axis, from a corner up to
/// kMaxOvershoot behind the end, the points of `candidates` (the pipe's inliers and the points no
/// pipe explains, near the end) on the leg's surface and off the pipe's, less those on the pipe's
/// and off the leg's past the corner, are the most (at least `minCompletionPoints`, over a few
/// sections). The leg's inliers are all the candidates on its surface.
std::optional<PipeSegment> legBeyondKink(const PointCloud& cloud, const PipeSegment& pipe, int side,
                                         const std::vector<Eigen::Vector3d>& directions,
                                         const std::vector<std::uint32_t>& candidates, const JointsParams& params) {
  const double r = pipe.radius;
  const double band = params.supportDistance;
  const double length = (pipe.end - pipe.start).norm();
  const double maxBack = std::min(kMaxOvershoot, length - params.minPipeDiameters * 2.0 * r);
  if (maxBack < 2.0 * r || cloud.normals.empty()) return std::nullopt;
  const Eigen::Vector3d end = side == 0 ? pipe.start : pipe.end;
  const Eigen::Vector3d outward = side == 0 ? Eigen::Vector3d(-unitAxis(pipe)) : unitAxis(pipe);
  const double minCosine = std::cos(radians(kLegNormalAngleDeg));
  const auto onSurface = [&](const Eigen::Vector3d& w, const Eigen::Vector3d& normal, const Eigen::Vector3d& axis,
                             double& along) {
    along = w.dot(axis);
    const Eigen::Vector3d radial = w - along * axis;
    const double distance = radial.norm();
    return std::fabs(distance - r) <= band && std::fabs(normal.dot(radial)) >= minCosine * distance;
  };
  // Each candidate from the end, and whether it lies on the pipe's surface (whatever the corner).
  struct Candidate {
    Eigen::Vector3d fromEnd;
    Eigen::Vector3d normal;
    double distanceFromAxis;
    double alongPipe;  // From the end, outward.
    bool onPipe;
  };
  std::vector<Candidate> points;
  for (std::uint32_t i : candidates) {
    Candidate c;
    c.fromEnd = cloud.positions[i].cast<double>() - end;
    c.normal = cloud.normals[i].cast<double>();
    c.onPipe = onSurface(c.fromEnd, c.normal, outward, c.alongPipe);
    c.distanceFromAxis = (c.fromEnd - c.alongPipe * outward).norm();
    if (c.alongPipe >= -maxBack - r) points.push_back(c);
  }
  // Corners `back` behind the end, in steps: each point adds to the gain of the corners that put it
  // on the leg's surface (and off the pipe's), and takes from those past which it lies on the
  // pipe's surface only. Seen across the leg, a point's offset from its axis in the bend plane is
  // p + back·sin θ and out of it q, so the corners on the surface solve |p + back·sin θ| ∈ [lo, hi].
  const auto steps = static_cast<int>(std::floor((maxBack - 2.0 * r) / kCornerStep)) + 1;
  const auto backOf = [&](int k) { return 2.0 * r + k * kCornerStep; };
  struct Best {
    int gain = 0;
    double back = 0.0;
    Eigen::Vector3d direction = Eigen::Vector3d::Zero();
  } best;
  std::vector<int> change(static_cast<std::size_t>(steps) + 1);
  std::vector<std::pair<int, int>> ranked;  // (−gain, step)
  std::vector<char> sections;
  for (Eigen::Vector3d direction : directions) {
    if (direction.dot(outward) < 0.0) direction = -direction;
    const double cosine = std::min(1.0, direction.dot(outward));
    const double angle = degrees(std::acos(cosine));
    if (angle < kMinKinkDeg || angle > kMaxKinkDeg) continue;
    const double sine = std::sqrt(1.0 - cosine * cosine);
    const Eigen::Vector3d inPlane = (outward - cosine * direction) / sine;
    std::fill(change.begin(), change.end(), 0);
    // Adds `value` to the corners from `low` to `high` behind the end.
    const auto add = [&](double low, double high, int value) {
      const int first = std::max(0, static_cast<int>(std::ceil((low - 2.0 * r) / kCornerStep - 1e-9)));
      const int last = std::min(steps - 1, static_cast<int>(std::floor((high - 2.0 * r) / kCornerStep + 1e-9)));
      if (first > last) return;
      change[static_cast<std::size_t>(first)] += value;
      change[static_cast<std::size_t>(last) + 1] -= value;
    };
    const double lowSquared = std::max(0.0, r - band) * std::max(0.0, r - band);
    const double highSquared = (r + band) * (r + band);
    for (const Candidate& c : points) {
      // Past `back` = −alongPipe the point lies ahead of the corner, on the pipe's side.
      if (c.onPipe) add(-c.alongPipe + 1e-12, maxBack, -1);
      const double along = c.fromEnd.dot(direction);
      const Eigen::Vector3d across = c.fromEnd - along * direction;
      const double p = across.dot(inPlane);
      const Eigen::Vector3d outOfPlane = across - p * inPlane;
      const double qSquared = outOfPlane.squaredNorm();
      if (qSquared > highSquared) continue;
      const double lo = std::sqrt(std::max(0.0, lowSquared - qSquared));
      const double hi = std::sqrt(highSquared - qSquared);
      const double minBack = -along / cosine;  // The point lies past the corner along the leg.
      for (const double sign : {1.0, -1.0}) {
        const double low = std::max(minBack, (sign > 0.0 ? lo - p : -hi - p) / sine);
        const double high = (sign > 0.0 ? hi - p : -lo - p) / sine;
        if (low > high) continue;
        const double middle = 0.5 * (low + high);
        const Eigen::Vector3d radial = (p + middle * sine) * inPlane + outOfPlane;
        if (std::fabs(c.normal.dot(radial)) < minCosine * radial.norm()) continue;
        // On the leg: a gain where it is off the pipe, and no loss where it is on it.
        if (c.onPipe) {
          add(std::max(low, -c.alongPipe + 1e-12), high, 1);
        } else {
          add(low, high, 1);
        }
      }
    }
    ranked.clear();
    int gain = 0;
    for (int k = 0; k < steps; ++k) {
      gain += change[static_cast<std::size_t>(k)];
      if (gain > best.gain && gain >= static_cast<int>(params.minCompletionPoints)) ranked.emplace_back(-gain, k);
    }
    std::stable_sort(ranked.begin(), ranked.end());
    for (const auto& [negativeGain, k] : ranked) {
      if (-negativeGain <= best.gain) break;
      // The leg's points must cover a few sections along it.
      const Eigen::Vector3d corner = -backOf(k) * outward;
      sections.clear();
      for (const Candidate& c : points) {
        double alongLeg = 0.0;
        if (!c.onPipe && onSurface(c.fromEnd - corner, c.normal, direction, alongLeg) && alongLeg >= 0.0) {
          const auto section = static_cast<std::size_t>(alongLeg / kSectionLength);
          if (section >= sections.size()) sections.resize(section + 1, 0);
          sections[section] = 1;
        }
      }
      if (std::count(sections.begin(), sections.end(), 1) >= kMinLegSections) {
        best = {-negativeGain, backOf(k), direction};
        break;
      }
    }
  }
  if (best.gain < static_cast<int>(params.minCompletionPoints)) return std::nullopt;
  PipeSegment leg;
  leg.radius = r;
  leg.rms = pipe.rms;
  leg.confidence = pipe.confidence;
  leg.start = end - best.back * outward;
  // The leg runs over the sections its points cover, across gaps no longer than a completion's,
  // and not on over stray points beyond.
  std::vector<std::vector<std::pair<double, std::uint32_t>>> bySection;
  for (std::uint32_t i : candidates) {
    double alongLeg = 0.0;
    if (onSurface(cloud.positions[i].cast<double>() - leg.start, cloud.normals[i].cast<double>(), best.direction,
                  alongLeg) &&
        alongLeg >= 0.0) {
      const auto section = static_cast<std::size_t>(alongLeg / kSectionLength);
      if (section >= bySection.size()) bySection.resize(section + 1);
      bySection[section].emplace_back(alongLeg, i);
    }
  }
  const auto pointsIn = [&](std::size_t k) { return bySection[k].size(); };
  std::size_t first = 0;
  while (bySection[first].empty()) ++first;
  const std::size_t last = withoutStrayTail(
      first, runEnd(first, bySection.size(), kMaxLegGapSections, [&](std::size_t k) { return pointsIn(k) > 0; }),
      pointsIn);
  double farthest = 0.0;
  for (std::size_t k = first; k <= last; ++k) {
    for (const auto& [alongLeg, i] : bySection[k]) {
      leg.inliers.push_back(i);
      farthest = std::max(farthest, alongLeg);
    }
  }
  std::sort(leg.inliers.begin(), leg.inliers.end());
  leg.end = leg.start + farthest * best.direction;
  // A pipe leaves empty space around its tube: an elbow's torus, or a wall, fitted as a leg does not.
  std::vector<std::uint32_t> own = pipe.inliers;
  std::sort(own.begin(), own.end());
  std::size_t clutter = 0;
  for (std::uint32_t i : candidates) {
    const Eigen::Vector3d w = cloud.positions[i].cast<double>() - leg.start;
    const double alongLeg = w.dot(best.direction);
    if (alongLeg < 0.0 || alongLeg > farthest) continue;
    const bool unexplained = !std::binary_search(own.begin(), own.end(), i);
    if (isClutter((w - alongLeg * best.direction).norm(), r, band, unexplained)) ++clutter;
  }
  if (static_cast<double>(clutter) > kMaxClutterShare * static_cast<double>(leg.inliers.size())) return std::nullopt;
  return leg;
}

/// `directions` and, for each sloping gently (kMinKinkDeg to kMaxKinkDeg off level across the unit
/// `up`), the level direction under it, unless one of `directions` runs so already: a sloping line
/// turns off a level one (a drain leaving a header) whether or not another level pipe runs that way.
std::vector<Eigen::Vector3d> withLevelUnderSlopes(const std::vector<Eigen::Vector3d>& directions,
                                                  const Eigen::Vector3d& up) {
  std::vector<Eigen::Vector3d> all = directions;
  for (const Eigen::Vector3d& direction : directions) {
    const Eigen::Vector3d level = direction - direction.dot(up) * up;
    if (level.norm() < 1e-9) continue;
    const double slope = degrees(std::acos(std::min(1.0, level.norm())));
    if (slope < kMinKinkDeg || slope > kMaxKinkDeg) continue;
    const Eigen::Vector3d unit = level.normalized();
    const bool known = std::any_of(all.begin(), all.end(), [&](const Eigen::Vector3d& other) {
      return std::fabs(other.dot(unit)) >= std::cos(radians(kMinKinkDeg));
    });
    if (!known) all.push_back(unit);
  }
  return all;
}

/// Whether the middle of `piece` lies inside the tube of one of `pipes` other than `except`: the
/// leg beyond a bend was found already.
bool insideAnotherTube(const PipeSegment& piece, const std::vector<PipeSegment>& pipes, std::size_t except) {
  for (std::size_t q = 0; q < pipes.size(); ++q) {
    if (q != except && middleInsideTube(piece, pipes[q])) return true;
  }
  return false;
}

}  // namespace

GentleKinks splitAtGentleKinks(const PointCells& cells, std::vector<PipeSegment>& pipes,
                               const std::vector<Eigen::Vector3d>& directions, const Eigen::Vector3d& up,
                               const JointsParams& params) {
  const PointCloud& cloud = cells.cloud();
  GentleKinks kinks;
  for (std::size_t a = 0; a < pipes.size(); ++a) {
    for (std::size_t b = a + 1; b < pipes.size(); ++b) {
      if (splitPair(cloud, pipes[a], pipes[b], params)) ++kinks.splitPairs;
    }
  }
  // Pipes fitted across a bend whose leg beyond no stage found: from their own inliers and the
  // points no pipe explains around their ends. A search for missed pipes, off with the completion.
  if (params.maxCompletionLength <= 0.0) return kinks;
  std::vector<char> explained(cloud.size(), 0);
  for (const PipeSegment& pipe : pipes) {
    for (std::uint32_t i : pipe.inliers) explained[i] = 1;
  }
  const double legReach = kMaxOvershoot + params.maxCompletionLength;
  const std::vector<Eigen::Vector3d> legDirections = withLevelUnderSlopes(directions, up);
  const std::size_t found = pipes.size();
  std::vector<std::optional<PipeSegment>> legs(2 * found);
  tbb::parallel_for(std::size_t{0}, legs.size(), [&](std::size_t key) {
    const PipeSegment& pipe = pipes[key / 2];
    const int side = static_cast<int>(key % 2);
    const Eigen::Vector3d end = side == 0 ? pipe.start : pipe.end;
    const Eigen::Vector3d outward = side == 0 ? Eigen::Vector3d(-unitAxis(pipe)) : unitAxis(pipe);
    std::vector<std::uint32_t> candidates;
    for (std::uint32_t i : pipe.inliers) {
      if ((cloud.positions[i].cast<double>() - end).dot(outward) >= -kMaxOvershoot - pipe.radius) candidates.push_back(i);
    }
    const double reach = pipe.radius + params.supportDistance + legReach * std::sin(radians(kMaxKinkDeg));
    const auto near = pointsNearSegment(cells, end - kMaxOvershoot * outward, end + params.maxCompletionLength * outward,
                                        reach, [&](std::size_t i) { return !explained[i]; });
    candidates.insert(candidates.end(), near.begin(), near.end());
    std::sort(candidates.begin(), candidates.end());
    legs[key] = legBeyondKink(cloud, pipe, side, legDirections, candidates, params);
  });
  // In end order: a leg found already (inside another pipe's tube, or over points an earlier leg
  // took) is not found again.
  std::vector<char> takenByLeg(cloud.size(), 0);
  for (std::size_t key = 0; key < legs.size(); ++key) {
    auto& leg = legs[key];
    if (!leg) continue;
    const std::size_t p = key / 2;
    const auto taken = std::count_if(leg->inliers.begin(), leg->inliers.end(), [&](std::uint32_t i) { return takenByLeg[i] != 0; });
    if (2 * static_cast<std::size_t>(taken) > leg->inliers.size() || insideAnotherTube(*leg, pipes, p) ||
        !splitPair(cloud, pipes[p], *leg, params)) {
      continue;
    }
    for (std::uint32_t i : leg->inliers) takenByLeg[i] = 1;
    pipes.push_back(std::move(*leg));
    ++kinks.legsFound;
  }
  return kinks;
}

}  // namespace piperun
