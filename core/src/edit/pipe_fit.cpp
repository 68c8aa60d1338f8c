#include "piperun/edit/pipe_fit.h"

#include "piperun/edit/edit.h"
#include "angles.h"
#include "random.h"

#include <Eigen/Geometry>
#include <Eigen/QR>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <string>

namespace piperun {

namespace {

constexpr double kMinGap = 0.05;  // shortest gap that ends the growth of a fit around a point (m)
constexpr double kMinRadiusGap = 0.002;  // radius agreement floor of a point pair, as in placement (m)
constexpr double kRadiusSlack = 0.8;     // a fit may leave [minRadius, maxRadius] by this factor, as in placement
constexpr int kTrials = 500;             // point pairs tried for the initial cylinder
constexpr std::size_t kMaxScored = 4000; // points an initial cylinder is scored on
constexpr std::size_t kStarts = 8;        // best-scored starts refined until one gives a pipe
constexpr std::uint64_t kSeed = 1;        // seed of the pair draws: the same points give the same fit
constexpr double kAnchorReach = 0.03;    // half the pairs tried around a picked point have a point this near it (m)
constexpr double kAnchorDrift = 2.0;     // the refined surface passes within this many inlier distances of the picked point
constexpr std::size_t kMinFitInliers = 15;  // a hand fit is confirmed by the user: fewer points than the stage's minInliers do

struct Cylinder3 {
  Eigen::Vector3d point, direction;  // relative to the cloud origin; unit direction
  double radius = 0.0;

  double offset(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d q = p - point;
    return (q - q.dot(direction) * direction).norm() - radius;
  }
};

std::vector<std::uint32_t> pointsWhere(const PointCloud& cloud, const std::function<bool(const Eigen::Vector3d&)>& inside) {
  std::vector<std::uint32_t> selected;
  for (std::size_t i = 0; i < cloud.positions.size(); ++i) {
    if (inside(cloud.positions[i].cast<double>())) selected.push_back(static_cast<std::uint32_t>(i));
  }
  return selected;
}

void requireNormals(const PointCloud& cloud) {
  if (cloud.normals.size() != cloud.positions.size()) throw EditError("fitting a pipe needs the preprocessed points with normals");
}

/// Points of `candidates` near the surface whose normal, across the axis, points radially.
std::vector<std::uint32_t> inliersOf(const PointCloud& cloud, const Cylinder3& cylinder, const std::vector<std::uint32_t>& candidates,
                                     const PlacementParams& params) {
  const double minCos = std::cos(params.inlierNormalAngleDeg * kDegree);
  std::vector<std::uint32_t> inliers;
  for (const std::uint32_t i : candidates) {
    const Eigen::Vector3d q = cloud.positions[i].cast<double>() - cylinder.point;
    const Eigen::Vector3d radial = q - q.dot(cylinder.direction) * cylinder.direction;
    const double distance = radial.norm();
    if (distance <= 0.0 || std::abs(distance - cylinder.radius) >= params.inlierDistance) continue;
    const Eigen::Vector3d n = cloud.normals[i].cast<double>();
    const Eigen::Vector3d across = n - n.dot(cylinder.direction) * cylinder.direction;
    const double acrossNorm = across.norm();
    if (acrossNorm > 0.0 && std::abs(across.dot(radial)) >= minCos * acrossNorm * distance) inliers.push_back(i);
  }
  return inliers;
}

/// The cylinder two points with normals determine: the axis is perpendicular to both normals, the
/// centre where the normal lines cross in the plane across it, the radius the two distances to it
/// when they agree as placement.radius_agreement requires.
std::optional<Cylinder3> cylinderThrough(const PointCloud& cloud, std::uint32_t i, std::uint32_t j, const PlacementParams& params) {
  const Eigen::Vector3d ni = cloud.normals[i].cast<double>(), nj = cloud.normals[j].cast<double>();
  const Eigen::Vector3d axis = ni.cross(nj);
  if (axis.norm() < std::sin(params.minPairAngleDeg * kDegree)) return std::nullopt;
  Cylinder3 cylinder;
  cylinder.direction = axis.normalized();
  const auto across = [&](const Eigen::Vector3d& v) { return Eigen::Vector3d(v - v.dot(cylinder.direction) * cylinder.direction); };
  const Eigen::Vector3d pi = cloud.positions[i].cast<double>(), pj = cloud.positions[j].cast<double>();
  const Eigen::Vector3d ui = across(ni).normalized(), uj = across(nj).normalized();
  // pi + t ui = pj + s uj (in the plane): least squares on the 3 x 2 system.
  Eigen::Matrix<double, 3, 2> system;
  system << ui, -uj;
  const Eigen::Vector2d ts = system.colPivHouseholderQr().solve(across(pj - pi));
  const double ri = std::abs(ts[0]), rj = std::abs(ts[1]);
  const double radius = 0.5 * (ri + rj);
  if (std::abs(ri - rj) > std::max(kMinRadiusGap, params.radiusAgreement * radius)) return std::nullopt;
  if (radius < kRadiusSlack * params.minRadius || radius > params.maxRadius / kRadiusSlack) return std::nullopt;
  cylinder.point = pi + ts[0] * ui;
  cylinder.radius = radius;
  return cylinder;
}

/// Starts for the fit: of the cylinders through random pairs of points (a fixed seed, so the same
/// points give the same fit), the kStarts best supported, best first. With an `anchor` (a picked
/// point), the cylinder's surface must pass by it, so that the pipe picked wins over a bigger one
/// beside it, and every other pair has a point near it, so that a thin pipe's few points are tried.
std::vector<Cylinder3> startingCylinders(const PointCloud& cloud, const std::vector<std::uint32_t>& points,
                                         const PlacementParams& params, const std::optional<Eigen::Vector3d>& anchor,
                                         const char* where) {
  std::vector<std::uint32_t> firsts;
  if (anchor) {
    for (const std::uint32_t i : points) {
      if ((cloud.positions[i].cast<double>() - *anchor).norm() <= kAnchorReach) firsts.push_back(i);
    }
  } else {
    firsts = points;
  }
  if (firsts.empty()) {
    throw EditError(anchor ? "no points within " + std::to_string(kAnchorReach) + " m of the picked point: pick a point on the pipe"
                           : std::string("no points ") + where);
  }
  Rng random(kSeed);
  // Scoring on a bounded sample (every k-th point) keeps a large box interactive.
  std::vector<std::uint32_t> sample;
  const std::size_t stride = (points.size() + kMaxScored - 1) / kMaxScored;
  for (std::size_t k = 0; k < points.size(); k += stride) sample.push_back(points[k]);
  std::vector<std::pair<double, Cylinder3>> scored;
  for (int trial = 0; trial < kTrials; ++trial) {
    const std::vector<std::uint32_t>& from = trial % 2 == 0 ? firsts : points;
    const std::uint32_t i = from[random.next() % from.size()], j = points[random.next() % points.size()];
    if (i == j) continue;
    const auto candidate = cylinderThrough(cloud, i, j, params);
    if (!candidate || (anchor && std::abs(candidate->offset(*anchor)) > params.inlierDistance)) continue;
    // MSAC: an inlier counts less the farther it lies from the surface, so the cylinder the points
    // hug wins over a bigger one whose band merely holds them.
    double score = 0.0;
    for (const std::uint32_t k : inliersOf(cloud, *candidate, sample, params)) {
      const double offset = candidate->offset(cloud.positions[k].cast<double>()) / params.inlierDistance;
      score += 1.0 - offset * offset;
    }
    if (score > 0.0) scored.emplace_back(score, *candidate);
  }
  if (scored.empty()) throw EditError(std::string("no two points ") + where + " agree on a pipe-sized cylinder");
  // Stable: equal scores keep the order they were drawn in.
  std::stable_sort(scored.begin(), scored.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<Cylinder3> starts;
  for (std::size_t k = 0; k < scored.size() && starts.size() < kStarts; ++k) starts.push_back(scored[k].second);
  return starts;
}

std::vector<Eigen::Vector3d> positionsOf(const PointCloud& cloud, const std::vector<std::uint32_t>& indices) {
  std::vector<Eigen::Vector3d> points;
  points.reserve(indices.size());
  for (const std::uint32_t i : indices) points.push_back(cloud.positions[i].cast<double>());
  return points;
}

std::string tooFew(std::size_t found, const char* where) {
  return "only " + std::to_string(found) + " points fit a cylinder " + where + " (a hand fit needs " +
         std::to_string(kMinFitInliers) + ")";
}

/// `start` refined twice on its inliers as the placement stage refines; throws EditError when the
/// result is no pipe (too few inliers, degenerate, off the picked point, radius beyond the limits).
Cylinder3 refineStart(const PointCloud& cloud, Cylinder3 cylinder, const std::vector<std::uint32_t>& points,
                      const PlacementParams& params, const std::optional<Eigen::Vector3d>& anchor, const char* where) {
  for (int pass = 0; pass < 2; ++pass) {
    const std::vector<std::uint32_t> inliers = inliersOf(cloud, cylinder, points, params);
    if (inliers.size() < kMinFitInliers) throw EditError(tooFew(inliers.size(), where));
    if (!refineCylinderFit(positionsOf(cloud, inliers), cylinder.point, cylinder.direction, cylinder.radius,
                           params.refineIterations)) {
      throw EditError(std::string("the cylinder fit ") + where + " degenerates");
    }
  }
  if (anchor && std::abs(cylinder.offset(*anchor)) > kAnchorDrift * params.inlierDistance) {
    throw EditError(std::string("the cylinder fitted ") + where + " does not pass by the point (" +
                    std::to_string(std::abs(cylinder.offset(*anchor))) + " m off its surface): pick a point on the pipe");
  }
  if (cylinder.radius < kRadiusSlack * params.minRadius || cylinder.radius > params.maxRadius / kRadiusSlack) {
    throw EditError(std::string("the points ") + where + " fit a cylinder of radius " + std::to_string(cylinder.radius) +
                    " m, outside the placement radius limits");
  }
  const std::size_t inliers = inliersOf(cloud, cylinder, points, params).size();
  if (inliers < kMinFitInliers) throw EditError(tooFew(inliers, where));
  return cylinder;
}

/// The first of the best starts that refines into a pipe; the best start's failure when none does.
Cylinder3 fitCylinder(const PointCloud& cloud, const std::vector<std::uint32_t>& points, const PlacementParams& params,
                      const std::optional<Eigen::Vector3d>& anchor, const char* where) {
  if (points.size() < kMinFitInliers) throw EditError(tooFew(points.size(), where));
  const std::vector<Cylinder3> starts = startingCylinders(cloud, points, params, anchor, where);
  std::optional<EditError> firstFailure;
  for (const Cylinder3& start : starts) {
    try {
      return refineStart(cloud, start, points, params, anchor, where);
    } catch (const EditError& failure) {
      if (!firstFailure) firstFailure = failure;
    }
  }
  throw *firstFailure;
}

/// The pipe along `cylinder` spanning `inliers` (world coordinates).
Pipe pipeOver(const PointCloud& cloud, const Cylinder3& cylinder, const std::vector<std::uint32_t>& inliers) {
  double low = std::numeric_limits<double>::infinity(), high = -low, squares = 0.0;
  for (const std::uint32_t i : inliers) {
    const Eigen::Vector3d p = cloud.positions[i].cast<double>();
    const double along = (p - cylinder.point).dot(cylinder.direction);
    low = std::min(low, along);
    high = std::max(high, along);
    squares += cylinder.offset(p) * cylinder.offset(p);
  }
  Pipe pipe;
  pipe.radius = cylinder.radius;
  pipe.start = cloud.origin + cylinder.point + low * cylinder.direction;
  pipe.end = cloud.origin + cylinder.point + high * cylinder.direction;
  pipe.fitRms = std::sqrt(squares / static_cast<double>(inliers.size()));
  pipe.inlierCount = static_cast<std::int64_t>(inliers.size());
  pipe.confidence = 1.0;
  pipe.status = PipeStatus::Accepted;
  return pipe;
}

}  // namespace

Pipe fitPipeInBox(const PointCloud& cloud, const Eigen::Vector3d& boxMin, const Eigen::Vector3d& boxMax,
                  const PlacementParams& params) {
  requireNormals(cloud);
  const Eigen::Vector3d low = boxMin.cwiseMin(boxMax) - cloud.origin, high = boxMin.cwiseMax(boxMax) - cloud.origin;
  const std::vector<std::uint32_t> inside = pointsWhere(cloud, [&](const Eigen::Vector3d& p) {
    return (p.array() >= low.array()).all() && (p.array() <= high.array()).all();
  });
  const Cylinder3 cylinder = fitCylinder(cloud, inside, params, std::nullopt, "in the box");
  return pipeOver(cloud, cylinder, inliersOf(cloud, cylinder, inside, params));
}

Pipe fitPipeAround(const PointCloud& cloud, const Eigen::Vector3d& center, double reach, const PlacementParams& params) {
  requireNormals(cloud);
  const Eigen::Vector3d local = center - cloud.origin;
  const std::vector<std::uint32_t> near =
      pointsWhere(cloud, [&](const Eigen::Vector3d& p) { return (p - local).squaredNorm() <= reach * reach; });
  const Cylinder3 cylinder = fitCylinder(cloud, near, params, local, "around the point");

  // Grow along the axis: the inliers anywhere, sorted along it, kept while they continue from the
  // picked point without a long gap.
  const double band = cylinder.radius + params.inlierDistance;
  std::vector<std::uint32_t> alongAxis = pointsWhere(cloud, [&](const Eigen::Vector3d& p) {
    const Eigen::Vector3d q = p - cylinder.point;
    return (q - q.dot(cylinder.direction) * cylinder.direction).squaredNorm() <= band * band;
  });
  std::vector<std::pair<double, std::uint32_t>> sorted;
  for (const std::uint32_t i : inliersOf(cloud, cylinder, alongAxis, params)) {
    sorted.emplace_back((cloud.positions[i].cast<double>() - cylinder.point).dot(cylinder.direction), i);
  }
  std::sort(sorted.begin(), sorted.end());
  const double picked = (local - cylinder.point).dot(cylinder.direction);
  const double maxGap = std::max(kMinGap, 2.0 * cylinder.radius);
  std::size_t first = 0;
  while (first < sorted.size() && sorted[first].first < picked) ++first;
  std::size_t last = first;
  if (first == sorted.size()) first = last = sorted.size() - 1;
  while (first > 0 && sorted[first].first - sorted[first - 1].first <= maxGap) --first;
  while (last + 1 < sorted.size() && sorted[last + 1].first - sorted[last].first <= maxGap) ++last;
  std::vector<std::uint32_t> inliers;
  for (std::size_t k = first; k <= last; ++k) inliers.push_back(sorted[k].second);
  return pipeOver(cloud, cylinder, inliers);
}

}  // namespace piperun
