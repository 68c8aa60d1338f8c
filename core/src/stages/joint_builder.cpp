// Joint hypotheses between pipe ends and bodies, and their reconstruction (see joint_builder.h).

#include "stages/joint_builder.h"

#include "angles.h"
#include "points_near.h"
#include "segment_distance.h"
#include "stages/segment_axis.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

namespace piperun {

std::vector<double> elbowRadiusVotes(const Eigen::Vector3d& point, const Eigen::Vector3d& corner,
                                     const Eigen::Vector3d& bisector, const Eigen::Vector3d& planeNormal,
                                     double halfAngle, double radius) {
  // In the bend plane, with x along the bisector and z along the normal, the centre is at
  // (kR, 0, 0), k = 1 / sin(halfAngle). On the torus: sqrt((x − kR)² + y²) = R + s, where
  // s = ±sqrt(r² − z²) picks the outer or inner side of the tube, which expands to
  // (k² − 1) R² − 2 (k x + s) R + (x² + y² − s²) = 0.
  std::vector<double> roots;
  const Eigen::Vector3d q = point - corner;
  const double x = q.dot(bisector);
  const double z = q.dot(planeNormal);
  if (std::fabs(z) > radius) return roots;
  const double y2 = std::max(0.0, q.squaredNorm() - x * x - z * z);
  const double k = 1.0 / std::sin(halfAngle);
  const double a = k * k - 1.0;
  const double tube = std::sqrt(radius * radius - z * z);
  for (double s : {tube, -tube}) {
    const double halfB = k * x + s;
    const double c = x * x + y2 - s * s;
    const double discriminant = halfB * halfB - a * c;
    if (discriminant < 0.0 || a <= 0.0) continue;
    const double root = std::sqrt(discriminant);
    for (double R : {(halfB - root) / a, (halfB + root) / a}) {
      if (R > 0.0 && R + s > 0.0) roots.push_back(R);
    }
  }
  return roots;
}

double unvotedBendRadius(double bendAngle, double seenToCorner, double band, double maxTilt, double slack,
                         double minRadius, double maxRadius) {
  // Where the inliers of a pipe leaving an elbow of radius R stop, measured from the corner: the
  // torus leaves the band (or tilts past maxTilt) an arc of phi past the tangent point.
  const auto inliersStop = [&](double R) {
    const double leaves = band >= R ? kPi : std::acos(1.0 - band / R);
    const double phi = std::min({bendAngle, maxTilt, leaves});
    return R * (std::tan(0.5 * bendAngle) - std::sin(phi));
  };
  const double bound = seenToCorner + slack;
  if (inliersStop(maxRadius) <= bound) return maxRadius;
  if (inliersStop(minRadius) > bound) return minRadius;
  // inliersStop grows with R: the torus leaves the band sooner the tighter it bends.
  double below = minRadius, above = maxRadius;
  for (int step = 0; step < 40; ++step) {
    const double middle = 0.5 * (below + above);
    (inliersStop(middle) <= bound ? below : above) = middle;
  }
  return below;
}

namespace joints {

namespace {

// An elbow voted tighter than this many pipe radii with almost no surface on its torus is no
// fitting (short-radius elbows bend at one diameter, two radii): the two pipes meet square at a
// tee whose main pipe was seen on one side only.
constexpr double kMinFittingBendRadii = 1.5;
// A pipe fitted into an elbow runs on past the corner by up to this many radii times the cotangent
// of half the bend angle (see tryEndPair); an end carried on over outliers may lie up to twice as
// far past, where its pipe holds at most this share of its linear density.
constexpr double kEndOvershootRadii = 1.25;
constexpr double kMaxPastCornerDensity = 0.2;
// How much nearer its corner than the inliers of such an elbow's pipe would stop an end may lie
// (m): the extents place ends to a 4 cm section.
constexpr double kUnvotedEndSlack = 0.04;

}  // namespace

bool normalAgrees(const PointCloud& cloud, std::uint32_t i, const Eigen::Vector3d& radial,
                  double maxAngleDeg) {
  if (cloud.normals.empty()) return true;
  return std::fabs(cloud.normals[i].cast<double>().dot(radial)) >= std::cos(radians(maxAngleDeg));
}

bool isFragment(const PipeSegment& pipe, const JointsParams& params) {
  return (pipe.end - pipe.start).norm() < params.minPipeDiameters * 2.0 * pipe.radius;
}

bool insideAnotherPipe(const PipeSegment& piece, const std::vector<PipeSegment>& pipes, const JointsParams& params) {
  return std::any_of(pipes.begin(), pipes.end(), [&](const PipeSegment& pipe) {
    return &pipe != &piece && !isFragment(pipe, params) && middleInsideTube(piece, pipe);
  });
}

bool cutsAnotherPipe(const PipeSegment& piece, std::initializer_list<int> except, const std::vector<PipeSegment>& pipes,
                     const JointsParams& params) {
  for (std::size_t p = 0; p < pipes.size(); ++p) {
    const PipeSegment& pipe = pipes[p];
    if (std::find(except.begin(), except.end(), static_cast<int>(p)) != except.end() || isFragment(pipe, params)) {
      continue;
    }
    if (segmentDistance(piece.start, piece.end, pipe.start, pipe.end) <
        piece.radius + pipe.radius - params.supportDistance) {
      return true;
    }
  }
  return false;
}

std::vector<Eigen::Vector3d> networkDirections(const std::vector<PipeSegment>& pipes) {
  constexpr double kGroupAngleDeg = 3.0;
  constexpr double kMinGroupLength = 0.5;
  std::vector<std::size_t> order(pipes.size());
  for (std::size_t p = 0; p < pipes.size(); ++p) order[p] = p;
  const auto length = [&](std::size_t p) { return (pipes[p].end - pipes[p].start).norm(); };
  std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return length(x) > length(y); });
  std::vector<Eigen::Vector3d> sums;
  for (std::size_t p : order) {
    const Eigen::Vector3d axis = unitAxis(pipes[p]);
    bool grouped = false;
    for (Eigen::Vector3d& sum : sums) {
      const double cosine = axis.dot(sum.normalized());
      if (std::fabs(cosine) >= std::cos(radians(kGroupAngleDeg))) {
        sum += (cosine < 0.0 ? -length(p) : length(p)) * axis;
        grouped = true;
        break;
      }
    }
    if (!grouped) sums.push_back(length(p) * axis);
  }
  std::vector<Eigen::Vector3d> directions;
  for (const Eigen::Vector3d& sum : sums) {
    if (sum.norm() >= kMinGroupLength) directions.push_back(sum.normalized());
  }
  return directions;
}

PipeEnd endOf(const std::vector<PipeSegment>& pipes, int pipe, int side) {
  const PipeSegment& segment = pipes[static_cast<std::size_t>(pipe)];
  const Eigen::Vector3d axis = unitAxis(segment);
  return {pipe, side, side == 0 ? segment.start : segment.end, side == 0 ? Eigen::Vector3d(-axis) : axis, segment.radius};
}

std::vector<std::pair<std::size_t, std::size_t>> endPairsWithin(const std::vector<PipeEnd>& ends,
                                                                const std::vector<double>& reaches) {
  double largestReach = 0.0;
  for (const double reach : reaches) largestReach = std::max(largestReach, reach);
  HashGrid endGrid(std::max(largestReach, 1e-3));
  for (std::size_t e = 0; e < ends.size(); ++e) endGrid.insert(endGrid.cellOf(ends[e].point), static_cast<std::uint32_t>(e));
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (std::size_t e = 0; e < ends.size(); ++e) {
    std::vector<std::size_t> partners;
    endGrid.forEachInCube(ends[e].point, reaches[e], [&](std::uint32_t f) {
      if (f > e && ends[f].pipe != ends[e].pipe && (ends[f].point - ends[e].point).norm() <= reaches[e]) {
        partners.push_back(f);
      }
    });
    std::sort(partners.begin(), partners.end());
    for (const std::size_t f : partners) pairs.emplace_back(e, f);
  }
  return pairs;
}

std::optional<Hypothesis> JointBuilder::boundaryBetween(const PipeEnd& a, const PipeEnd& b) const {
  const double smaller = std::min(a.radius, b.radius);
  const double larger = std::max(a.radius, b.radius);
  if (smaller < params_.minRadiusRatio * larger) return std::nullopt;
  const double bendAngle = std::acos(std::clamp(-a.outward.dot(b.outward), -1.0, 1.0));
  if (bendAngle > radians(params_.maxBoundaryAngleDeg)) return std::nullopt;
  Hypothesis h;
  h.type = JointType::Boundary;
  h.a = a;
  h.b = b;
  h.gap = (b.point - a.point).dot(a.outward);
  h.gapLimit = boundaryGapLimit(larger);
  if (h.gap < -smaller || h.gap > h.gapLimit) return std::nullopt;
  h.skew = std::max(distanceToLine(a.point, b.point, b.outward), distanceToLine(b.point, a.point, a.outward));
  h.skewLimit = skewLimit(smaller);
  if (h.skew > h.skewLimit) return std::nullopt;
  h.bendAngle = bendAngle;
  h.center = 0.5 * (a.point + b.point);
  h.reach = 0.5 * std::max(h.gap, 0.0) + larger + params_.supportDistance;
  return h;
}

void JointBuilder::tryEndPair(const PipeEnd& a, const PipeEnd& b, std::vector<Hypothesis>& out) const {
  const double smaller = std::min(a.radius, b.radius);
  const double larger = std::max(a.radius, b.radius);
  if (smaller < params_.minRadiusRatio * larger) {
    tryTeeBeyondEnd(a.radius < b.radius ? a : b, a.radius < b.radius ? b : a, out);
    return;
  }
  const double bendAngle = std::acos(std::clamp(-a.outward.dot(b.outward), -1.0, 1.0));

  if (bendAngle <= radians(params_.maxBoundaryAngleDeg)) {
    if (auto h = boundaryBetween(a, b)) out.push_back(std::move(*h));
    return;
  }
  if (bendAngle < radians(params_.minElbowAngleDeg) || bendAngle > radians(params_.maxElbowAngleDeg)) return;
  const auto parameters = closestLineParameters(a.point, a.outward, b.point, b.outward);
  if (!parameters) return;
  const auto [alongA, alongB] = *parameters;
  const double search = searchDistance(larger);
  // The corner lies ahead of both ends, or behind one by as much as the ends of pipes fitted
  // into the elbow overshoot it: about a radius at a square bend, more at a gentle one, whose
  // surface stays within a cylinder's band for longer (a quarter more for where the extents
  // place an end). A main seen on one side of a branch overshoots the same way, to the branch's
  // far wall, and that corner becomes a tee when no bend fits (teeForBendlessCorner). On a scan
  // with many outliers, an end the merge carried on over a few of them lies farther past (up to
  // twice as far): its pipe must hold few points past the corner, and the elbow's points must
  // vote for a fitting's bend (see reconstructElbow).
  const double overshoot = kEndOvershootRadii * larger / std::tan(0.5 * bendAngle);
  const double farOvershoot = 2.0 * overshoot;
  // Together the ends lie within twice the search distance of the elbow's shortest tangent
  // points: one may be farther when the other is nearer (an end whose last half metre was too
  // sparse for the extents).
  const double shortestTangent = params_.minBendRadii * smaller * std::tan(0.5 * bendAngle);
  if (alongA < -farOvershoot || alongB < -farOvershoot ||
      std::max(alongA, 0.0) + std::max(alongB, 0.0) > 2.0 * (search + shortestTangent)) {
    return;
  }
  const Eigen::Vector3d onA = a.point + alongA * a.outward;
  const Eigen::Vector3d onB = b.point + alongB * b.outward;
  Hypothesis h;
  h.type = JointType::Elbow;
  h.a = a;
  h.b = b;
  h.skew = (onA - onB).norm();
  h.skewLimit = skewLimit(smaller);
  if (h.skew > h.skewLimit) return;
  h.bendAngle = bendAngle;
  const bool aPastCorner = alongA < -overshoot;
  const bool bPastCorner = alongB < -overshoot;
  if ((aPastCorner && !sparselyPast(a, alongA)) || (bPastCorner && !sparselyPast(b, alongB))) return;
  h.endPastCorner = aPastCorner || bPastCorner;
  h.corner = 0.5 * (onA + onB);
  h.center = h.corner;
  const double longestTangent = params_.maxBendRadii * larger / std::tan(0.5 * (kPi - bendAngle));
  h.reach = std::max({alongA, alongB, longestTangent}) + 2.0 * larger + params_.supportDistance;
  out.push_back(std::move(h));
}

void JointBuilder::tryTeeBeyondEnd(const PipeEnd& branch, const PipeEnd& mainEnd, std::vector<Hypothesis>& out) const {
  auto h = teeAt(branch, mainEnd.pipe, /*mainSeenBeyond=*/false);
  if (!h) return;
  const double hidden = searchDistance(branch.radius);
  const double pastEnd = (h->corner - mainEnd.point).dot(mainEnd.outward);
  if (pastEnd <= 0.0 || pastEnd > hidden || (h->corner - branch.point).norm() > hidden) return;
  if (insideAnotherPipe(input_.pipes[static_cast<std::size_t>(branch.pipe)], input_.pipes, params_)) return;
  h->mainSeenOneSide = true;
  h->mainEnd = mainEnd;
  out.push_back(std::move(*h));
}

std::optional<Hypothesis> JointBuilder::teeForBendlessCorner(const Hypothesis& elbow,
                                                             const std::vector<std::uint32_t>& nearby) const {
  if (elbow.type != JointType::Elbow || !elbow.valid || !elbow.bendless) return std::nullopt;
  const auto reachToCorner = [&](const PipeEnd& end, const PipeEnd& other) {
    return (elbow.corner - end.point).dot(end.outward) / other.radius;
  };
  const bool aIsMain = reachToCorner(elbow.a, elbow.b) <= reachToCorner(elbow.b, elbow.a);
  for (const bool mainIsA : {aIsMain, !aIsMain}) {
    const PipeEnd& main = mainIsA ? elbow.a : elbow.b;
    const PipeEnd& branch = mainIsA ? elbow.b : elbow.a;
    auto tee = teeAt(branch, main.pipe, /*mainSeenBeyond=*/false);
    if (!tee) continue;
    tee->mainEnd = main;
    reconstructTee(*tee, nearby);
    tee->confidence *= 0.5;
    return tee;
  }
  return std::nullopt;
}

std::optional<Hypothesis> JointBuilder::teeAt(const PipeEnd& branch, int main, bool mainSeenBeyond) const {
  const PipeSegment& mainPipe = input_.pipes[static_cast<std::size_t>(main)];
  if (branch.radius > params_.maxBranchRatio * mainPipe.radius) return std::nullopt;
  const Eigen::Vector3d mainAxis = unitAxis(mainPipe);
  if (std::fabs(branch.outward.dot(mainAxis)) > std::cos(radians(params_.minTeeAngleDeg))) return std::nullopt;
  const auto parameters = closestLineParameters(branch.point, branch.outward, mainPipe.start, mainAxis);
  if (!parameters) return std::nullopt;
  const auto [alongBranch, alongMain] = *parameters;
  const double mainLength = (mainPipe.end - mainPipe.start).norm();
  // Well inside the main pipe's body: a branch meeting the main near its end is an elbow whose
  // pipe overshot the tangent point, or a corner of which nothing says it is a tee. Unless the
  // main's line carries on there in another pipe: the main broken at the junction.
  const double margin = 2.0 * branch.radius;
  if (mainSeenBeyond && ((alongMain < margin && !lineCarriesOn(main, alongMain - margin)) ||
                         (alongMain > mainLength - margin && !lineCarriesOn(main, alongMain + margin)))) {
    return std::nullopt;
  }
  Hypothesis h;
  h.type = JointType::Tee;
  h.a = branch;
  h.mainPipe = main;
  h.gap = alongBranch - mainPipe.radius;  // From the main pipe's surface to the branch end.
  // Like an elbow's ends, a branch looks for its main as far as the larger pipe is thick: a thin
  // branch's last diameters are the first lost to occlusion and sparse scan lines.
  h.gapLimit = searchDistance(std::max(branch.radius, mainPipe.radius));
  // The branch end stays inside the main's tube at most (a branch of the main's size shares
  // points with it around the junction, and its fit may reach through to the far wall).
  if (alongBranch < -mainPipe.radius || h.gap > h.gapLimit) return std::nullopt;
  h.skew = (branch.point + alongBranch * branch.outward - (mainPipe.start + alongMain * mainAxis)).norm();
  h.skewLimit = skewLimit(branch.radius);
  if (h.skew > h.skewLimit) return std::nullopt;
  h.corner = mainPipe.start + alongMain * mainAxis;
  h.center = 0.5 * (h.corner + branch.point);
  h.reach = 0.5 * alongBranch + mainPipe.radius + params_.supportDistance;
  return h;
}

bool JointBuilder::lineCarriesOn(int main, double along) const {
  const PipeSegment& mainPipe = input_.pipes[static_cast<std::size_t>(main)];
  const Eigen::Vector3d axis = unitAxis(mainPipe);
  const bool pastStart = along < 0.5 * (mainPipe.end - mainPipe.start).norm();
  const PipeEnd mainEnd = endOf(input_.pipes, main, pastStart ? 0 : 1);
  for (int other = 0; other < static_cast<int>(input_.pipes.size()); ++other) {
    if (other == main || isFragment(input_.pipes[static_cast<std::size_t>(other)], params_)) continue;
    for (int side = 0; side < 2; ++side) {
      if (!boundaryBetween(mainEnd, endOf(input_.pipes, other, side))) continue;
      const double farEnd = (endOf(input_.pipes, other, side ^ 1).point - mainPipe.start).dot(axis);
      if (pastStart ? farEnd <= along : farEnd >= along) return true;
    }
  }
  return false;
}

void JointBuilder::reconstruct(Hypothesis& h, const std::vector<std::uint32_t>& nearby) const {
  switch (h.type) {
    case JointType::Elbow: reconstructElbow(h, nearby); break;
    case JointType::Tee: reconstructTee(h, nearby); break;
    case JointType::Boundary: reconstructBoundary(h, nearby); break;
  }
}

double JointBuilder::straightCoverage(const Eigen::Vector3d& from, const Eigen::Vector3d& to, double r,
                                      const std::vector<std::uint32_t>& nearby,
                                      std::vector<std::uint32_t>& supportPoints) const {
  const double length = (to - from).norm();
  if (length < kSectionLength) return 1.0;
  const Eigen::Vector3d axis = (to - from) / length;
  const auto sections = static_cast<std::size_t>(std::ceil(length / kSectionLength));
  std::vector<char> covered(sections, 0);
  for (std::uint32_t i : nearby) {
    const Eigen::Vector3d d = position(i) - from;
    const double along = d.dot(axis);
    if (along < 0.0 || along >= length) continue;
    const Eigen::Vector3d radial = d - along * axis;
    const double distance = radial.norm();
    if (std::fabs(distance - r) > params_.supportDistance ||
        !normalAgrees(input_.cloud, i, radial / std::max(distance, 1e-12))) {
      continue;
    }
    covered[std::min(sections - 1, static_cast<std::size_t>(along / kSectionLength))] = 1;
    supportPoints.push_back(i);
  }
  return static_cast<double>(std::count(covered.begin(), covered.end(), 1)) / static_cast<double>(sections);
}

bool JointBuilder::sparselyPast(const PipeEnd& end, double along) const {
  const PipeSegment& pipe = input_.pipes[static_cast<std::size_t>(end.pipe)];
  const auto past = std::count_if(pipe.inliers.begin(), pipe.inliers.end(), [&](std::uint32_t i) {
    return (position(i) - end.point).dot(end.outward) > along;
  });
  return static_cast<double>(past) <= kMaxPastCornerDensity * linearDensity(end.pipe) * -along;
}

double JointBuilder::linearDensity(int pipe) const {
  const PipeSegment& segment = input_.pipes[static_cast<std::size_t>(pipe)];
  const double length = (segment.end - segment.start).norm();
  return length > 0.0 ? static_cast<double>(segment.inliers.size()) / length : 0.0;
}

void JointBuilder::reconstructElbow(Hypothesis& h, const std::vector<std::uint32_t>& nearby) const {
  const double r = 0.5 * (h.a.radius + h.b.radius);
  // Arms from the corner towards each pipe, in the common plane (the outward directions are
  // already orthogonal to its normal u_a × u_b).
  const Eigen::Vector3d armA = -h.a.outward;
  const Eigen::Vector3d armB = -h.b.outward;
  const Eigen::Vector3d normal = h.a.outward.cross(h.b.outward).normalized();
  const Eigen::Vector3d bisector = (armA + armB).normalized();
  const double halfAngle = 0.5 * (kPi - h.bendAngle);  // Half the angle between the arms.
  const double tangentPerRadius = 1.0 / std::tan(halfAngle);
  const double toEndA = (h.a.point - h.corner).dot(armA);
  const double toEndB = (h.b.point - h.corner).dot(armB);
  const auto seenTo = [](const PipeEnd& end, double toEnd) {
    return end.seenToEnd ? toEnd : std::numeric_limits<double>::infinity();
  };
  const double larger = std::max(h.a.radius, h.b.radius);
  // Not bounded by the ends: they stop short of the tangent points where occlusion cut them, and
  // overshoot into the elbow where its surface stays within the cylinder's inlier band.
  const double minBend = params_.minBendRadii * r;
  const double maxBend = std::max(minBend, std::min(params_.maxBendRadii * r, h.maxBendRadius));

  const auto onElbow = [&](const Eigen::Vector3d& p, double bendRadius, Eigen::Vector3d& radial) {
    const Eigen::Vector3d center = h.corner + bendRadius / std::sin(halfAngle) * bisector;
    const Eigen::Vector3d tangentA = h.corner + bendRadius * tangentPerRadius * armA;
    const Eigen::Vector3d tangentB = h.corner + bendRadius * tangentPerRadius * armB;
    if ((p - tangentA).dot(armA) > 0.0 || (p - tangentB).dot(armB) > 0.0 || (p - center).dot(bisector) > 0.0) {
      return false;  // Beyond a tangent plane, or on the far side of the torus.
    }
    Eigen::Vector3d inPlane = p - center;
    inPlane -= inPlane.dot(normal) * normal;
    const double length = inPlane.norm();
    if (length < 1e-12) return false;
    const Eigen::Vector3d tubeCenter = center + bendRadius * inPlane / length;
    radial = p - tubeCenter;
    return true;
  };

  // Votes for R (paper eqs. 3–4), accumulated in a histogram smoothed by a triangular kernel.
  // Points the straight pipes explain stay out: each ring of a pipe would vote for the R whose
  // tangent point it lies at, a plateau that buries the elbow's peak.
  const double binWidth = std::max(0.001, 0.02 * r);
  VoteHistogram histogram(minBend, maxBend, binWidth);
  std::vector<std::pair<double, std::uint32_t>> votes;
  for (std::uint32_t i : nearby) {
    if (explained_[i]) continue;
    const Eigen::Vector3d p = position(i);
    for (double bendRadius : elbowRadiusVotes(p, h.corner, bisector, normal, halfAngle, r)) {
      if (bendRadius < minBend || bendRadius > maxBend) continue;
      Eigen::Vector3d radial;
      if (!onElbow(p, bendRadius, radial) || !normalAgrees(input_.cloud, i, radial.normalized())) continue;
      votes.emplace_back(bendRadius, i);
      histogram.vote(bendRadius);
    }
  }
  // The bend: voted, or with no vote the widest fitting its ends allow. The tightest bend the
  // points allow: the voted one, or with no vote the one whose tangent point lies at the nearer
  // end seen straight up to where it stops.
  double bendRadius = 0.0;
  double tightest = 0.0;
  if (votes.empty()) {
    // No points to vote for the bend: the commonest fitting, a long-radius elbow, unless the pipes'
    // ends, seen straight up to where they stop, say tighter.
    const double nearestSeenEnd = std::min(seenTo(h.a, toEndA), seenTo(h.b, toEndB));
    bendRadius = unvotedBendRadius(h.bendAngle, nearestSeenEnd, params_.supportDistance,
                                   radians(kSupportNormalAngleDeg), kUnvotedEndSlack, minBend,
                                   std::clamp(kLongElbowRadii * r, minBend, maxBend));
    tightest = std::clamp(nearestSeenEnd / tangentPerRadius, minBend, maxBend);
  } else {
    const double peakRadius = histogram.peak().first;
    // Refine: the mean of the votes within two bins of the peak.
    double sum = 0.0;
    std::size_t count = 0;
    for (const auto& [vote, point] : votes) {
      if (std::fabs(vote - peakRadius) <= 2.0 * binWidth) {
        sum += vote;
        ++count;
      }
    }
    bendRadius = count > 0 ? sum / static_cast<double>(count) : peakRadius;
    tightest = bendRadius;
  }
  // An end past its corner farther than the elbow's own surface carries a fit (tryEndPair).
  if (h.endPastCorner && (votes.empty() || bendRadius < kMinFittingBendRadii * r)) return;

  // Support: points within the support distance of a torus, against those it would hold at the
  // pipes' linear density.
  const auto supportAt = [&](double R, std::vector<std::uint32_t>& points) {
    for (std::uint32_t i : nearby) {
      const Eigen::Vector3d p = position(i);
      Eigen::Vector3d radial;
      if (!onElbow(p, R, radial)) continue;
      const double distance = radial.norm();
      if (std::fabs(distance - r) <= params_.supportDistance &&
          normalAgrees(input_.cloud, i, radial / std::max(distance, 1e-12))) {
        points.push_back(i);
      }
    }
    return 0.5 * (linearDensity(h.a.pipe) + linearDensity(h.b.pipe)) * R * h.bendAngle;
  };
  const auto share = [](std::size_t points, double expected) {
    return expected > 0.0 ? std::min(1.0, static_cast<double>(points) / expected) : 0.0;
  };
  h.expectedSupport = supportAt(bendRadius, h.supportPoints);
  h.support = share(h.supportPoints.size(), h.expectedSupport);
  if (tightest < kMinFittingBendRadii * r) {
    // The chosen torus is the tightest when voted; else the tightest's support is counted apart.
    std::vector<std::uint32_t> tightPoints;
    const double tightExpected = votes.empty() ? supportAt(tightest, tightPoints) : h.expectedSupport;
    const std::size_t tightSupport = votes.empty() ? tightPoints.size() : h.supportPoints.size();
    h.bendless = share(tightSupport, tightExpected) <= kMaxBendlessSupport && tightExpected >= kMinBendlessEvidence;
  }

  const double tangent = bendRadius * tangentPerRadius;
  h.newA = h.corner + tangent * armA;
  h.newB = h.corner + tangent * armB;
  const double search = searchDistance(larger);
  // An end short of its tangent point leaves a gap nothing observed; an end past it is normal (the
  // elbow's surface stays within a cylinder's inlier band for a while, and near the corner the
  // other pipe's wall crosses the cylinder's extension).
  const double endGap = std::max({0.0, toEndA - tangent, toEndB - tangent});
  h.geometric = (1.0 - h.skew / h.skewLimit) * std::clamp(1.0 - endGap / search, 0.0, 1.0);
  h.confidence = 0.4 * h.geometric + 0.6 * h.support;
  h.bendRadius = bendRadius;
  const Eigen::Vector3d center = h.corner + bendRadius / std::sin(halfAngle) * bisector;
  h.axis = sampleArc(center, h.newA, h.newB, 0.01);
  h.valid = true;
}

void JointBuilder::reconstructTee(Hypothesis& h, const std::vector<std::uint32_t>& nearby) const {
  const PipeSegment& main = input_.pipes[static_cast<std::size_t>(h.mainPipe)];
  // A junction taken for hidden must be: points on or in a ball of the main's radius around the
  // corner are the main or a fitting seen there.
  if (h.mainSeenOneSide && std::any_of(nearby.begin(), nearby.end(), [&](std::uint32_t i) {
        return (input_.cloud.positions[i].cast<double>() - h.corner).norm() < main.radius + params_.supportDistance;
      })) {
    return;
  }
  // The gap between the main pipe's surface and the branch end is checked for points; a branch
  // that already reaches the main pipe is direct evidence.
  const Eigen::Vector3d toBranch = (h.a.point - h.corner).normalized();
  const Eigen::Vector3d surface = h.corner + main.radius * toBranch;
  const double branchGap = std::max(0.0, h.gap);
  h.support = branchGap <= std::max(kSectionLength, 0.5 * h.a.radius)
                  ? 1.0
                  : straightCoverage(surface, h.a.point, h.a.radius, nearby, h.supportPoints);
  h.geometric = (1.0 - h.skew / h.skewLimit) * (1.0 - branchGap / h.gapLimit);
  h.confidence = 0.5 * h.geometric + 0.5 * h.support;
  if (h.mainSeenOneSide) h.confidence *= 0.5;
  h.axis = {h.corner, h.a.point};
  h.valid = true;
}

void JointBuilder::reconstructBoundary(Hypothesis& h, const std::vector<std::uint32_t>& nearby) const {
  const double r = 0.5 * (h.a.radius + h.b.radius);
  h.support = straightCoverage(h.a.point, h.b.point, r, nearby, h.supportPoints);
  const double gap = std::max(0.0, h.gap);
  h.geometric = (1.0 - h.skew / h.skewLimit) * (1.0 - h.bendAngle / radians(params_.maxBoundaryAngleDeg)) *
                std::sqrt(1.0 - gap / h.gapLimit);
  // Gaps are mostly occlusions with no points in them: the geometry carries most of the weight.
  h.confidence = 0.7 * h.geometric + 0.3 * h.support;
  h.axis = {h.a.point, h.b.point};
  h.valid = true;
}

}  // namespace joints
}  // namespace piperun
