// Ends still free joined across what the scan does not show (see joint_hidden_legs.h).

#include "stages/joint_hidden_legs.h"

#include "angles.h"
#include "stages/segment_axis.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <optional>
#include <utility>
#include <vector>

namespace piperun::joints {

namespace {

// Points this close to the axis of a stretch an elbow would bridge across an occlusion, in its
// pipe's radius, are something else standing where the pipe would run (see bridgeOccludedCorners).
constexpr double kOccludedCoreRadii = 0.5;
// A leg between two seen bends (see joinSeenBends) turns square off both pipes it joins: their
// lines pass each other at least this far from parallel, and it runs along one of the network's
// directions within this.
constexpr double kSquareLegMinAngleDeg = 60.0;
constexpr double kSquareLegDirectionDeg = 3.0;
// A leg neither of whose bends was seen joins two ends only where their lines pass each other
// square within kSquareLegDirectionDeg and the pipes are this alike in radius (a run keeps its size
// through its elbows; a neighbour running beside it need not).
constexpr double kHiddenLegRadiusRatio = 0.9;
// A stretch a pipe runs on thinly to an elbow (see reachThinRuns) holds a point on its surface in at
// least this share of its sections of this length (m), and at most this many points per metre near
// its axis (outliers: a few per cubic metre of room).
constexpr double kMinThinCoverage = 0.5;
constexpr double kThinSectionLength = 0.25;
constexpr double kMaxThinCorePoints = 1.0;
// A stretch not seen thinly is carried on only where the two centre lines meet within this many
// radii of the thinner pipe (a quarter of the skew the joints allow).
constexpr double kMaxHiddenSkewRadii = 0.25;

/// The stretch of pipe from `end` to `tangent`, when the tangent point lies beyond the end.
std::optional<PipeSegment> stretchBeyond(const PipeEnd& end, const Eigen::Vector3d& tangent) {
  if ((tangent - end.point).dot(end.outward) <= 0.0) return std::nullopt;
  PipeSegment stretch;
  stretch.start = end.point;
  stretch.end = tangent;
  stretch.radius = end.radius;
  return stretch;
}

/// Whether nothing stands where a pipe bridged across an occlusion would run: its tube cuts no pipe
/// but those in `except`, and none of `points` lies near its axis.
bool nothingInTheWay(const PointCloud& cloud, const PipeSegment& stretch, std::initializer_list<int> except,
                     const std::vector<PipeSegment>& pipes, const JointsParams& params,
                     const std::vector<std::uint32_t>& points) {
  if (cutsAnotherPipe(stretch, except, pipes, params)) return false;
  const Eigen::Vector3d axis = stretch.end - stretch.start;
  const double length = axis.norm();
  return std::none_of(points.begin(), points.end(), [&](std::uint32_t i) {
    const Eigen::Vector3d w = cloud.positions[i].cast<double>() - stretch.start;
    const double along = w.dot(axis) / length;
    return along > 0.0 && along < length && (w - along * axis / length).norm() < kOccludedCoreRadii * stretch.radius;
  });
}

/// Adds to `resolution` the elbows among `candidates` (indices `viable`), best-supported first, whose
/// ends no joint took and which leave both their pipes a length; `onChosen(h)` sees each one just
/// before it goes in.
template <class OnChosen>
void chooseElbows(std::vector<Hypothesis>& candidates, std::vector<std::size_t> viable,
                  const std::vector<PipeSegment>& pipes, Resolution& resolution, OnChosen&& onChosen) {
  std::stable_sort(viable.begin(), viable.end(),
                   [&](std::size_t x, std::size_t y) { return candidates[x].confidence > candidates[y].confidence; });
  MovedEnds movedEnds(pipes);
  for (std::size_t h : resolution.chosen) {
    if (resolution.hypotheses[h].type == JointType::Elbow) movedEnds.move(resolution.hypotheses[h]);
  }
  for (std::size_t h : viable) {
    Hypothesis& candidate = candidates[h];
    auto& takenA = resolution.takenBy[static_cast<std::size_t>(candidate.a.key())];
    auto& takenB = resolution.takenBy[static_cast<std::size_t>(candidate.b.key())];
    if (takenA >= 0 || takenB >= 0 || !movedEnds.leaveLength(candidate)) continue;
    movedEnds.move(candidate);
    onChosen(h);
    takenA = takenB = static_cast<int>(resolution.hypotheses.size());
    resolution.chosen.push_back(resolution.hypotheses.size());
    resolution.hypotheses.push_back(std::move(candidate));
  }
}

}  // namespace

std::vector<PipeSegment> bridgeOccludedCorners(const JointsInput& input, const JointsParams& params,
                                               const std::vector<char>& explained, const PointCells& cells,
                                               Resolution& resolution) {
  std::vector<PipeSegment> stretches;
  if (params.occludedSearchDiameters <= params.searchDiameters) return stretches;
  const auto& pipes = input.pipes;
  const JointBuilder builder(input, params, explained);
  JointsParams occludedParams = params;
  occludedParams.searchDiameters = params.occludedSearchDiameters;
  const JointBuilder occludedBuilder(input, occludedParams, explained);

  const std::vector<PipeEnd> ends = freeEnds(pipes, params, resolution);
  std::vector<double> reaches;
  const double widestTangent = std::tan(0.5 * radians(params.maxElbowAngleDeg));
  for (const PipeEnd& end : ends) {
    // As far as tryEndPair lets two ends lie apart, for a partner as thick as an elbow allows.
    const double partner = end.radius / params.minRadiusRatio;
    reaches.push_back(2.0 * (occludedBuilder.searchDistance(partner) + params.minBendRadii * partner * widestTangent) +
                      occludedBuilder.skewLimit(partner));
  }
  std::vector<Hypothesis> candidates;
  std::vector<Hypothesis> within;
  for (const auto& [e, f] : endPairsWithin(ends, reaches)) {
    within.clear();
    builder.tryEndPair(ends[e], ends[f], within);
    if (!within.empty()) continue;  // The resolution weighed this pair already.
    const std::size_t before = candidates.size();
    occludedBuilder.tryEndPair(ends[e], ends[f], candidates);
    candidates.erase(std::remove_if(candidates.begin() + static_cast<std::ptrdiff_t>(before), candidates.end(),
                                    [](const Hypothesis& h) { return h.type != JointType::Elbow; }),
                     candidates.end());
  }
  if (candidates.empty()) return stretches;

  std::vector<std::pair<Eigen::Vector3d, double>> spheres;
  for (const auto& candidate : candidates) spheres.emplace_back(candidate.center, candidate.reach);
  const auto nearby = pointsInSpheres(cells, spheres, [](std::size_t) { return true; });
  tbb::parallel_for(std::size_t{0}, candidates.size(),
                    [&](std::size_t h) { builder.reconstruct(candidates[h], nearby[h]); });

  std::vector<std::array<std::optional<PipeSegment>, 2>> bridges(candidates.size());
  std::vector<std::size_t> order;
  for (std::size_t h = 0; h < candidates.size(); ++h) {
    const Hypothesis& candidate = candidates[h];
    bridges[h] = {stretchBeyond(candidate.a, candidate.newA), stretchBeyond(candidate.b, candidate.newB)};
    if (std::all_of(bridges[h].begin(), bridges[h].end(), [&](const std::optional<PipeSegment>& stretch) {
          return !stretch ||
                 nothingInTheWay(input.cloud, *stretch, {candidate.a.pipe, candidate.b.pipe}, pipes, params, nearby[h]);
        })) {
      order.push_back(h);
    }
  }
  chooseElbows(candidates, std::move(order), pipes, resolution, [&](std::size_t h) {
    for (const auto& stretch : bridges[h]) {
      if (stretch) stretches.push_back(*stretch);
    }
    ++resolution.diagnostics.occludedElbows;
  });
  return stretches;
}

std::vector<PipeSegment> reachThinRuns(const JointsInput& input, const JointsParams& params,
                                       const std::vector<char>& explained, const PointCells& cells, Resolution& resolution) {
  std::vector<PipeSegment> stretches;
  if (params.maxThinStretch <= 0.0) return stretches;
  const auto& pipes = input.pipes;
  const JointBuilder builder(input, params, explained);
  // The far end may lie anywhere up to maxThinStretch from the corner.
  JointsParams farParams = params;
  farParams.minSearchDistance = std::max(params.minSearchDistance, params.maxThinStretch);
  const JointBuilder farBuilder(input, farParams, explained);

  const std::vector<PipeEnd> ends = freeEnds(pipes, params, resolution);
  std::vector<double> reaches;
  for (const PipeEnd& end : ends) reaches.push_back(builder.searchDistance(end.radius) + params.maxThinStretch);
  std::vector<Hypothesis> candidates;
  std::vector<std::size_t> farEnds;  // Per candidate: 0 when its end `a` runs on thinly, 1 when `b` does.
  std::vector<Hypothesis> made;
  for (const auto& [e, f] : endPairsWithin(ends, reaches)) {
    made.clear();
    farBuilder.tryEndPair(ends[e], ends[f], made);
    if (made.size() != 1 || made[0].type != JointType::Elbow) continue;
    Hypothesis& h = made[0];
    const double alongA = (h.corner - h.a.point).dot(h.a.outward);
    const double alongB = (h.corner - h.b.point).dot(h.b.outward);
    const bool aNear = alongA <= builder.searchDistance(h.a.radius);
    const bool bNear = alongB <= builder.searchDistance(h.b.radius);
    if (aNear == bNear) continue;  // Both near: the resolution weighed it; both far: nothing reaches it.
    // Only the bend's surroundings vote for its radius; the stretch is looked at on its own. The
    // near pipe was seen straight up to its end: the bend starts at most a radius back along it.
    const double larger = std::max(h.a.radius, h.b.radius);
    const double radiusPerTangent = std::tan(0.5 * (kPi - h.bendAngle));  // Bend radius per tangent length.
    h.center = h.corner;
    h.reach = params.maxBendRadii * larger / radiusPerTangent + 2.0 * larger + params.supportDistance;
    h.maxBendRadius = ((aNear ? alongA : alongB) + (aNear ? h.a : h.b).radius) * radiusPerTangent;
    farEnds.push_back(aNear ? 1 : 0);
    candidates.push_back(std::move(h));
  }
  if (candidates.empty()) return stretches;

  std::vector<std::pair<Eigen::Vector3d, double>> spheres;
  for (const auto& candidate : candidates) spheres.emplace_back(candidate.center, candidate.reach);
  const auto nearby = pointsInSpheres(cells, spheres, [](std::size_t) { return true; });
  std::vector<PipeSegment> thin(candidates.size());
  std::vector<double> seen(candidates.size(), 0.0);
  std::vector<char> viable(candidates.size(), 0);
  std::vector<char> hidden(candidates.size(), 0);
  tbb::parallel_for(std::size_t{0}, candidates.size(), [&](std::size_t h) {
    Hypothesis& candidate = candidates[h];
    builder.reconstruct(candidate, nearby[h]);
    if (!candidate.valid) return;
    const PipeEnd& far = farEnds[h] == 0 ? candidate.a : candidate.b;
    const auto stretch = stretchBeyond(far, farEnds[h] == 0 ? candidate.newA : candidate.newB);
    if (!stretch || cutsAnotherPipe(*stretch, {candidate.a.pipe, candidate.b.pipe}, pipes, params)) return;
    thin[h] = *stretch;
    const double length = (stretch->end - stretch->start).norm();
    const Eigen::Vector3d axis = (stretch->end - stretch->start) / length;
    const auto near = pointsNearSegment(cells, stretch->start, stretch->end, stretch->radius + params.supportDistance,
                                        [](std::size_t) { return true; });
    // Seen all along, in long sections, and how much of it in the usual short ones; stray points
    // near the axis are few. No normal is asked for: on a thin, far pipe they stray.
    const auto coarseSections = static_cast<std::size_t>(std::ceil(length / kThinSectionLength));
    const auto fineSections = static_cast<std::size_t>(std::ceil(length / kSectionLength));
    std::vector<char> coarse(coarseSections, 0), fine(fineSections, 0);
    std::size_t core = 0;
    for (std::uint32_t i : near) {
      const Eigen::Vector3d w = input.cloud.positions[i].cast<double>() - stretch->start;
      const double along = w.dot(axis);
      if (along <= 0.0 || along >= length) continue;
      const Eigen::Vector3d radial = w - along * axis;
      const double distance = radial.norm();
      if (distance < kOccludedCoreRadii * stretch->radius) ++core;
      if (explained[i] || std::fabs(distance - stretch->radius) > params.supportDistance) continue;
      coarse[std::min(coarseSections - 1, static_cast<std::size_t>(along / kThinSectionLength))] = 1;
      fine[std::min(fineSections - 1, static_cast<std::size_t>(along / kSectionLength))] = 1;
    }
    const auto share = [](const std::vector<char>& sections) {
      return static_cast<double>(std::count(sections.begin(), sections.end(), 1)) / static_cast<double>(sections.size());
    };
    if (static_cast<double>(core) > kMaxThinCorePoints * length) return;
    const bool thinly = share(coarse) >= kMinThinCoverage;
    if (!thinly && candidate.skew > kMaxHiddenSkewRadii * std::min(candidate.a.radius, candidate.b.radius)) return;
    hidden[h] = thinly ? 0 : 1;
    seen[h] = share(fine);
    viable[h] = 1;
  });

  std::vector<std::size_t> order;
  for (std::size_t h = 0; h < candidates.size(); ++h) {
    if (viable[h]) order.push_back(h);
  }
  chooseElbows(candidates, std::move(order), pipes, resolution, [&](std::size_t h) {
    stretches.push_back(std::move(thin[h]));
    candidates[h].confidence = std::min(candidates[h].confidence, seen[h]);
    ++(hidden[h] ? resolution.diagnostics.hiddenRunElbows : resolution.diagnostics.thinRunElbows);
  });
  return stretches;
}

namespace {

/// A leg between the free ends of two pipes whose lines pass each other askew, or run parallel
/// with the ends facing past each other (see joinSeenBends): the lines' common perpendicular, from
/// the corner on `from`'s line to the corner on `to`'s.
struct SquareLeg {
  PipeSegment pipe;
  PipeEnd from;
  PipeEnd to;
  // The ends' lines pass square, or run parallel, and their pipes are alike: no bend need be seen.
  bool mayBeHidden = false;
};

/// Whether `axis` runs along one of `directions` within kSquareLegDirectionDeg.
bool alongOneOf(const std::vector<Eigen::Vector3d>& directions, const Eigen::Vector3d& axis) {
  return std::any_of(directions.begin(), directions.end(), [&](const Eigen::Vector3d& direction) {
    return std::fabs(direction.dot(axis)) >= std::cos(radians(kSquareLegDirectionDeg));
  });
}

/// Whether another of the `pipes`, as thick, carries the line of `end` on ahead of it, its near end
/// within `reach`.
bool lineCarriedOn(const PipeEnd& end, const std::vector<PipeSegment>& pipes, double reach, const JointBuilder& builder) {
  for (int other = 0; other < static_cast<int>(pipes.size()); ++other) {
    const PipeSegment& pipe = pipes[static_cast<std::size_t>(other)];
    if (other == end.pipe || std::min(pipe.radius, end.radius) < kHiddenLegRadiusRatio * std::max(pipe.radius, end.radius) ||
        std::fabs(unitAxis(pipe).dot(end.outward)) < std::cos(radians(kSquareLegDirectionDeg))) {
      continue;
    }
    const double startAhead = (pipe.start - end.point).dot(end.outward);
    const double endAhead = (pipe.end - end.point).dot(end.outward);
    const Eigen::Vector3d& near = startAhead < endAhead ? pipe.start : pipe.end;
    const double ahead = std::min(startAhead, endAhead);
    if (ahead > 0.0 && ahead <= reach && distanceToLine(near, end.point, end.outward) <= builder.skewLimit(end.radius)) {
      return true;
    }
  }
  return false;
}

/// The legs that may join pairs of the free `ends`: where two ends' lines pass each other askew
/// and near square, their common perpendicular; where they run parallel (within
/// kSquareLegDirectionDeg) with each end facing past the other (an offset) and no pipe as thick
/// carries either line on ahead, the perpendicular between them in the middle of the gap between
/// the ends. Either is kept when it runs along one of the network's `directions`, is long enough for an
/// elbow at each corner and no longer than a completion, and each corner lies on its end's line
/// within the search distance ahead of it.
std::vector<SquareLeg> squareLegCandidates(const std::vector<PipeEnd>& ends, const std::vector<PipeSegment>& pipes,
                                           const std::vector<Eigen::Vector3d>& directions, const JointsParams& params,
                                           const JointBuilder& builder) {
  // Ahead of the end, or behind it by as much as a pipe fitted into a square elbow overshoots the
  // corner (see tryEndPair).
  const auto cornerInReach = [&](const PipeEnd& end, double along) {
    return along >= -1.25 * end.radius && along <= builder.searchDistance(end.radius);
  };
  std::vector<double> reaches;
  for (const PipeEnd& end : ends) {
    reaches.push_back(2.0 * builder.searchDistance(end.radius / params.minRadiusRatio) + params.maxCompletionLength);
  }
  std::vector<SquareLeg> legs;
  for (const auto& [e, f] : endPairsWithin(ends, reaches)) {
    const PipeEnd& a = ends[e];
    const PipeEnd& b = ends[f];
    if (std::min(a.radius, b.radius) < params.minRadiusRatio * std::max(a.radius, b.radius)) continue;
    const bool alike = std::min(a.radius, b.radius) >= kHiddenLegRadiusRatio * std::max(a.radius, b.radius);
    const double cosine = a.outward.dot(b.outward);
    std::optional<std::pair<double, double>> parameters;
    bool mayBeHidden = false;
    if (std::fabs(cosine) <= std::cos(radians(kSquareLegMinAngleDeg))) {
      parameters = closestLineParameters(a.point, a.outward, b.point, b.outward);
      mayBeHidden = std::fabs(cosine) <= std::sin(radians(kSquareLegDirectionDeg)) && alike;
    } else if (cosine <= -std::cos(radians(kSquareLegDirectionDeg)) &&
               !lineCarriedOn(a, pipes, reaches[e], builder) && !lineCarriedOn(b, pipes, reaches[f], builder)) {
      // Parallel, each end facing past the other: an offset, its leg square to both in the middle
      // of the gap between the ends (where their bends meet when both were seen up to them). Not
      // where a pipe carries an end's line on ahead: that pipe was only hidden for a stretch.
      const double half = 0.5 * (b.point - a.point).dot(a.outward);
      parameters = std::pair{half, half};
      mayBeHidden = alike;
    }
    if (!parameters || !cornerInReach(a, parameters->first) || !cornerInReach(b, parameters->second)) continue;
    const Eigen::Vector3d cornerA = a.point + parameters->first * a.outward;
    const Eigen::Vector3d cornerB = b.point + parameters->second * b.outward;
    const double length = (cornerB - cornerA).norm();
    const double radius = 0.5 * (a.radius + b.radius);
    if (length < 2.0 * params.minBendRadii * radius + kSectionLength || length > params.maxCompletionLength ||
        !alongOneOf(directions, (cornerB - cornerA) / length)) {
      continue;
    }
    SquareLeg& leg = legs.emplace_back();
    leg.pipe.start = cornerA;
    leg.pipe.end = cornerB;
    leg.pipe.radius = radius;
    leg.from = a;
    leg.to = b;
    leg.mayBeHidden = mayBeHidden;
  }
  return legs;
}

/// Whether an elbow's bend off an end of `pipe` was seen, at the density of that pipe.
bool bendSeen(const Hypothesis& elbow, const PipeSegment& pipe) {
  const double expected =
      static_cast<double>(pipe.inliers.size()) / (pipe.end - pipe.start).norm() * elbow.bendRadius * elbow.bendAngle;
  return expected >= kMinBendlessEvidence &&
         static_cast<double>(elbow.supportPoints.size()) >= kMaxBendlessSupport * expected;
}

/// The spheres whose points a leg's two joints and the leg itself are built with, appended to
/// `spheres`: each joint's (an empty one where the joints could not be made), then one around the leg.
void addLegSpheres(const std::vector<Hypothesis>& joints, const PipeSegment& leg,
                   std::vector<std::pair<Eigen::Vector3d, double>>& spheres) {
  for (std::size_t j = 0; j < 2; ++j) {
    spheres.emplace_back(joints.empty() ? leg.start : joints[j].center, joints.empty() ? 0.0 : joints[j].reach);
  }
  spheres.emplace_back(0.5 * (leg.start + leg.end), 0.5 * (leg.end - leg.start).norm() + 2.0 * leg.radius);
}

/// Adds a chosen leg's `joints` to `resolution` (elbows moving their ends in `movedEnds`), their
/// ends on the candidate pipe `candidatePipe` now on the leg, which goes after the `inputPipes`
/// and the legs chosen before it; their confidence is capped at the share of the leg seen.
void adoptLeg(std::vector<Hypothesis>& joints, int candidatePipe, PipeSegment leg, double coverage,
              std::size_t inputPipes, MovedEnds& movedEnds, Resolution& resolution,
              std::vector<PipeSegment>& chosenLegs) {
  const int pipe = static_cast<int>(inputPipes + chosenLegs.size());
  auto& takenBy = resolution.takenBy;
  takenBy.resize(2 * static_cast<std::size_t>(pipe + 1), -1);
  resolution.arcPieces.push_back(0);
  for (Hypothesis& joint : joints) {
    if (joint.type == JointType::Elbow) movedEnds.move(joint);
    for (PipeEnd* end : {&joint.a, &joint.b}) {
      if (end->pipe == candidatePipe) end->pipe = pipe;
    }
    joint.confidence = std::min(joint.confidence, coverage);
    const auto index = static_cast<int>(resolution.hypotheses.size());
    takenBy[static_cast<std::size_t>(joint.a.key())] = index;
    if (joint.type != JointType::Tee) takenBy[static_cast<std::size_t>(joint.b.key())] = index;
    resolution.chosen.push_back(resolution.hypotheses.size());
    resolution.hypotheses.push_back(std::move(joint));
  }
  leg.confidence = coverage;
  chosenLegs.push_back(std::move(leg));
}

/// The input pipes followed by candidate legs, each a pipe of its own to build its joints with,
/// and a joint builder over them all.
class WithLegs {
 public:
  WithLegs(const JointsInput& input, const std::vector<PipeSegment>& legs, const JointsParams& params,
           const std::vector<char>& explained)
      : inputPipes_(input.pipes.size()),
        pipes_(appended(input.pipes, legs)),
        input_{input.cloud, pipes_},
        builder_(input_, params, explained) {}
  WithLegs(const WithLegs&) = delete;
  WithLegs& operator=(const WithLegs&) = delete;

  /// The input pipes, then the legs.
  const std::vector<PipeSegment>& pipes() const { return pipes_; }
  std::size_t legCount() const { return pipes_.size() - inputPipes_; }
  /// Candidate leg k's index among pipes().
  int legPipe(std::size_t k) const { return static_cast<int>(inputPipes_ + k); }
  const JointBuilder& builder() const { return builder_; }

 private:
  static std::vector<PipeSegment> appended(const std::vector<PipeSegment>& pipes, const std::vector<PipeSegment>& legs) {
    std::vector<PipeSegment> all = pipes;
    all.insert(all.end(), legs.begin(), legs.end());
    return all;
  }

  std::size_t inputPipes_;
  std::vector<PipeSegment> pipes_;
  JointsInput input_;  // refers to pipes_
  JointBuilder builder_;  // refers to input_
};

/// The joints at both ends of each candidate leg: `make(k, legFrom, legTo, made)` tries them with
/// the leg's own ends marked unseen (it is drawn between corners, not seen up to them), and they are
/// kept when they come out as `first` and `second`. Also the points near each leg's two joints and
/// along it: three spheres a leg, as addLegSpheres gives them.
struct LegJoints {
  std::vector<std::vector<Hypothesis>> joints;
  std::vector<std::vector<std::uint32_t>> nearby;
};

template <typename Make>
LegJoints jointsAtLegEnds(const WithLegs& withLegs, JointType first, JointType second, const PointCells& cells, Make&& make) {
  LegJoints legs;
  legs.joints.resize(withLegs.legCount());
  std::vector<std::pair<Eigen::Vector3d, double>> spheres;
  for (std::size_t k = 0; k < legs.joints.size(); ++k) {
    const int legPipe = withLegs.legPipe(k);
    PipeEnd legFrom = endOf(withLegs.pipes(), legPipe, 0), legTo = endOf(withLegs.pipes(), legPipe, 1);
    legFrom.seenToEnd = legTo.seenToEnd = false;
    std::vector<Hypothesis> made;
    make(k, legFrom, legTo, made);
    if (made.size() == 2 && made[0].type == first && made[1].type == second) legs.joints[k] = std::move(made);
    addLegSpheres(legs.joints[k], withLegs.pipes()[static_cast<std::size_t>(legPipe)], spheres);
  }
  legs.nearby = pointsInSpheres(cells, spheres, [](std::size_t) { return true; });
  return legs;
}

}  // namespace

std::vector<PipeSegment> joinSeenBends(const JointsInput& input, const JointsParams& params,
                                       const std::vector<char>& explained, const PointCells& cells, Resolution& resolution) {
  std::vector<PipeSegment> chosenLegs;
  if (params.maxCompletionLength <= 0.0) return chosenLegs;
  const auto& pipes = input.pipes;
  const std::vector<SquareLeg> candidates =
      squareLegCandidates(freeEnds(pipes, params, resolution), pipes, networkDirections(pipes), params,
                          JointBuilder(input, params, explained));
  if (candidates.empty()) return chosenLegs;

  std::vector<PipeSegment> legs;
  for (const SquareLeg& leg : candidates) legs.push_back(leg.pipe);
  const WithLegs withLegs(input, legs, params, explained);
  const JointBuilder& builder = withLegs.builder();
  // Per candidate: the elbow at `from`, then the one at `to`.
  const auto tryJoints = [&](std::size_t k, const PipeEnd& legFrom, const PipeEnd& legTo, auto& made) {
    builder.tryEndPair(candidates[k].from, legFrom, made);
    builder.tryEndPair(legTo, candidates[k].to, made);
  };
  LegJoints legJoints = jointsAtLegEnds(withLegs, JointType::Elbow, JointType::Elbow, cells, tryJoints);
  std::vector<std::vector<Hypothesis>>& elbows = legJoints.joints;
  const std::vector<std::vector<std::uint32_t>>& nearby = legJoints.nearby;

  // The leg between its tangent points, the share of its sections seen, and whether both bends
  // were seen and nothing stands in the way of what the elbows bridge.
  std::vector<PipeSegment> between(candidates.size());
  std::vector<double> coverage(candidates.size(), 0.0);
  std::vector<char> viable(candidates.size(), 0);
  std::vector<char> hidden(candidates.size(), 0);  // A bend was not seen.
  tbb::parallel_for(std::size_t{0}, candidates.size(), [&](std::size_t k) {
    if (elbows[k].empty()) return;
    const SquareLeg& leg = candidates[k];
    Hypothesis& near = elbows[k][0];
    Hypothesis& far = elbows[k][1];
    builder.reconstruct(near, nearby[3 * k]);
    builder.reconstruct(far, nearby[3 * k + 1]);
    if (!near.valid || !far.valid) return;
    hidden[k] = !bendSeen(near, pipes[static_cast<std::size_t>(leg.from.pipe)]) ||
                !bendSeen(far, pipes[static_cast<std::size_t>(leg.to.pipe)]);
    if (hidden[k] && !leg.mayBeHidden) return;
    PipeSegment& stretch = between[k];
    stretch = leg.pipe;
    stretch.start = near.newB;
    stretch.end = far.newA;
    if ((stretch.end - stretch.start).dot(unitAxis(leg.pipe)) < kSectionLength) return;
    coverage[k] = builder.straightCoverage(stretch.start, stretch.end, stretch.radius, nearby[3 * k + 2], stretch.inliers);
    const auto inTheClear = [&](const std::optional<PipeSegment>& piece, const std::vector<std::uint32_t>& points) {
      return !piece || nothingInTheWay(input.cloud, *piece, {leg.from.pipe, leg.to.pipe}, pipes, params, points);
    };
    viable[k] = inTheClear(stretchBeyond(leg.from, near.newA), nearby[3 * k]) && inTheClear(stretch, nearby[3 * k + 2]) &&
                inTheClear(stretchBeyond(leg.to, far.newB), nearby[3 * k + 1]);
  });

  std::vector<std::size_t> order;
  for (std::size_t k = 0; k < candidates.size(); ++k) {
    if (viable[k]) order.push_back(k);
  }
  const auto support = [&](std::size_t k) { return std::min(elbows[k][0].confidence, elbows[k][1].confidence); };
  std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return support(x) > support(y); });
  MovedEnds movedEnds(withLegs.pipes());
  for (std::size_t h : resolution.chosen) {
    if (resolution.hypotheses[h].type == JointType::Elbow) movedEnds.move(resolution.hypotheses[h]);
  }
  auto& takenBy = resolution.takenBy;
  for (std::size_t k : order) {
    const SquareLeg& leg = candidates[k];
    if (takenBy[static_cast<std::size_t>(leg.from.key())] >= 0 || takenBy[static_cast<std::size_t>(leg.to.key())] >= 0 ||
        !movedEnds.leaveLength(elbows[k][0]) || !movedEnds.leaveLength(elbows[k][1]) ||
        cutsAnotherPipe(between[k], {}, chosenLegs, params)) {
      continue;
    }
    PipeSegment chosen = leg.pipe;
    chosen.inliers = std::move(between[k].inliers);
    adoptLeg(elbows[k], withLegs.legPipe(k), std::move(chosen), coverage[k], pipes.size(), movedEnds, resolution, chosenLegs);
    ++(hidden[k] ? resolution.diagnostics.hiddenLegs : resolution.diagnostics.legsBetweenBends);
  }
  return chosenLegs;
}

std::vector<PipeSegment> joinHiddenBranches(const JointsInput& input, const JointsParams& params,
                                            const std::vector<char>& explained, const PointCells& cells,
                                            Resolution& resolution) {
  std::vector<PipeSegment> chosenLegs;
  if (params.maxCompletionLength <= 0.0) return chosenLegs;
  const auto& pipes = input.pipes;
  const JointBuilder searching(input, params, explained);
  const std::vector<Eigen::Vector3d> directions = networkDirections(pipes);
  struct Candidate {
    PipeEnd end;
    int main = -1;
    PipeSegment leg;  // From the corner on the end's line to the main's wall.
    bool beside = false;  // The end's pipe runs beside the main (else square to it).
  };
  std::vector<Candidate> candidates;
  for (const PipeEnd& end : freeEnds(pipes, params, resolution)) {
    for (int main = 0; main < static_cast<int>(pipes.size()); ++main) {
      const PipeSegment& mainPipe = pipes[static_cast<std::size_t>(main)];
      if (main == end.pipe || isFragment(mainPipe, params) || resolution.arcPieces[static_cast<std::size_t>(main)] ||
          mainPipe.radius < end.radius || end.radius > params.maxBranchRatio * mainPipe.radius) {
        continue;
      }
      const Eigen::Vector3d mainAxis = unitAxis(mainPipe);
      const double mainLength = (mainPipe.end - mainPipe.start).norm();
      const double cosine = std::fabs(end.outward.dot(mainAxis));
      Eigen::Vector3d corner;
      double alongMain = 0.0;
      const bool beside = cosine >= std::cos(radians(kSquareLegDirectionDeg));
      if (cosine <= std::sin(radians(kSquareLegDirectionDeg))) {
        // Square to the main: the lines' common perpendicular.
        const auto parameters = closestLineParameters(end.point, end.outward, mainPipe.start, mainAxis);
        if (!parameters) continue;
        const double alongEnd = parameters->first;
        if (alongEnd < -1.25 * end.radius || alongEnd > searching.searchDistance(end.radius)) continue;
        corner = end.point + alongEnd * end.outward;
        alongMain = parameters->second;
      } else if (beside) {
        // Beside the main: the end was seen up to a short-radius elbow's tangent point.
        corner = end.point + kShortElbowRadii * end.radius * end.outward;
        alongMain = (corner - mainPipe.start).dot(mainAxis);
      } else {
        continue;
      }
      if (alongMain < 2.0 * end.radius || alongMain > mainLength - 2.0 * end.radius) continue;
      const Eigen::Vector3d foot = mainPipe.start + alongMain * mainAxis;
      const double length = (foot - corner).norm();
      if (length < params.minBendRadii * end.radius + mainPipe.radius + kSectionLength ||
          length > params.maxCompletionLength + mainPipe.radius || !alongOneOf(directions, (foot - corner) / length)) {
        continue;
      }
      Candidate& candidate = candidates.emplace_back();
      candidate.end = end;
      candidate.main = main;
      candidate.leg.start = corner;
      candidate.leg.end = foot + mainPipe.radius * (corner - foot) / length;
      candidate.leg.radius = end.radius;
      candidate.beside = beside;
    }
  }
  if (candidates.empty()) return chosenLegs;

  std::vector<PipeSegment> legs;
  for (const Candidate& candidate : candidates) legs.push_back(candidate.leg);
  const WithLegs withLegs(input, legs, params, explained);
  const JointBuilder& builder = withLegs.builder();
  // Per candidate: the elbow at the end, then the tee on the main.
  const auto tryJoints = [&](std::size_t k, const PipeEnd& legFrom, const PipeEnd& legTo, auto& made) {
    builder.tryEndPair(candidates[k].end, legFrom, made);
    builder.tryTee(legTo, candidates[k].main, made);
  };
  LegJoints legJoints = jointsAtLegEnds(withLegs, JointType::Elbow, JointType::Tee, cells, tryJoints);
  std::vector<std::vector<Hypothesis>>& joints = legJoints.joints;
  const std::vector<std::vector<std::uint32_t>>& nearby = legJoints.nearby;

  std::vector<PipeSegment> between(candidates.size());
  std::vector<double> coverage(candidates.size(), 0.0);
  std::vector<char> viable(candidates.size(), 0);
  tbb::parallel_for(std::size_t{0}, candidates.size(), [&](std::size_t k) {
    if (joints[k].empty()) return;
    const Candidate& candidate = candidates[k];
    Hypothesis& elbow = joints[k][0];
    Hypothesis& tee = joints[k][1];
    builder.reconstruct(elbow, nearby[3 * k]);
    builder.reconstruct(tee, nearby[3 * k + 1]);
    if (!elbow.valid || !tee.valid) return;
    // Its bend was seen (a leg beside the main starts where a short-radius elbow's would: its
    // points are looked for there).
    Hypothesis assumed = elbow;
    if (candidate.beside) assumed.bendRadius = kShortElbowRadii * candidate.end.radius;
    if (!bendSeen(assumed, pipes[static_cast<std::size_t>(candidate.end.pipe)])) return;
    PipeSegment& stretch = between[k];
    stretch = candidate.leg;
    stretch.start = elbow.newB;
    if ((stretch.end - stretch.start).dot(unitAxis(candidate.leg)) < kSectionLength) return;
    coverage[k] = builder.straightCoverage(stretch.start, stretch.end, stretch.radius, nearby[3 * k + 2], stretch.inliers);
    const auto inTheClear = [&](const std::optional<PipeSegment>& piece, const std::vector<std::uint32_t>& points) {
      return !piece || nothingInTheWay(input.cloud, *piece, {candidate.end.pipe, candidate.main}, pipes, params, points);
    };
    // (The main's own surface, where the leg meets it, stands in no leg's way.)
    PipeSegment clearOfMain = stretch;
    clearOfMain.end -= params.supportDistance * unitAxis(candidate.leg);
    viable[k] = coverage[k] > 0.0 && inTheClear(stretchBeyond(candidate.end, elbow.newA), nearby[3 * k]) &&
                inTheClear(clearOfMain, nearby[3 * k + 2]);
  });

  std::vector<std::size_t> order;
  for (std::size_t k = 0; k < candidates.size(); ++k) {
    if (viable[k]) order.push_back(k);
  }
  const auto support = [&](std::size_t k) { return std::min(joints[k][0].confidence, joints[k][1].confidence); };
  std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return support(x) > support(y); });
  MovedEnds movedEnds(withLegs.pipes());
  for (std::size_t h : resolution.chosen) {
    if (resolution.hypotheses[h].type == JointType::Elbow) movedEnds.move(resolution.hypotheses[h]);
  }
  auto& takenBy = resolution.takenBy;
  for (std::size_t k : order) {
    const Candidate& candidate = candidates[k];
    if (takenBy[static_cast<std::size_t>(candidate.end.key())] >= 0 || !movedEnds.leaveLength(joints[k][0]) ||
        cutsAnotherPipe(between[k], {}, chosenLegs, params)) {
      continue;
    }
    PipeSegment chosen = candidate.leg;
    chosen.inliers = std::move(between[k].inliers);
    adoptLeg(joints[k], withLegs.legPipe(k), std::move(chosen), coverage[k], pipes.size(), movedEnds, resolution, chosenLegs);
    ++resolution.diagnostics.hiddenBranches;
  }
  return chosenLegs;
}

}  // namespace piperun::joints
