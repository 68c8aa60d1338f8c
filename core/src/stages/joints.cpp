// Joints and pipe-runs (paper §6).
//
// 0. Pipes whose tube reaches below the ground (the lowest floor, nothing scanned under it) go,
//    and no leg completed later may reach there (Ground). Pipes that overlap at a gentle bend, one
//    fitted across it, are split at its corner, and a pipe fitted across such a bend with no pipe
//    found beyond it yields the leg beyond (gentle_kinks.h): no hypothesis below would join them.
// 1. Hypotheses. A hash grid over the pipes' axis samples gives, for each pipe end, the pipes
//    near it. Each end–end pair whose axes continue each other is a boundary-joint hypothesis;
//    each end–end pair whose axes meet ahead of both ends at a bend angle is an elbow hypothesis;
//    each end whose extension meets another pipe's body is a T-junction hypothesis, and so is a
//    thinner end whose extension meets a thicker pipe's line past its end, both hidden at the
//    junction (too unequal for an elbow). Every limit scales with the radii.
// 2. Reconstruction. Elbows: the two axes are forced onto their common mid-plane and intersected
//    at the corner P_I; the bend centre lies on the bisector, and each point near the corner votes
//    for the major radii R that put it on the torus (paper eqs. 3–4); the most voted R wins and the
//    pipes are trimmed or extended to the tangent points. Tees: the branch's end is extended to
//    the main pipe's axis. Boundary joints bridge the gap between collinear ends.
// 3. Confidence = how well the criteria hold, blended with the point support on the joint's
//    surface; the best-supported hypothesis takes an end first, an end takes at most one joint,
//    and no joint turns a main's end short of a tee that its line is carried on to past that end.
//    An elbow whose bend would leave a pipe shorter than a section, after an elbow chosen before
//    it trimmed that pipe's far end, is voted again with its bend bounded by the room left, and
//    taken when that torus holds half the points it would at its pipes' density, or more than the
//    wider bend did (a short pipe between two bends).
//    A piece of an elbow's arc fitted as a cylinder makes two elbows of one: a pipe lying on the
//    arc of a confident elbow between two other pipes waits for that elbow, and goes when it is
//    chosen; the elbow, voted without the piece's points (and the fragments' in its bend), is voted
//    again with them. Where the piece took an elbow at each end all the same, leaving little of it
//    straight (or one, the other end free), the elbow between its two neighbours (between that
//    elbow's far end and a free end) is voted again by its points and replaces them when it holds
//    its own.
// 4. Completion: an end no joint took looks beyond an elbow, along each of the network's
//    directions and along the direction its nearby points vote for (a sloped leg), for a pipe the
//    earlier stages missed (short legs between elbows, tails into equipment: too few points to
//    stand out on the Gaussian sphere). Knowing the radius, only the corner's place along the end's
//    extension is unknown: each unexplained point votes for the corners that put it on the surface.
//    The peak's pipe must cover its sections, leave empty space around the tube, carry the
//    continued radius all around (a square post's faces and corners do not) and be neither a flat
//    face (normals of one direction on points in a line) nor the edge of a post (normals on two
//    directions at right angles); it is kept when it takes the elbow with the end it grew from
//    (steps 1–3 run again with it); one that ran to the completion's length carries on over its
//    points where they stop just past it (carryOnCappedLegs). Likewise every pipe looks along its
//    body for a thin branch seen in a few scan columns: its axis meets the main's, so each
//    unexplained point votes for where along the main and how thick; a peak's branch passes the
//    same tests and must take the tee.
//    The pipes so found look on in turn, round by round, until a round finds none.
// 5. Ends still free: two look farther for each other across a corner hidden behind something
//    (bridgeOccludedCorners), one reaches a pipe seen running on thinly to its corner from metres
//    away (reachThinRuns), and two whose bends were seen turning square towards each other's line
//    are joined by the leg between the bends, little of which was seen (joinSeenBends); so are
//    two pipes alike whose lines pass square, though neither bend was seen.
// 6. Pieces: fragments on a chosen elbow's arc or on the stretch it extends a pipe over go; a
//    shorter pipe on a pipe's line in its tube goes into it, and one taking no joint that lies in
//    its tube with another radius or off its line goes.
// 7. Runs: connected components of the pipes over accepted joints.
//
// Steps 1–3 live in joint_builder.h and joint_resolution.h, step 4 in joint_completion.h, step 5 in
// joint_hidden_legs.h (docs/ARCHITECTURE.md lists them); this file runs them in rounds (joinOnce).

#include "piperun/stages/joints.h"

#include "piperun/edit/runs.h"
#include "piperun/stages/merge.h"
#include "angles.h"
#include "points_near.h"
#include "stages/end_extension.h"
#include "stages/gentle_kinks.h"
#include "stages/joint_completion.h"
#include "stages/joint_hidden_legs.h"
#include "stages/segment_axis.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <tuple>
#include <utility>
#include <vector>

namespace piperun::joints {

namespace {

// Rounds of completion at most: the pipes one round finds look for what lies beyond them in the
// next, until a round finds none (medium scenes need two).
constexpr int kMaxCompletionRounds = 4;
// A completed leg that ran to the completion's length carries on past it by at most this (m; see
// carryOnCappedLegs): on small 1–60, legs carried on 0.5–2 m were clutter's...
constexpr double kMaxCarry = 0.3;
// ...and its points are looked at this many sections farther, so that a run going on past it shows.
constexpr double kCarrySlackSections = 3.0;

/// A piece on a pipe's line covering at least this share of its length is a copy of it (see
/// joinOnce's merge of pieces).
constexpr double kMinCopyShare = 0.8;

/// Where a shorter piece lies on a pipe's line, inside its tube (see pieceOnLine).
struct PieceOnLine {
  int outer = 0;       // The piece's side past the pipe's end, or nearer it...
  int pipeSide = 0;    // ...and that end's side of the pipe.
  bool within = false;  // Wholly inside the pipe's span...
  double fromEnd = 0.0;  // ...this far from that end (m).
  double overlap = 0.0;  // The length of the pipe's span the piece covers (m).
};

/// Whether the shorter `piece` is `pipe` again: as thick, on its line (both ends within half a
/// radius of its axis, at most 5° off it), and either lying wholly inside the pipe's span or
/// running on from inside it past one of its ends.
std::optional<PieceOnLine> pieceOnLine(const PipeSegment& piece, const PipeSegment& pipe) {
  constexpr double kOnLineAngleDeg = 5.0;  // a piece fitted along a direction a few degrees off
  constexpr double kOnLineOffsetRadii = 0.5;
  const Eigen::Vector3d axis = unitAxis(pipe);
  const double length = (pipe.end - pipe.start).norm();
  if ((piece.end - piece.start).norm() >= length) return std::nullopt;
  if (std::fabs(unitAxis(piece).dot(axis)) < std::cos(radians(kOnLineAngleDeg))) return std::nullopt;
  // As thick as the merge stage asks of one pipe's pieces, by its default.
  if (!radiiAgree(piece.radius, pipe.radius, MergeParams{}.maxRadiusDifference)) return std::nullopt;
  std::array<double, 2> along{};
  for (int side = 0; side < 2; ++side) {
    const Eigen::Vector3d w = (side == 0 ? piece.start : piece.end) - pipe.start;
    along[static_cast<std::size_t>(side)] = w.dot(axis);
    if ((w - along[static_cast<std::size_t>(side)] * axis).norm() > kOnLineOffsetRadii * pipe.radius) return std::nullopt;
  }
  const auto inside = [&](double t) { return t >= 0.0 && t <= length; };
  const double overlap = std::min(length, std::max(along[0], along[1])) - std::max(0.0, std::min(along[0], along[1]));
  for (int outer = 0; outer < 2; ++outer) {
    const double out = along[static_cast<std::size_t>(outer)];
    if (!inside(out) && inside(along[static_cast<std::size_t>(1 - outer)])) {
      return PieceOnLine{outer, out < 0.0 ? 0 : 1, false, 0.0, overlap};
    }
  }
  if (!inside(along[0]) || !inside(along[1])) return std::nullopt;
  const double toStart = std::min(along[0], along[1]);
  const double toEnd = length - std::max(along[0], along[1]);
  const int pipeSide = toStart <= toEnd ? 0 : 1;
  const int outer = (along[0] <= along[1]) == (pipeSide == 0) ? 0 : 1;
  return PieceOnLine{outer, pipeSide, true, std::min(toStart, toEnd), overlap};
}

/// Whether `piece` and `pipe` lie in each other along the piece: both its ends within the larger
/// radius of the pipe's line (its axis in the pipe's tube, or the pipe's in its own), and within the
/// pipe's span or up to a radius past an end (into its elbow). (A piece running on farther carries
/// the pipe on: a piece of it with another radius, not one inside it.)
bool liesInTube(const PipeSegment& piece, const PipeSegment& pipe) {
  const Eigen::Vector3d axis = unitAxis(pipe);
  const double length = (pipe.end - pipe.start).norm();
  const double reach = std::max(piece.radius, pipe.radius);
  for (const Eigen::Vector3d& point : {piece.start, piece.end}) {
    const Eigen::Vector3d w = point - pipe.start;
    const double along = w.dot(axis);
    if (along < -pipe.radius || along > length + pipe.radius || (w - along * axis).norm() >= reach) return false;
  }
  return true;
}

/// The ground: the lowest level of the removed planes that face up (floors), when no more than a
/// trace of the scan lies below it. Nothing was seen under it and no pipe runs through it: a tube
/// reaching below it is a fit to the floor's points by a riser's foot, not a pipe.
class Ground {
 public:
  Ground(const PointCloud* planes, const PointCloud& cloud, const Eigen::Vector3d& up) : up_(up) {
    if (!planes || planes->normals.empty()) return;
    const double minUp = std::cos(radians(kMaxFloorTiltDeg));
    std::vector<double> heights;
    for (std::size_t i = 0; i < planes->size(); ++i) {
      if (std::fabs(planes->normals[i].cast<double>().dot(up)) >= minUp) heights.push_back(heightOf(planes->positions[i]));
    }
    if (heights.empty()) return;
    // The lowest level holding a good share of the floors' points (a stray low patch does not count).
    const double lowest = *std::min_element(heights.begin(), heights.end());
    const double highest = *std::max_element(heights.begin(), heights.end());
    std::vector<std::size_t> perLevel(static_cast<std::size_t>((highest - lowest) / kLevelStep) + 1, 0);
    for (const double z : heights) ++perLevel[static_cast<std::size_t>((z - lowest) / kLevelStep)];
    std::size_t level = 0;
    while (static_cast<double>(perLevel[level]) < kMinGroundShare * static_cast<double>(heights.size())) ++level;
    const double from = lowest + (static_cast<double>(level) - 1.0) * kLevelStep;
    const double to = lowest + (static_cast<double>(level) + 2.0) * kLevelStep;
    double sum = 0.0;
    std::size_t count = 0;
    for (const double z : heights) {
      if (z < from || z >= to) continue;
      sum += z;
      ++count;
    }
    const double height = sum / static_cast<double>(count);
    // A floor with the scan under it (a deck over pipes, a camera's frame) is no ground.
    const auto below = std::count_if(cloud.positions.begin(), cloud.positions.end(),
                                     [&](const Eigen::Vector3f& p) { return heightOf(p) < height - kLevelStep; });
    if (static_cast<double>(below) <= kMaxShareBelowGround * static_cast<double>(cloud.size())) height_ = height;
  }

  /// Whether the tube of `pipe` reaches below the ground by more than the floor's noise.
  bool under(const PipeSegment& pipe) const {
    if (!height_) return false;
    const double rise = unitAxis(pipe).dot(up_);
    const double lowest = std::min(pipe.start.dot(up_), pipe.end.dot(up_)) -
                          pipe.radius * std::sqrt(std::max(0.0, 1.0 - rise * rise));
    return lowest < *height_ - kGroundTolerance;
  }

 private:
  double heightOf(const Eigen::Vector3f& p) const { return p.cast<double>().dot(up_); }

  static constexpr double kMaxFloorTiltDeg = 10.0;      // Plane points whose normals lie this near vertical are floors'.
  static constexpr double kLevelStep = 0.02;            // Floors' heights are binned this finely (m).
  static constexpr double kMinGroundShare = 0.05;       // The ground's level holds this share of the floors' points...
  static constexpr double kMaxShareBelowGround = 0.001; // ...and at most this share of the scan lies under it.
  static constexpr double kGroundTolerance = 0.005;     // A tube may reach this far below it (m): a pipe lying on it.
  Eigen::Vector3d up_;
  std::optional<double> height_;
};

/// A network joined once, and which of the input pipes that must take a joint took none.
struct JoinedOnce {
  JointsResult result;
  std::vector<std::size_t> unjoined;  // Indices into the input pipes, ascending.
};

/// The legs among `completions` (the last pipes of `pipes`) that ran to the completion's length carry
/// on past it over their surface points, as merged pipes' ends do (see extension), up to kMaxCarry:
/// the completion looks no farther, so a leg longer than that stops short of its far corner, out
/// of its end's reach when the pipe is thin. Their points join `explained` and `explainedByPipes`.
/// Returns how many carried on.
std::size_t carryOnCappedLegs(const PointCloud& cloud, const std::vector<Completion>& completions,
                              std::vector<PipeSegment>& pipes, const JointsParams& params, const PointCells& cells,
                              std::vector<char>& explained, std::vector<char>& explainedByPipes) {
  const MergeParams merge;  // The merge stage's rule for points on the surface, as it extends ends.
  const double reach = kMaxCarry + kCarrySlackSections * kSectionLength;
  const std::size_t firstLeg = pipes.size() - completions.size();
  std::vector<std::size_t> capped;
  std::vector<std::pair<Eigen::Vector3d, double>> spheres;
  for (std::size_t c = 0; c < completions.size(); ++c) {
    const PipeSegment& leg = pipes[firstLeg + c];
    // A leg between two ends runs to the far one's corner already.
    if (completions[c].between || (leg.end - leg.start).norm() < params.maxCompletionLength - 2.0 * kSectionLength) {
      continue;
    }
    capped.push_back(firstLeg + c);
    spheres.emplace_back(leg.end + 0.5 * reach * unitAxis(leg), std::hypot(0.5 * reach, 2.0 * (leg.radius + surfaceBand(leg))));
  }
  const auto nearby = pointsInSpheres(cells, spheres, [](std::uint32_t) { return true; });
  std::size_t carried = 0;
  for (std::size_t k = 0; k < capped.size(); ++k) {
    PipeSegment& leg = pipes[capped[k]];
    const Eigen::Vector3d outward = unitAxis(leg);
    std::vector<std::uint32_t> surface;
    const double length = extension(cloud, leg, leg.end, outward, reachBeforeOtherPipes(pipes, capped[k], leg.end, outward, reach),
                                    nearby[k], explained, merge, surface);
    // Running on farther, the points are rarely the leg's: a hanger rod down to the floor, a floor's
    // seam, a neighbour on its line.
    if (!(length > 0.0) || length > kMaxCarry) continue;
    leg.end += length * outward;
    for (std::uint32_t i : surface) explained[i] = explainedByPipes[i] = 1;
    leg.inliers.insert(leg.inliers.end(), surface.begin(), surface.end());
    std::sort(leg.inliers.begin(), leg.inliers.end());
    ++carried;
  }
  return carried;
}

JoinedOnce joinOnce(const JointsInput& input, const PlaneCells& planes, const Ground& ground, const PointCells& cells,
                    const JointsParams& params, Progress& progress) {
  std::vector<PipeSegment> pipes = input.pipes;
  const GentleKinks kinks = splitAtGentleKinks(cells, pipes, networkDirections(input.pipes), input.up, params);
  const std::size_t foundCount = pipes.size();  // The input pipes and the legs found beyond gentle bends.
  const JointsInput split{input.cloud, pipes, nullptr, input.up};
  std::vector<char> explained(input.cloud.size(), 0);
  for (const auto& pipe : pipes) {
    for (std::uint32_t i : pipe.inliers) explained[i] = 1;
  }
  Resolution resolution = resolveJoints(split, params, explained, foundCount, cells, progress);
  progress.report("joints", 0.4);

  // Free ends completed by the pipes the earlier stages missed; a completion is kept when it takes
  // an elbow with the end it grew from (the others go and the rest are resolved again). The pipes
  // found so look on in turn: a leg completed between two elbows, or a branch, ends freely too.
  std::size_t completed = 0;
  std::size_t carried = 0;
  std::size_t underGround = 0;
  std::size_t legsBetween = 0;
  std::size_t branches = 0;
  if (params.maxCompletionLength > 0.0) {
    // A fragment's points may be a missed leg's only ones (a short stretch seen between elbows):
    // the completion may take them, and the fragment goes with the completed pipe (below).
    std::vector<char> explainedByPipes(input.cloud.size(), 0);
    for (const auto& pipe : pipes) {
      if (isFragment(pipe, params)) continue;
      for (std::uint32_t i : pipe.inliers) explainedByPipes[i] = 1;
    }
    std::size_t lookingFrom = 0;
    // One round of completions of the pipes from `lookingFrom` on (of all, for legs seen only on
    // their bends); whether any was adopted.
    const auto completeRound = [&](bool fromBends) {
      const JointsInput current{input.cloud, pipes, nullptr, input.up};
      std::vector<Completion> completions = completeFreeEnds(current, params, explainedByPipes, resolution, planes,
                                                             fromBends ? 0 : lookingFrom, cells, fromBends);
      const auto found = completions.size();
      completions.erase(std::remove_if(completions.begin(), completions.end(),
                                       [&](const Completion& completion) { return ground.under(completion.pipe); }),
                        completions.end());
      underGround += found - completions.size();
      auto adopted =
          adoptCompletions(current, params, explained, std::move(completions), foundCount, cells, progress);
      if (!adopted) return false;
      lookingFrom = pipes.size();
      for (const Completion& completion : adopted->completions) {
        for (std::uint32_t i : completion.pipe.inliers) explainedByPipes[i] = 1;
        ++(completion.main >= 0 ? branches : completed);
        if (completion.between) ++legsBetween;
      }
      pipes = std::move(adopted->pipes);
      explained = std::move(adopted->explained);
      resolution = std::move(adopted->resolution);
      carried += carryOnCappedLegs(input.cloud, adopted->completions, pipes, params, cells, explained, explainedByPipes);
      return true;
    };
    // Rounds of straight legs and branches until one finds none; then one of legs seen only on
    // their bends, where no straight leg was found.
    for (int round = 0; round < kMaxCompletionRounds; ++round) {
      if (!completeRound(false)) break;
    }
    completeRound(true);
  }
  std::vector<PipeSegment> bridged =
      bridgeOccludedCorners({input.cloud, pipes}, params, explained, cells, resolution);
  for (PipeSegment& stretch : reachThinRuns({input.cloud, pipes}, params, explained, cells, resolution)) {
    bridged.push_back(std::move(stretch));
  }
  const std::vector<PipeSegment> legsBetweenBends =
      joinSeenBends({input.cloud, pipes}, params, explained, cells, resolution);
  pipes.insert(pipes.end(), legsBetweenBends.begin(), legsBetweenBends.end());
  const std::vector<PipeSegment> hiddenBranches =
      joinHiddenBranches({input.cloud, pipes}, params, explained, cells, resolution);
  pipes.insert(pipes.end(), hiddenBranches.begin(), hiddenBranches.end());
  progress.report("joints", 0.8);

  JoinedOnce joined;
  JointsResult& result = joined.result;
  result.diagnostics = resolution.diagnostics;
  result.diagnostics.completedPipes = completed;
  result.diagnostics.legsBetweenEnds = legsBetween;
  result.diagnostics.carriedLegs = carried;
  result.diagnostics.underGround = underGround;
  result.diagnostics.branchPipes = branches;
  result.diagnostics.splitKinks = kinks.splitPairs;
  result.diagnostics.kinkLegs = kinks.legsFound;
  auto& hypotheses = resolution.hypotheses;
  const auto& chosen = resolution.chosen;
  const int pipeCount = static_cast<int>(pipes.size());

  // Where the chosen elbows leave the pipes' ends (trimmed or extended to their tangent points),
  // and the stretches they extend pipes over, from an end to the tangent point past it (across a
  // corner the scan hid).
  MovedEnds movedEnds(pipes);
  std::vector<PipeSegment> extensions;
  std::vector<char> takesChosenJoint(pipes.size(), 0);
  for (std::size_t h : chosen) {
    const Hypothesis& joint = hypotheses[h];
    const auto [first, second] = joint.joinedPipes();
    takesChosenJoint[static_cast<std::size_t>(first)] = takesChosenJoint[static_cast<std::size_t>(second)] = 1;
    if (joint.type != JointType::Elbow) continue;
    movedEnds.move(joint);
    for (const auto& [end, tangentPoint] : {std::pair{joint.a, joint.newA}, std::pair{joint.b, joint.newB}}) {
      const PipeSegment& pipe = pipes[static_cast<std::size_t>(end.pipe)];
      const Eigen::Vector3d& endPoint = end.side == 0 ? pipe.start : pipe.end;
      if ((tangentPoint - endPoint).dot(end.outward) <= 0.0) continue;
      PipeSegment stretch;
      stretch.start = endPoint;
      stretch.end = tangentPoint;
      stretch.radius = pipe.radius;
      extensions.push_back(stretch);
    }
  }
  // Each pipe's axis and radius as the chosen elbows leave it (no inliers: only its tube is asked).
  std::vector<PipeSegment> asJoined(pipes.size());
  for (std::size_t p = 0; p < pipes.size(); ++p) {
    asJoined[p].start = movedEnds.at(static_cast<int>(2 * p));
    asJoined[p].end = movedEnds.at(static_cast<int>(2 * p + 1));
    asJoined[p].radius = pipes[p].radius;
  }

  // Fragments lying on a chosen elbow's arc are bits of the elbow fitted as cylinders: they go,
  // and so do the arc pieces the resolution found.
  std::vector<char> absorbed = resolution.arcPieces;
  for (int p = 0; p < pipeCount; ++p) {
    if (!isFragment(pipes[static_cast<std::size_t>(p)], params)) continue;
    for (std::size_t h : chosen) {
      const Hypothesis& elbow = hypotheses[h];
      if (elbow.type == JointType::Elbow && liesOnArc(pipes[static_cast<std::size_t>(p)], elbow)) {
        absorbed[static_cast<std::size_t>(p)] = 1;
      }
    }
    // So do fragments inside a completed pipe's tube (bits of the leg it completed) and inside a
    // stretch bridged across an occlusion (bits of the pipe seen through a gap in it).
    for (std::size_t c = foundCount; c < pipes.size(); ++c) {
      if (middleInsideTube(pipes[static_cast<std::size_t>(p)], pipes[c])) absorbed[static_cast<std::size_t>(p)] = 1;
    }
    for (const PipeSegment& stretch : bridged) {
      if (middleInsideTube(pipes[static_cast<std::size_t>(p)], stretch)) absorbed[static_cast<std::size_t>(p)] = 1;
    }
    // So do fragments taking no joint inside the stretch an elbow extends its pipe over: bits of
    // that pipe seen across the hidden corner (medium seed 2: an 18 cm piece of a 20 cm pipe,
    // 0.4 m inside the 1.76 m its elbow extends it by, was left in it for review).
    if (takesChosenJoint[static_cast<std::size_t>(p)]) continue;
    for (const PipeSegment& stretch : extensions) {
      if (middleInsideTube(pipes[static_cast<std::size_t>(p)], stretch)) absorbed[static_cast<std::size_t>(p)] = 1;
    }
  }
  // A shorter pipe on a pipe's line and in its tube (see pieceOnLine) is that pipe again: a
  // completion that took the points its inliers left out (medium seed 6: a 0.71 m leg over the
  // first 0.48 m of a 12 m pipe whose fit began short of the corner), or a piece fitted in another
  // tile or along another direction. The pipe takes it over (its points, its joints, its outer end
  // when that lies past the pipe's), so that no pipe lies in another and the run goes on: a piece
  // that takes no joint anywhere in the pipe's span; one whose joints all lie at its outer side
  // when it runs on past the pipe's end or lies within a diameter of it, and that end takes none,
  // or only the same joints again (those twins go).
  std::vector<int> carriedBy(pipes.size(), -1);
  std::vector<int> carriedSide(pipes.size(), 0);  // The pipe's side the piece's outer end became.
  std::vector<std::array<char, 2>> carriedOn(pipes.size(), {0, 0});  // Per pipe, the sides a piece with joints was merged at.
  std::vector<char> carries(pipes.size(), 0);
  std::vector<char> droppedTwin(hypotheses.size(), 0);  // A merged piece's joints that its pipe took too.
  const auto otherPipeOf = [](const Hypothesis& joint, int pipe) {
    const auto [first, second] = joint.joinedPipes();
    return first == pipe ? second : first;
  };
  const auto jointEndsOf = [&](std::size_t pipe) {
    std::vector<std::pair<std::size_t, int>> ends;  // Hypothesis, side (-1: a tee's main body).
    for (std::size_t h : chosen) {
      const Hypothesis& joint = hypotheses[h];
      if (joint.a.pipe == static_cast<int>(pipe)) ends.emplace_back(h, joint.a.side);
      if (joint.type == JointType::Tee) {
        if (joint.mainPipe == static_cast<int>(pipe)) ends.emplace_back(h, -1);
      } else if (joint.b.pipe == static_cast<int>(pipe)) {
        ends.emplace_back(h, joint.b.side);
      }
    }
    return ends;
  };
  const auto twinOf = [&](std::size_t h, std::size_t pipe, const std::vector<std::pair<std::size_t, int>>& ends,
                          std::size_t endsPipe) {
    return std::find_if(ends.begin(), ends.end(), [&](const auto& end) {
      return hypotheses[end.first].type == hypotheses[h].type &&
             otherPipeOf(hypotheses[end.first], static_cast<int>(endsPipe)) ==
                 otherPipeOf(hypotheses[h], static_cast<int>(pipe));
    });
  };
  const auto lengthOf = [&](std::size_t pipe) { return (pipes[pipe].end - pipes[pipe].start).norm(); };
  // `into` takes over the points of `from`, which goes into it.
  const auto takeOver = [&](std::size_t into, std::size_t from) {
    std::vector<std::uint32_t> inliers;
    std::set_union(pipes[into].inliers.begin(), pipes[into].inliers.end(), pipes[from].inliers.begin(),
                   pipes[from].inliers.end(), std::back_inserter(inliers));
    pipes[into].inliers = std::move(inliers);
    carriedBy[from] = static_cast<int>(into);
    carries[into] = 1;
  };
  for (std::size_t c = 0; c < pipes.size(); ++c) {
    // A pipe that took a piece over stays; one that went into a piece as its copy is done.
    if (absorbed[c] || carries[c] || carriedBy[c] >= 0) continue;
    const auto ownEnds = jointEndsOf(c);
    const bool jointless = ownEnds.empty();
    for (std::size_t p = 0; p < pipes.size(); ++p) {
      if (p == c || absorbed[p] || carriedBy[p] >= 0 || isFragment(pipes[p], params)) continue;
      const auto onLine = pieceOnLine(pipes[c], pipes[p]);
      if (!onLine) continue;
      // Covering most of the pipe, the piece is the pipe fitted again (in another tile): when the pipe
      // takes no joint the piece does not take too (the same kind, with the same pipe), it goes into
      // the piece, which keeps its own joints, and its twins go.
      if (!jointless && !carries[p] && onLine->overlap >= kMinCopyShare * lengthOf(p)) {
        const auto pipeEnds = jointEndsOf(p);
        if (std::all_of(pipeEnds.begin(), pipeEnds.end(),
                        [&](const auto& end) { return twinOf(end.first, p, ownEnds, c) != ownEnds.end(); })) {
          for (const auto& end : pipeEnds) droppedTwin[end.first] = 1;
          takeOver(c, p);
          continue;
        }
      }
      const int outer = onLine->outer;
      const int pipeSide = onLine->pipeSide;
      if (carriedOn[p][static_cast<std::size_t>(pipeSide)]) continue;
      // The piece's joints that the pipe's end takes as well (the same kind, with the same pipe):
      // the piece was fitted again and so was its joint.
      std::vector<std::size_t> duplicated;
      if (!(onLine->within && jointless)) {
        if ((onLine->within && onLine->fromEnd > 2.0 * pipes[p].radius) ||
            std::any_of(ownEnds.begin(), ownEnds.end(), [&](const auto& end) { return end.second != outer; })) {
          continue;
        }
        bool endTaken = false;
        for (const auto& [h, side] : jointEndsOf(p)) {
          if (side != pipeSide) continue;
          const auto twin = twinOf(h, p, ownEnds, c);
          if (twin == ownEnds.end()) {
            endTaken = true;
            break;
          }
          duplicated.push_back(twin->first);
        }
        // A piece with a twin there brings no joint of its own to that end.
        if (endTaken || (!duplicated.empty() && duplicated.size() != ownEnds.size())) continue;
      }
      for (const std::size_t h : duplicated) droppedTwin[h] = 1;
      PipeSegment& pipe = pipes[p];
      // The pipe reaches on to the piece's outer end when that lies past its own (its elbow's
      // tangent point, if it takes one, is set below either way) and takes no joint of its own there.
      const Eigen::Vector3d& outerEnd = outer == 0 ? pipes[c].start : pipes[c].end;
      Eigen::Vector3d& pipeEnd = pipeSide == 0 ? pipe.start : pipe.end;
      const Eigen::Vector3d inward = pipeSide == 0 ? unitAxis(pipe) : Eigen::Vector3d(-unitAxis(pipe));
      if (duplicated.empty() && (outerEnd - pipeEnd).dot(inward) < 0.0) pipeEnd = outerEnd;
      takeOver(p, c);
      carriedSide[c] = pipeSide;
      if (!jointless) carriedOn[p][static_cast<std::size_t>(pipeSide)] = 1;
      break;
    }
  }
  // A pipe taking no joint that lies in a longer pipe's tube (as its elbows leave it), thicker or
  // thinner than it or off its line, is no pipe of its own (two pipes cannot lie in each other): a
  // cylinder fitted to part of that pipe's points with the wrong radius, or to a few of them and
  // something beside (small seed 2: a 0.59 m cylinder of radius 110 mm in a 162 mm pipe, 8 mm RMS
  // off its points).
  for (std::size_t c = 0; c < pipes.size(); ++c) {
    // (One that had to take a joint goes anyway, and the network is joined again without it.)
    if (absorbed[c] || carries[c] || carriedBy[c] >= 0 || takesChosenJoint[c] || pipes[c].mustJoin) continue;
    for (std::size_t p = 0; p < pipes.size(); ++p) {
      if (p == c || absorbed[p] || carriedBy[p] >= 0 || isFragment(pipes[p], params)) continue;
      if (lengthOf(c) < lengthOf(p) && liesInTube(pipes[c], asJoined[p])) {
        absorbed[c] = 1;
        ++result.diagnostics.piecesInsidePipes;
        break;
      }
    }
  }
  const auto holder = [&](int pipe) {
    return carriedBy[static_cast<std::size_t>(pipe)] >= 0 ? carriedBy[static_cast<std::size_t>(pipe)] : pipe;
  };

  // Input pipes that had to take a joint (weakly supported circles, few inliers) and that no chosen
  // joint took (absorbed ones go anyway).
  std::vector<char> inJoint(pipes.size(), 0);
  for (std::size_t h : chosen) {
    const auto [first, second] = hypotheses[h].joinedPipes();
    inJoint[static_cast<std::size_t>(holder(first))] = inJoint[static_cast<std::size_t>(holder(second))] = 1;
  }
  for (std::size_t p = 0; p < input.pipes.size(); ++p) {
    // A piece that went into another pipe takes that pipe's joints.
    if (pipes[p].mustJoin && !inJoint[static_cast<std::size_t>(holder(static_cast<int>(p)))] && !absorbed[p]) {
      joined.unjoined.push_back(p);
    }
  }

  // Pipe ids: input order, absorbed fragments and pieces merged at ends left out.
  std::vector<int> idOf(static_cast<std::size_t>(pipeCount), 0);
  int pipeIds = 0;
  for (int p = 0; p < pipeCount; ++p) {
    if (absorbed[static_cast<std::size_t>(p)] || carriedBy[static_cast<std::size_t>(p)] >= 0) continue;
    idOf[static_cast<std::size_t>(p)] = ++pipeIds;
    result.pipes.push_back(pipes[static_cast<std::size_t>(p)]);
  }
  for (int p = 0; p < pipeCount; ++p) {
    if (carriedBy[static_cast<std::size_t>(p)] >= 0) idOf[static_cast<std::size_t>(p)] = idOf[static_cast<std::size_t>(holder(p))];
  }
  result.diagnostics.absorbedFragments =
      static_cast<std::size_t>(std::count(absorbed.begin(), absorbed.end(), 1)) - result.diagnostics.piecesInsidePipes;
  result.diagnostics.piecesAtEnds =
      static_cast<std::size_t>(std::count_if(carriedBy.begin(), carriedBy.end(), [](int p) { return p >= 0; }));

  // Joints, ordered by the pipes they join; elbows trim or extend their pipes to the tangent points.
  std::vector<std::tuple<int, int, int, std::size_t>> keyed;  // first pipe id, second pipe id, type, hypothesis
  for (std::size_t h : chosen) {
    if (droppedTwin[h]) continue;
    const auto [first, second] = hypotheses[h].joinedPipes();
    keyed.emplace_back(idOf[static_cast<std::size_t>(first)], idOf[static_cast<std::size_t>(second)],
                       static_cast<int>(hypotheses[h].type), h);
  }
  std::sort(keyed.begin(), keyed.end());
  int nextId = pipeIds + 1;
  for (const auto& [first, second, type, h] : keyed) {
    Hypothesis& hypothesis = hypotheses[h];
    if (hypothesis.type == JointType::Elbow) {
      for (const auto& [end, point] : {std::pair{hypothesis.a, hypothesis.newA}, std::pair{hypothesis.b, hypothesis.newB}}) {
        PipeSegment& pipe = result.pipes[static_cast<std::size_t>(idOf[static_cast<std::size_t>(end.pipe)] - 1)];
        const int carried = carriedBy[static_cast<std::size_t>(end.pipe)];
        const int side = carried >= 0 ? carriedSide[static_cast<std::size_t>(end.pipe)] : end.side;
        (side == 0 ? pipe.start : pipe.end) = point;
      }
    }
    Joint joint;
    joint.id = nextId++;
    joint.type = hypothesis.type;
    joint.pipeIds = {first, second};
    joint.radius = hypothesis.type == JointType::Tee ? hypothesis.a.radius : 0.5 * (hypothesis.a.radius + hypothesis.b.radius);
    joint.axis = std::move(hypothesis.axis);
    joint.bendRadius = hypothesis.bendRadius;
    joint.confidence = std::clamp(hypothesis.confidence, 0.0, 1.0);
    joint.status = joint.confidence >= params.acceptConfidence ? JointStatus::Accepted : JointStatus::Proposed;
    std::sort(hypothesis.supportPoints.begin(), hypothesis.supportPoints.end());
    result.jointSupport.push_back(std::move(hypothesis.supportPoints));
    result.joints.push_back(std::move(joint));
  }

  // A pipe that takes no joint and is short says little of being a pipe: a flange, a valve or pump
  // body, a vessel's nozzle are such cylinders too. Its confidence falls with its length under two
  // fragments' length, below one half (proposed, for review) under one.
  std::vector<char> takesJoint(result.pipes.size(), 0);
  for (const Joint& joint : result.joints) {
    for (int id : joint.pipeIds) takesJoint[static_cast<std::size_t>(id - 1)] = 1;
  }
  for (std::size_t p = 0; p < result.pipes.size(); ++p) {
    PipeSegment& pipe = result.pipes[p];
    const double shortOf = 2.0 * params.minPipeDiameters * 2.0 * pipe.radius;
    const double length = (pipe.end - pipe.start).norm();
    if (!takesJoint[p] && length < shortOf) pipe.confidence *= length / shortOf;
  }

  // Runs by the rule every edit of the network uses too.
  PipeNetwork network;
  for (int id = 1; id <= pipeIds; ++id) network.pipes.push_back(Pipe{id});
  network.joints = result.joints;
  assignRuns(network);
  result.runs = std::move(network.runs);
  return joined;
}

}  // namespace

}  // namespace piperun::joints

namespace piperun {

JointsResult connectPipes(const JointsInput& input, const JointsParams& params, Progress& progress) {
  const auto started = std::chrono::steady_clock::now();
  // A pipe that must take a joint (a weakly supported circle, few inliers) stays only when it does:
  // without those that took none the network is joined again (their points free for the others),
  // until all left do.
  std::vector<PipeSegment> pipes = input.pipes;
  const joints::PlaneCells planes(input.planes);
  const joints::Ground ground(input.planes, input.cloud, input.up);
  const auto pipesBefore = pipes.size();
  pipes.erase(std::remove_if(pipes.begin(), pipes.end(), [&](const PipeSegment& pipe) { return ground.under(pipe); }),
              pipes.end());
  const std::size_t inputUnderGround = pipesBefore - pipes.size();
  // A fit over the points along a room's edge or a floor's seam is the removed planes' residue.
  const auto pipesOverGround = pipes.size();
  std::vector<char> residue(pipes.size(), 0);
  tbb::parallel_for(std::size_t{0}, pipes.size(),
                    [&](std::size_t p) { residue[p] = planes.alongPlanes(input.cloud, pipes[p].inliers); });
  std::size_t kept = 0;
  for (std::size_t p = 0; p < pipes.size(); ++p) {
    if (residue[p]) continue;
    if (kept != p) pipes[kept] = std::move(pipes[p]);
    ++kept;
  }
  pipes.resize(kept);
  const std::size_t planeResidue = pipesOverGround - pipes.size();
  // Every search for points near a place reads the cloud filed once by these cells.
  const PointCells cells(input.cloud, std::max(params.minSearchDistance, 0.25));
  std::size_t dropped = 0;
  for (;;) {
    joints::JoinedOnce joined = joints::joinOnce({input.cloud, pipes, nullptr, input.up}, planes, ground, cells, params, progress);
    if (joined.unjoined.empty()) {
      JointsResult& result = joined.result;
      result.diagnostics.unjoinedPipes = dropped;
      result.diagnostics.underGround += inputUnderGround;
      result.diagnostics.planeResidue = planeResidue;
      progress.report("joints", 1.0);
      result.diagnostics.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
      return std::move(result);
    }
    dropped += joined.unjoined.size();
    for (auto p = joined.unjoined.rbegin(); p != joined.unjoined.rend(); ++p) {
      pipes.erase(pipes.begin() + static_cast<std::ptrdiff_t>(*p));
    }
  }
}

}  // namespace piperun
