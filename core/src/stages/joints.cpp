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
//    A piece of an elbow's arc fitted as a cylinder makes two elbows of one: a pipe lying on the
//    arc of a confident elbow between two other pipes waits for that elbow, and goes when it is
//    chosen.
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
// 6. Runs: connected components of the pipes over accepted joints.

#include "piperun/stages/joints.h"

#include "piperun/edit/runs.h"
#include "piperun/stages/merge.h"

#include "angles.h"
#include "points_near.h"
#include "sector_offsets.h"
#include "sort_by_key.h"
#include "segment_distance.h"
#include "stages/end_extension.h"
#include "stages/gentle_kinks.h"
#include "stages/section_runs.h"
#include "stages/segment_axis.h"

#include <Eigen/Eigenvalues>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <optional>
#include <tuple>
#include <utility>

namespace piperun {

namespace {

constexpr double kSectionLength = 0.04;  // Sections of a gap tested for point support (m).
constexpr double kSupportNormalAngleDeg = 30.0;
// An elbow voted tighter than this many pipe radii with almost no surface on its torus is no
// fitting (short-radius elbows bend at one diameter, two radii): the two pipes meet square at a
// tee whose main pipe was seen on one side only.
constexpr double kMinFittingBendRadii = 1.5;
// A pipe fitted into an elbow runs on past the corner by up to this many radii times the cotangent
// of half the bend angle (see tryEndPair); an end carried on over outliers may lie up to twice as
// far past, where its pipe holds at most this share of its linear density.
constexpr double kEndOvershootRadii = 1.25;
constexpr double kMaxPastCornerDensity = 0.2;
constexpr double kMaxBendlessSupport = 0.2;
// A cylinder fitted across an elbow's bend (see liesOnArc): its middle within this many radii of
// the arc, its ends within this many, at most this share of the arc's length, and at least this
// far off both pipes' lines (deg).
constexpr double kChordMiddleRadii = 0.5;
constexpr double kChordEndRadii = 2.0;
constexpr double kMaxChordArcShare = 1.5;
constexpr double kMinChordOffLineDeg = 15.0;
// Missing points say the torus is not there only where it would hold this many: a thin pipe seen
// from afar leaves a few on an elbow, which the overshooting pipes take as their inliers.
constexpr double kMinBendlessEvidence = 10.0;
// An elbow with no points to vote for its bend is taken for the commonest fitting, a long-radius
// elbow (1.5 diameters), unless its pipes' ends, seen straight up to where they stop, say tighter.
constexpr double kLongElbowRadii = 3.0;
// How much nearer its corner than the inliers of such an elbow's pipe would stop an end may lie
// (m): the extents place ends to a 4 cm section.
constexpr double kUnvotedEndSlack = 0.04;
// Rounds of completion at most: the pipes one round finds look for what lies beyond them in the
// next, until a round finds none (medium scenes need two).
constexpr int kMaxCompletionRounds = 4;
// A completed leg that ran to the completion's length carries on past it by at most this (m; see
// carryOnCappedLegs): on small 1–60, legs carried on 0.5–2 m were clutter's...
constexpr double kMaxCarry = 0.3;
// ...and its points are looked at this many sections farther, so that a run going on past it shows.
constexpr double kCarrySlackSections = 3.0;
// Points this close to the axis of a stretch an elbow would bridge across an occlusion, in its
// pipe's radius, are something else standing where the pipe would run (see bridgeOccludedCorners).
constexpr double kOccludedCoreRadii = 0.5;
// A leg between two seen bends (see joinSeenBends) turns square off both pipes it joins: their
// lines pass each other at least this far from parallel, and it runs along one of the network's
// directions within this.
constexpr double kSquareLegMinAngleDeg = 60.0;
constexpr double kSquareLegDirectionDeg = 3.0;
constexpr double kShortElbowRadii = 2.0;  // A short-radius elbow's bend radius, in pipe radii.
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

/// Whether point i's normal is within the support angle of the unit `radial` (normals are unoriented).
bool normalAgrees(const PointCloud& cloud, std::uint32_t i, const Eigen::Vector3d& radial,
                  double maxAngleDeg = kSupportNormalAngleDeg) {
  if (cloud.normals.empty()) return true;
  return std::fabs(cloud.normals[i].cast<double>().dot(radial)) >= std::cos(radians(maxAngleDeg));
}

bool isFragment(const PipeSegment& pipe, const JointsParams& params) {
  return (pipe.end - pipe.start).norm() < params.minPipeDiameters * 2.0 * pipe.radius;
}

/// Whether the middle of `piece` lies inside the tube of one of `pipes` other than itself; a
/// fragment's tube does not count (its points are a bit of what lies around it).
bool insideAnotherPipe(const PipeSegment& piece, const std::vector<PipeSegment>& pipes, const JointsParams& params) {
  return std::any_of(pipes.begin(), pipes.end(), [&](const PipeSegment& pipe) {
    return &pipe != &piece && !isFragment(pipe, params) && middleInsideTube(piece, pipe);
  });
}

/// Whether `piece` runs alongside one of `pipes` (a fragment's does not count) through its tube:
/// near parallel, over a stretch of it, their axes closer than the two radii, neither inside the
/// other's tube (a piece inside a pipe is that pipe again, a thinner pipe inside the piece a
/// cylinder fitted into its tube).
bool runsThroughAlongside(const PipeSegment& piece, const std::vector<PipeSegment>& pipes, const JointsParams& params) {
  constexpr double kAlongsideAngleDeg = 10.0;
  const Eigen::Vector3d direction = unitAxis(piece);
  const Eigen::Vector3d middle = 0.5 * (piece.start + piece.end);
  return std::any_of(pipes.begin(), pipes.end(), [&](const PipeSegment& pipe) {
    if (&pipe == &piece || isFragment(pipe, params)) return false;
    const Eigen::Vector3d axis = unitAxis(pipe);
    if (std::fabs(axis.dot(direction)) < std::cos(radians(kAlongsideAngleDeg))) return false;
    const double length = (pipe.end - pipe.start).norm();
    const double from = (piece.start - pipe.start).dot(axis), to = (piece.end - pipe.start).dot(axis);
    if (std::max(from, to) <= 0.0 || std::min(from, to) >= length) return false;
    const Eigen::Vector3d offset = middle - pipe.start - (middle - pipe.start).dot(axis) * axis;
    return offset.norm() >= std::max(piece.radius, pipe.radius) &&
           offset.norm() < piece.radius + pipe.radius - params.supportDistance;
  });
}

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

/// Whether the tube of `piece` cuts the tube of one of `pipes` other than those in `except` (a
/// fragment's does not count): pipes do not pass through each other.
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

/// Votes for values in [low, high], each split linearly between its two nearest bins; the peak is
/// the bin with the most votes once smoothed by a triangular (1, 2, 1) kernel.
class VoteHistogram {
 public:
  VoteHistogram(double low, double high, double binWidth)
      : low_(low), width_(binWidth), bins_(static_cast<std::size_t>(std::ceil((high - low) / binWidth)) + 1, 0.0) {}

  void vote(double value) {
    const double position = (value - low_) / width_;
    const auto bin = std::min(bins_.size() - 1, static_cast<std::size_t>(position));
    const double fraction = position - static_cast<double>(bin);
    bins_[bin] += 1.0 - fraction;
    if (bin + 1 < bins_.size()) bins_[bin + 1] += fraction;
  }

  /// The value at the peak (the first of equal peaks) and its smoothed votes; (low, 0) without votes.
  std::pair<double, double> peak() const {
    std::size_t best = 0;
    double most = 0.0;
    for (std::size_t k = 0; k < bins_.size(); ++k) {
      if (smoothed(k) > most) {
        most = smoothed(k);
        best = k;
      }
    }
    return {low_ + static_cast<double>(best) * width_, most};
  }

  /// The values at the `count` highest local peaks of the smoothed votes, highest first (ties in
  /// order of value).
  std::vector<double> peaks(std::size_t count) const {
    std::vector<std::pair<double, std::size_t>> found;  // (votes, bin)
    for (std::size_t k = 0; k < bins_.size(); ++k) {
      const double here = smoothed(k);
      if (here > 0.0 && (k == 0 || here > smoothed(k - 1)) && (k + 1 == bins_.size() || here >= smoothed(k + 1))) {
        found.emplace_back(here, k);
      }
    }
    std::stable_sort(found.begin(), found.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    std::vector<double> values;
    for (std::size_t k = 0; k < std::min(count, found.size()); ++k) {
      values.push_back(low_ + static_cast<double>(found[k].second) * width_);
    }
    return values;
  }

 private:
  double low_;
  double width_;
  std::vector<double> bins_;

  double smoothed(std::size_t k) const {
    return 2.0 * bins_[k] + (k > 0 ? bins_[k - 1] : 0.0) + (k + 1 < bins_.size() ? bins_[k + 1] : 0.0);
  }
};

/// Votes over a grid of bins (rows × columns, e.g. place along a pipe × radius); peaks are the local
/// maxima of the votes summed over 3 × 3 bins.
class GridVotes {
 public:
  struct Peak {
    float votes;  // Summed over the 3 × 3 bins around it.
    int row;
    int column;
  };

  GridVotes(int rows, int columns)
      : rows_(rows), columns_(columns), votes_(static_cast<std::size_t>(rows) * static_cast<std::size_t>(columns), 0.0F) {}

  void vote(int row, int column) { votes_[bin(row, column)] += 1.0F; }

  /// The peaks of at least `minimum` summed votes at bins that were voted for, highest first (of
  /// equal neighbours the first bin is the peak; equal peaks in bin order).
  std::vector<Peak> peaks(float minimum) const {
    // Summed where a voted bin needs it only: most of a long pipe's bins hold no vote. (Votes are
    // whole numbers, so every order of summing gives the same sums.)
    const auto summed = [&](int row, int column) {
      float sum = 0.0F;
      forNeighbours(row, column, [&](int r, int c) { sum += votes_[bin(r, c)]; });
      return sum;
    };
    std::vector<Peak> found;
    for (int row = 0; row < rows_; ++row) {
      for (int column = 0; column < columns_; ++column) {
        if (votes_[bin(row, column)] == 0.0F) continue;
        const float here = summed(row, column);
        if (here < minimum) continue;
        bool highest = true;
        forNeighbours(row, column, [&](int r, int c) {
          const float there = summed(r, c);
          if ((r != row || c != column) && (there > here || (there == here && bin(r, c) < bin(row, column)))) {
            highest = false;
          }
        });
        if (highest) found.push_back({here, row, column});
      }
    }
    std::stable_sort(found.begin(), found.end(), [](const Peak& a, const Peak& b) { return a.votes > b.votes; });
    return found;
  }

 private:
  int rows_;
  int columns_;
  std::vector<float> votes_;

  std::size_t bin(int row, int column) const {
    return static_cast<std::size_t>(row) * static_cast<std::size_t>(columns_) + static_cast<std::size_t>(column);
  }

  /// Calls `visit(row, column)` for each bin of the 3 × 3 block around one, inside the grid.
  template <typename Visit>
  void forNeighbours(int row, int column, Visit visit) const {
    for (int r = std::max(0, row - 1); r <= std::min(rows_ - 1, row + 1); ++r) {
      for (int c = std::max(0, column - 1); c <= std::min(columns_ - 1, column + 1); ++c) visit(r, c);
    }
  }
};

struct PipeEnd {
  int pipe = 0;
  int side = 0;  // 0: start, 1: end
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d outward = Eigen::Vector3d::Zero();  // Unit, pointing away from the pipe's body.
  double radius = 0.0;
  bool seenToEnd = true;  // The pipe was seen up to here (a leg drawn between two corners was not).
  int key() const { return 2 * pipe + side; }
};

PipeEnd endOf(const std::vector<PipeSegment>& pipes, int pipe, int side) {
  const PipeSegment& segment = pipes[static_cast<std::size_t>(pipe)];
  const Eigen::Vector3d axis = unitAxis(segment);
  return {pipe, side, side == 0 ? segment.start : segment.end, side == 0 ? Eigen::Vector3d(-axis) : axis, segment.radius};
}

/// A joint hypothesis: geometry fixed from the pipes alone, then completed with the points.
struct Hypothesis {
  JointType type = JointType::Elbow;
  PipeEnd a;                // Elbow/boundary: the first end; tee: the branch end.
  PipeEnd b;                // Elbow/boundary: the second end.
  int mainPipe = -1;        // Tee: the pipe whose body the branch meets.
  double skew = 0.0;        // How far the centre lines miss each other (m).
  double skewLimit = 0.0;
  Eigen::Vector3d corner = Eigen::Vector3d::Zero();  // Elbow: P_I; tee: the point on the main axis.
  double bendAngle = 0.0;   // Elbow: angle between the two pipes' directions (rad).
  double gap = 0.0;         // Boundary: gap length; tee: from the main pipe's surface to the branch end.
  double gapLimit = 0.0;
  double reach = 0.0;       // Points within this of `center` are gathered for the hypothesis.
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  bool mainSeenOneSide = false;  // Tee: the main's end stops short of the junction.
  // Elbow: an end lies past the corner by more than the elbow's own surface carries a fit (see
  // tryEndPair); only a bend its points vote for explains it.
  bool endPastCorner = false;
  // Tee whose main stops short of the junction (tryTeeBeyondEnd, teeForBendlessCorner): the main's
  // end its line is carried on from, to the junction and beyond.
  std::optional<PipeEnd> mainEnd;
  // Elbow: the largest bend radius voted for (a pipe seen straight up to its end bounds it).
  double maxBendRadius = std::numeric_limits<double>::infinity();

  // Completed by reconstruct():
  double geometric = 0.0;   // How well the criteria hold, in [0, 1].
  double support = 0.0;     // Point support on the joint's surface, in [0, 1].
  double confidence = 0.0;
  double bendRadius = 0.0;
  // Elbow: the tightest bend the points allow (the voted one, or with no vote the one whose tangent
  // point lies at the nearer end seen straight up to where it stops) is tighter than any fitting,
  // and its torus holds almost none of the points it should: no bend (see teeForBendlessCorner).
  bool bendless = false;
  double expectedSupport = 0.0;  // Elbow: the points its torus would hold at its pipes' linear density.
  // Elbow: the tangent points the two pipes are trimmed or extended to.
  Eigen::Vector3d newA = Eigen::Vector3d::Zero(), newB = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> axis;
  std::vector<std::uint32_t> supportPoints;
  bool valid = false;

  /// The two pipes it joins: a tee's main, then its branch; an elbow's or boundary's a, then b.
  std::pair<int, int> joinedPipes() const {
    return type == JointType::Tee ? std::pair{mainPipe, a.pipe} : std::pair{a.pipe, b.pipe};
  }
};

/// Where each pipe end lies once the elbows chosen so far have moved it to their tangent points:
/// two elbows on one short pipe must leave it a length.
class MovedEnds {
 public:
  explicit MovedEnds(const std::vector<PipeSegment>& pipes) : points_(2 * pipes.size()) {
    for (std::size_t p = 0; p < pipes.size(); ++p) {
      points_[2 * p] = pipes[p].start;
      points_[2 * p + 1] = pipes[p].end;
    }
  }

  /// Whether `elbow` leaves both its pipes at least a section long.
  bool leaveLength(const Hypothesis& elbow) const {
    return keepsLength(elbow.a, elbow.newA) && keepsLength(elbow.b, elbow.newB);
  }
  void move(const Hypothesis& elbow) {
    points_[static_cast<std::size_t>(elbow.a.key())] = elbow.newA;
    points_[static_cast<std::size_t>(elbow.b.key())] = elbow.newB;
  }

 private:
  bool keepsLength(const PipeEnd& end, const Eigen::Vector3d& moved) const {
    return (moved - points_[static_cast<std::size_t>(end.key() ^ 1)]).dot(end.outward) >= kSectionLength;
  }

  std::vector<Eigen::Vector3d> points_;
};

class JointBuilder {
 public:
  /// `explained` flags the points that are inliers of some pipe.
  JointBuilder(const JointsInput& input, const JointsParams& params, const std::vector<char>& explained)
      : input_(input), params_(params), explained_(explained) {}

  double searchDistance(double radius) const {
    return std::max(params_.minSearchDistance, params_.searchDiameters * 2.0 * radius);
  }
  double boundaryGapLimit(double radius) const {
    return std::max(params_.minSearchDistance, params_.maxBoundaryGapDiameters * 2.0 * radius);
  }
  double skewLimit(double radius) const { return std::max(params_.minSkewDistance, params_.maxSkewRadii * radius); }

  /// The boundary joint between two ends whose axes continue each other, where the limits allow one.
  std::optional<Hypothesis> boundaryBetween(const PipeEnd& a, const PipeEnd& b) const {
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

  /// Hypotheses from an end and an end of another pipe (elbow or boundary joint).
  void tryEndPair(const PipeEnd& a, const PipeEnd& b, std::vector<Hypothesis>& out) const {
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

  /// A reducing corner: the thinner `branch`'s extension meets the line of the thicker pipe past
  /// its `mainEnd`, both hidden at the junction for no farther than the branch looks for a partner.
  /// Too unequal for an elbow, it is a tee whose main was seen on one side only, and it counts half
  /// its confidence like teeForBendlessCorner's. (A thinner cylinder fitted inside another pipe's
  /// tube meets the lines of the pipes that pipe joins in just such corners: it is no branch.)
  void tryTeeBeyondEnd(const PipeEnd& branch, const PipeEnd& mainEnd, std::vector<Hypothesis>& out) const {
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

  /// A T-junction hypothesis: `branch`'s extension meets the body of pipe `main`.
  void tryTee(const PipeEnd& branch, int main, std::vector<Hypothesis>& out) const {
    if (auto h = teeAt(branch, main, /*mainSeenBeyond=*/true)) out.push_back(std::move(*h));
  }

  /// The tee that replaces an elbow hypothesis with no bend (Hypothesis::bendless), at a near-square
  /// corner. Its main pipe is the one whose end reaches nearer the corner (in radii of the other);
  /// the main's far side was not seen, so the tee counts half its confidence and is proposed for
  /// review.
  std::optional<Hypothesis> teeForBendlessCorner(const Hypothesis& elbow,
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

  /// The tee where `branch`'s extension meets the axis of pipe `main`: inside its body when the
  /// main pipe is seen beyond the branch, anywhere along its line otherwise.
  std::optional<Hypothesis> teeAt(const PipeEnd& branch, int main, bool mainSeenBeyond) const {
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

  /// Whether another pipe, one a boundary joint could join to the nearer end of pipe `main`, covers
  /// the main's line to `along` (from the main's start along its axis) past that end.
  bool lineCarriesOn(int main, double along) const {
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

  /// Completes a hypothesis with its points (indices into the cloud within its reach).
  void reconstruct(Hypothesis& h, const std::vector<std::uint32_t>& nearby) const {
    switch (h.type) {
      case JointType::Elbow: reconstructElbow(h, nearby); break;
      case JointType::Tee: reconstructTee(h, nearby); break;
      case JointType::Boundary: reconstructBoundary(h, nearby); break;
    }
  }

  /// Share of the straight piece from `from` to `to` (radius r) whose sections hold a point on its
  /// surface; collects those points.
  double straightCoverage(const Eigen::Vector3d& from, const Eigen::Vector3d& to, double r,
                          const std::vector<std::uint32_t>& nearby, std::vector<std::uint32_t>& supportPoints) const {
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

 private:
  Eigen::Vector3d position(std::uint32_t i) const { return input_.cloud.positions[i].cast<double>(); }

  /// Whether the pipe of `end` holds past its corner (`along` its extension, behind the end) a small
  /// share of its linear density: carried on there over scattered points, not seen running on.
  bool sparselyPast(const PipeEnd& end, double along) const {
    const PipeSegment& pipe = input_.pipes[static_cast<std::size_t>(end.pipe)];
    const auto past = std::count_if(pipe.inliers.begin(), pipe.inliers.end(), [&](std::uint32_t i) {
      return (position(i) - end.point).dot(end.outward) > along;
    });
    return static_cast<double>(past) <= kMaxPastCornerDensity * linearDensity(end.pipe) * -along;
  }

  /// Inliers per metre of axis of a pipe: the density a joint of the same size should show.
  double linearDensity(int pipe) const {
    const PipeSegment& segment = input_.pipes[static_cast<std::size_t>(pipe)];
    const double length = (segment.end - segment.start).norm();
    return length > 0.0 ? static_cast<double>(segment.inliers.size()) / length : 0.0;
  }

  void reconstructElbow(Hypothesis& h, const std::vector<std::uint32_t>& nearby) const {
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

  void reconstructTee(Hypothesis& h, const std::vector<std::uint32_t>& nearby) const {
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

  void reconstructBoundary(Hypothesis& h, const std::vector<std::uint32_t>& nearby) const {
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

  const JointsInput& input_;
  const JointsParams& params_;
  const std::vector<char>& explained_;
};

}  // namespace

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

namespace {

/// Whether `pipe` is a piece of the arc of `elbow` (reconstructed) fitted as a cylinder: both its
/// ends lie within its radius of the arc, or it was fitted across the bend.
bool liesOnArc(const PipeSegment& pipe, const Hypothesis& elbow) {
  const auto nearArc = [&](const Eigen::Vector3d& point, double within) {
    return std::any_of(elbow.axis.begin(), elbow.axis.end(),
                       [&](const Eigen::Vector3d& sample) { return (sample - point).norm() <= within; });
  };
  if (nearArc(pipe.start, pipe.radius) && nearArc(pipe.end, pipe.radius)) return true;
  // A cylinder fitted across the bend (a noisy bend's points fit one along a tangent or chord of
  // the arc) leaves the arc at one end: its middle lies on the arc, it runs off both pipes' lines
  // (a piece of either pipe runs along one), and it is at most half as long again as the arc.
  double arcLength = 0.0;
  for (std::size_t k = 1; k < elbow.axis.size(); ++k) arcLength += (elbow.axis[k] - elbow.axis[k - 1]).norm();
  const Eigen::Vector3d axis = unitAxis(pipe);
  const double maxCosine = std::cos(radians(kMinChordOffLineDeg));
  return std::fabs(axis.dot(elbow.a.outward)) <= maxCosine && std::fabs(axis.dot(elbow.b.outward)) <= maxCosine &&
         (pipe.end - pipe.start).norm() <= kMaxChordArcShare * arcLength &&
         nearArc(0.5 * (pipe.start + pipe.end), kChordMiddleRadii * pipe.radius) &&
         nearArc(pipe.start, kChordEndRadii * pipe.radius) && nearArc(pipe.end, kChordEndRadii * pipe.radius);
}

/// A spatial index over the pipes' axes: each pipe (by index) is filed in the cells its axis samples,
/// half a cell apart, fall in.
HashGrid pipeAxisGrid(const std::vector<PipeSegment>& pipes, double cellSize) {
  HashGrid grid(cellSize);
  for (std::size_t p = 0; p < pipes.size(); ++p) {
    const PipeSegment& pipe = pipes[p];
    const double length = (pipe.end - pipe.start).norm();
    const int steps = std::max(1, static_cast<int>(std::ceil(length / (0.5 * cellSize))));
    for (int k = 0; k <= steps; ++k) {
      const Eigen::Vector3d sample = pipe.start + (pipe.end - pipe.start) * (static_cast<double>(k) / steps);
      grid.insert(grid.cellOf(sample), static_cast<std::uint32_t>(p));
    }
  }
  return grid;
}

/// The joints chosen among the hypotheses between a set of pipes.
struct Resolution {
  std::vector<Hypothesis> hypotheses;
  std::vector<std::size_t> chosen;  // Into hypotheses, in the order they took their ends.
  std::vector<int> takenBy;         // By PipeEnd::key(): the chosen hypothesis that took the end, -1 for none.
  std::vector<char> arcPieces;      // By pipe: a piece of an elbow's arc, replaced by the elbow (it goes).
  JointsResult::Diagnostics diagnostics;
};

/// Hypotheses between `input.pipes`, reconstructed with their points, and the conflicts resolved.
/// `explained` flags the points that are inliers of some pipe; pipes from `completionsFrom` on are
/// completions of free ends.
Resolution resolveJoints(const JointsInput& input, const JointsParams& params, const std::vector<char>& explained,
                         std::size_t completionsFrom, const PointCells& cells, Progress& progress) {
  const auto& pipes = input.pipes;
  const int pipeCount = static_cast<int>(pipes.size());
  const JointBuilder builder(input, params, explained);
  Resolution resolution;

  double largestRadius = 0.0;
  for (const auto& pipe : pipes) largestRadius = std::max(largestRadius, pipe.radius);
  const HashGrid pipeGrid = pipeAxisGrid(pipes, cells.cellSize());

  // Hypotheses, in a deterministic order (by end, then by partner).
  auto& hypotheses = resolution.hypotheses;
  std::vector<int> near;
  const auto fragment = [&](int p) { return isFragment(pipes[static_cast<std::size_t>(p)], params); };
  for (int p = 0; p < pipeCount; ++p) {
    if (fragment(p)) continue;
    for (int side = 0; side < 2; ++side) {
      const PipeEnd end = endOf(pipes, p, side);
      const double partnerRadius = end.radius / params.minRadiusRatio;
      // (A tee's main may be the thickest pipe of all: see teeAt.)
      const double reach = std::max({builder.searchDistance(partnerRadius), builder.boundaryGapLimit(partnerRadius),
                                     builder.searchDistance(largestRadius)}) +
                           largestRadius;
      near.clear();
      pipeGrid.forEachInCube(end.point, reach, [&](std::uint32_t other) {
        if (static_cast<int>(other) != p && !fragment(static_cast<int>(other))) near.push_back(static_cast<int>(other));
      });
      std::sort(near.begin(), near.end());
      near.erase(std::unique(near.begin(), near.end()), near.end());
      for (int other : near) {
        ++resolution.diagnostics.candidatePairs;
        builder.tryTee(end, other, hypotheses);
        for (int otherSide = 0; otherSide < 2; ++otherSide) {
          if (2 * other + otherSide < end.key()) continue;  // Each end pair once.
          builder.tryEndPair(end, endOf(pipes, other, otherSide), hypotheses);
        }
      }
    }
  }
  progress.checkCancelled();

  std::vector<std::pair<Eigen::Vector3d, double>> spheres;
  for (const auto& hypothesis : hypotheses) spheres.emplace_back(hypothesis.center, hypothesis.reach);
  const auto nearby = pointsInSpheres(cells, spheres, [](std::size_t) { return true; });
  progress.checkCancelled();
  tbb::parallel_for(std::size_t{0}, hypotheses.size(),
                    [&](std::size_t h) { builder.reconstruct(hypotheses[h], nearby[h]); });
  progress.checkCancelled();
  // A completion starts at the shortest elbow's tangent point, so the bend voted with it says
  // nothing of the corner's shape: only the pipes found by the earlier stages are looked at.
  const auto measured = [&](const PipeEnd& end) { return static_cast<std::size_t>(end.pipe) < completionsFrom; };
  for (std::size_t h = 0, count = hypotheses.size(); h < count; ++h) {
    if (!measured(hypotheses[h].a) || !measured(hypotheses[h].b)) continue;
    if (auto tee = builder.teeForBendlessCorner(hypotheses[h], nearby[h])) {
      hypotheses[h].valid = false;
      hypotheses.push_back(std::move(*tee));
    }
  }

  // A pipe of an elbow's radius lying on the arc of an elbow hypothesis between two other pipes,
  // one confident enough to be accepted, may be a piece of that elbow's arc fitted as a cylinder.
  // Its joints wait for that elbow: they take their ends no earlier than it would.
  constexpr double kNoArc = 2.0;  // Above every confidence.
  std::vector<double> arcConfidence(static_cast<std::size_t>(pipeCount), kNoArc);
  for (const Hypothesis& elbow : hypotheses) {
    if (!elbow.valid || elbow.type != JointType::Elbow || elbow.confidence < params.acceptConfidence) continue;
    pipeGrid.forEachInCube(elbow.center, elbow.reach, [&](std::uint32_t p) {
      const PipeSegment& pipe = pipes[p];
      const double radiusRatio = std::min(pipe.radius, elbow.a.radius) / std::max(pipe.radius, elbow.a.radius);
      if (static_cast<int>(p) != elbow.a.pipe && static_cast<int>(p) != elbow.b.pipe && !fragment(static_cast<int>(p)) &&
          radiusRatio >= params.minRadiusRatio && liesOnArc(pipe, elbow)) {
        arcConfidence[p] = std::min(arcConfidence[p], elbow.confidence);
      }
    });
  }
  const auto onArc = [&](int p) { return arcConfidence[static_cast<std::size_t>(p)] < kNoArc; };
  const auto otherPipe = [](const Hypothesis& joint) {
    return joint.type == JointType::Tee ? joint.mainPipe : joint.b.pipe;
  };
  const auto rank = [&](std::size_t h) {
    const Hypothesis& joint = hypotheses[h];
    const double waitsFor = std::min(arcConfidence[static_cast<std::size_t>(joint.a.pipe)],
                                     arcConfidence[static_cast<std::size_t>(otherPipe(joint))]);
    // (confidence, whether it does not wait): an elbow goes before the joints that wait for it.
    return std::pair{std::min(joint.confidence, waitsFor), joint.confidence < waitsFor};
  };

  // Conflicts: the best-supported hypothesis takes its ends first.
  std::vector<std::size_t> order;
  for (std::size_t h = 0; h < hypotheses.size(); ++h) {
    if (!hypotheses[h].valid) continue;
    ++resolution.diagnostics.hypotheses[static_cast<std::size_t>(hypotheses[h].type)];
    order.push_back(h);
  }
  std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return rank(x) > rank(y); });
  auto& takenBy = resolution.takenBy;
  takenBy.assign(2 * static_cast<std::size_t>(pipeCount), -1);
  const auto taken = [&](const PipeEnd& end) { return takenBy[static_cast<std::size_t>(end.key())] >= 0; };
  // A tee whose main stops short of the junction carries the main's line on past that end, as far
  // as the junction at least: no joint may turn the end nearer (a riser that bends at an elbow does
  // not run on to a tee above it). By end: how far past it a chosen tee carries its line.
  std::vector<double> carriedPast(takenBy.size(), -std::numeric_limits<double>::infinity());
  const auto turnsAhead = [](const Hypothesis& joint, const PipeEnd& end) {  // where the joint ends its line
    if (joint.type == JointType::Boundary) return std::numeric_limits<double>::infinity();
    return (joint.corner - end.point).dot(end.outward);
  };
  const auto turnedShort = [&](const Hypothesis& joint, const PipeEnd& end) {
    return carriedPast[static_cast<std::size_t>(end.key())] > turnsAhead(joint, end);
  };
  const auto carriedPastTurn = [&](const Hypothesis& tee) {
    if (!tee.mainEnd) return false;
    const int by = takenBy[static_cast<std::size_t>(tee.mainEnd->key())];
    if (by < 0) return false;
    const Hypothesis& joint = hypotheses[static_cast<std::size_t>(by)];
    const PipeEnd& end = joint.a.key() == tee.mainEnd->key() ? joint.a : joint.b;
    return turnsAhead(joint, end) < turnsAhead(tee, *tee.mainEnd);
  };
  MovedEnds movedEnds(pipes);
  for (std::size_t h : order) {
    const Hypothesis& hypothesis = hypotheses[h];
    const bool twoEnds = hypothesis.type != JointType::Tee;
    const bool elbow = hypothesis.type == JointType::Elbow;
    if (taken(hypothesis.a) || (twoEnds && taken(hypothesis.b)) || turnedShort(hypothesis, hypothesis.a) ||
        (twoEnds && turnedShort(hypothesis, hypothesis.b)) || carriedPastTurn(hypothesis) ||
        (elbow && !movedEnds.leaveLength(hypothesis))) {
      ++resolution.diagnostics.conflicts;
      continue;
    }
    takenBy[static_cast<std::size_t>(hypothesis.a.key())] = static_cast<int>(h);
    if (twoEnds) takenBy[static_cast<std::size_t>(hypothesis.b.key())] = static_cast<int>(h);
    if (hypothesis.mainEnd) {
      double& past = carriedPast[static_cast<std::size_t>(hypothesis.mainEnd->key())];
      past = std::max(past, turnsAhead(hypothesis, *hypothesis.mainEnd));
    }
    if (elbow) movedEnds.move(hypothesis);
    resolution.chosen.push_back(h);
  }

  resolution.arcPieces.assign(static_cast<std::size_t>(pipeCount), 0);
  auto& chosen = resolution.chosen;
  // The pieces on the arc of an elbow chosen between two other pipes go, and their own joints
  // with them.
  for (std::size_t h : chosen) {
    const Hypothesis& elbow = hypotheses[h];
    if (elbow.type != JointType::Elbow || onArc(elbow.a.pipe) || onArc(elbow.b.pipe)) continue;
    pipeGrid.forEachInCube(elbow.center, elbow.reach, [&](std::uint32_t p) {
      if (onArc(static_cast<int>(p)) && static_cast<int>(p) != elbow.a.pipe && static_cast<int>(p) != elbow.b.pipe &&
          liesOnArc(pipes[p], elbow)) {
        resolution.arcPieces[p] = 1;
      }
    });
  }
  const auto onPiece = [&](std::size_t h) {
    return resolution.arcPieces[static_cast<std::size_t>(hypotheses[h].a.pipe)] ||
           resolution.arcPieces[static_cast<std::size_t>(otherPipe(hypotheses[h]))];
  };
  for (std::size_t h : chosen) {
    if (!onPiece(h)) continue;
    takenBy[static_cast<std::size_t>(hypotheses[h].a.key())] = -1;
    if (hypotheses[h].type != JointType::Tee) takenBy[static_cast<std::size_t>(hypotheses[h].b.key())] = -1;
  }
  chosen.erase(std::remove_if(chosen.begin(), chosen.end(), onPiece), chosen.end());
  return resolution;
}

/// The directions of the network: the pipes' axes grouped within a few degrees (longest pipes
/// first, ties in input order), each group's length-weighted mean, for groups of at least half a
/// metre of pipe.
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

/// Sums over points in a plane from which the squared distances of the points from the line that
/// fits them best follow (the smaller eigenvalue of their covariance), for any run of them.
struct LineFitSums {
  double count = 0.0;
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  Eigen::Matrix2d squares = Eigen::Matrix2d::Zero();

  void add(const Eigen::Vector2d& q) {
    count += 1.0;
    sum += q;
    squares += q * q.transpose();
  }
  LineFitSums operator-(const LineFitSums& other) const {
    return {count - other.count, sum - other.sum, squares - other.squares};
  }
  double squaresOffLine() const {
    if (count <= 0.0) return 0.0;
    const Eigen::Vector2d mean = sum / count;
    const Eigen::Matrix2d covariance = squares / count - mean * mean.transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> solver(covariance, Eigen::EigenvaluesOnly);
    return count * std::max(0.0, solver.eigenvalues()(0));
  }
};

/// The ground: the lowest level of the removed planes that face up (floors), when no more than a
/// trace of the scan lies below it. Nothing was seen under it and no pipe runs through it: a tube
/// reaching below it is a fit to the floor's points by a riser's foot, not a pipe.
class Ground {
 public:
  Ground(const PointCloud* planes, const PointCloud& cloud) {
    if (!planes || planes->normals.empty()) return;
    const double minUp = std::cos(radians(kMaxFloorTiltDeg));
    std::vector<double> heights;
    for (std::size_t i = 0; i < planes->size(); ++i) {
      if (std::fabs(planes->normals[i].z()) >= minUp) heights.push_back(planes->positions[i].z());
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
                                     [&](const Eigen::Vector3f& p) { return p.z() < height - kLevelStep; });
    if (static_cast<double>(below) <= kMaxShareBelowGround * static_cast<double>(cloud.size())) height_ = height;
  }

  /// Whether the tube of `pipe` reaches below the ground by more than the floor's noise.
  bool under(const PipeSegment& pipe) const {
    if (!height_) return false;
    const Eigen::Vector3d axis = unitAxis(pipe);
    const double lowest = std::min(pipe.start.z(), pipe.end.z()) -
                          pipe.radius * std::sqrt(std::max(0.0, 1.0 - axis.z() * axis.z()));
    return lowest < *height_ - kGroundTolerance;
  }

 private:
  static constexpr double kMaxFloorTiltDeg = 10.0;      // Plane points whose normals lie this near vertical are floors'.
  static constexpr double kLevelStep = 0.02;            // Floors' heights are binned this finely (m).
  static constexpr double kMinGroundShare = 0.05;       // The ground's level holds this share of the floors' points...
  static constexpr double kMaxShareBelowGround = 0.001; // ...and at most this share of the scan lies under it.
  static constexpr double kGroundTolerance = 0.005;     // A tube may reach this far below it (m): a pipe lying on it.
  std::optional<double> height_;
};

/// The 1 cm cells holding points removed as large planes: a point lies by a plane when a cell within
/// one of its own holds one (within 1–2 cm of a plane point). Kept as sorted cell keys, built once
/// per joining: a large scan's floors hold millions of points, too many to file again each round.
class PlaneCells {
 public:
  explicit PlaneCells(const PointCloud* planes) {
    if (!planes) return;
    keys_.reserve(planes->size());
    for (const Eigen::Vector3f& position : planes->positions) keys_.push_back(cellKey(cellOf(position.cast<double>())));
    stableSortByKey(keys_, [](std::uint64_t key) { return key; });
    keys_.erase(std::unique(keys_.begin(), keys_.end()), keys_.end());
  }

  bool by(const Eigen::Vector3d& p) const {
    if (keys_.empty()) return false;
    const Eigen::Vector3i cell = cellOf(p);
    for (int k = 0; k < 27; ++k) {
      const Eigen::Vector3i near = cell + Eigen::Vector3i(k % 3 - 1, k / 3 % 3 - 1, k / 9 - 1);
      if (std::binary_search(keys_.begin(), keys_.end(), cellKey(near))) return true;
    }
    return false;
  }

 private:
  static constexpr double kCellSize = 0.01;
  static Eigen::Vector3i cellOf(const Eigen::Vector3d& p) { return (p / kCellSize).array().floor().cast<int>(); }

  std::vector<std::uint64_t> keys_;
};

/// A pipe the earlier stages missed, found beyond a free end: short legs between elbows and tails
/// into equipment hold too few points for the Gaussian sphere, but knowing the radius, the end and
/// the network's directions leaves only the corner's place to find.
struct Completion {
  PipeEnd from;   // The end it continues beyond an elbow...
  int main = -1;  // ...or, when not negative, the pipe it branches from at a tee.
  PipeSegment pipe;  // From the corner beyond `from` (the main's wall) to its last supported section.
  bool between = false;  // A leg up to the corner beyond a second end (see Completer::legBetween).
  std::size_t bendSupport = 0;  // Points on the elbow's bend, for a leg found from them (see legBeyondBend)...
  double bendSeenShare = 1.0;   // ...and the share of its turn they show, when it was seen from its start only.

  /// The points that support it: on its pipe, and on the bend it was found from.
  std::size_t support() const { return pipe.inliers.size() + bendSupport; }
};

class Completer {
 public:
  /// `fromBends`: complete legs from their bends alone (see legBeyondBend), and no straight legs.
  /// `planes`: the cells of points removed as planes (see completeAt).
  Completer(const JointsInput& input, const JointsParams& params, const JointBuilder& builder, bool fromBends,
            const PlaneCells& planes)
      : input_(input), params_(params), builder_(builder), fromBends_(fromBends), scanNoise_(medianFitRms(input.pipes)),
        planes_(planes) {}

  /// The radius of the sphere around an end that holds every point a completion may use.
  double reach(const PipeEnd& end) const {
    return builder_.searchDistance(end.radius) + params_.maxBendRadii * end.radius + params_.maxCompletionLength +
           end.radius + params_.supportDistance;
  }

  /// The best-supported completion of `end` along one of `directions` (either way), from the
  /// points `nearby` (not explained by any pipe).
  std::optional<Completion> complete(const PipeEnd& end, const std::vector<Eigen::Vector3d>& networkDirections,
                                     const std::vector<std::uint32_t>& nearby) const {
    std::vector<Eigen::Vector3d> directions = networkDirections;
    // A local direction near a network direction is that direction, measured less well.
    const auto local = localDirection(end, nearby);
    if (local && std::none_of(directions.begin(), directions.end(), [&](const Eigen::Vector3d& direction) {
          return std::fabs(direction.dot(*local)) >= std::cos(radians(kLocalDirectionSnapDeg));
        })) {
      directions.push_back(*local);
    }
    std::optional<Completion> best;
    for (std::size_t d = 0; d < directions.size(); ++d) {
      const bool networks = d < networkDirections.size();
      for (const double sign : {1.0, -1.0}) {
        auto candidate = completeAlong(end, sign * directions[d], networks, nearby);
        if (candidate && (!best || candidate->support() > best->support())) {
          best = std::move(candidate);
        }
      }
    }
    return best;
  }

  /// The leg square to the parallel pipes of ends `a` and `b` that joins their extensions, an elbow
  /// at each: a U-turn (the two ends face one way) or an offset (they face opposite ways). Seen by a
  /// few scan lines between two elbows, such a leg holds too few points for complete(); but the two
  /// pipes fix its direction and length, so it needs only half the points, over its whole length.
  /// Where along the pipes it runs is voted for as in completeAlong. `nearby` and `nearbyB`: the
  /// points not explained by any pipe within reach(a) and reach(b).
  std::optional<Completion> legBetween(const PipeEnd& a, const PipeEnd& b, const std::vector<std::uint32_t>& nearby,
                                       const std::vector<std::uint32_t>& nearbyB) const {
    if (std::min(a.radius, b.radius) < params_.minRadiusRatio * std::max(a.radius, b.radius)) return std::nullopt;
    const Eigen::Vector3d& outward = a.outward;
    const double parallel = outward.dot(b.outward);
    if (std::fabs(parallel) < std::cos(radians(kMaxLegTiltDeg))) return std::nullopt;
    const Eigen::Vector3d offset = b.point - a.point;
    const double axial = offset.dot(outward);  // b's end along a's axis.
    const Eigen::Vector3d lateral = offset - axial * outward;
    const double span = lateral.norm();  // Axis to axis: the leg's length, corner to corner.
    const double r = 0.5 * (a.radius + b.radius);
    const double band = params_.supportDistance;
    // The straight runs between the tightest elbows' tangent points.
    const double firstAlong = params_.minBendRadii * r;
    const double length = span - firstAlong - kShortElbowRadii * r;
    if (length < 2.0 * r * params_.minPipeDiameters || length > params_.maxCompletionLength) return std::nullopt;
    // Corners (along a's axis from its end) past both ends, within the search distance of each.
    const double behindA = cornerBehindEnd(a.radius, 0.5 * kPi);
    const double behindB = cornerBehindEnd(b.radius, 0.5 * kPi);
    const double searchA = builder_.searchDistance(a.radius);
    const double searchB = builder_.searchDistance(b.radius);
    const bool uTurn = parallel > 0.0;
    const double minCorner = uTurn ? std::max(-behindA, axial - behindB) : std::max(-behindA, axial - searchB);
    const double maxCorner = uTurn ? std::min(searchA, axial + searchB) : std::min(searchA, axial + behindB);
    if (minCorner >= maxCorner) return std::nullopt;

    const Eigen::Vector3d along = lateral / span;
    const Eigen::Vector3d aside = along.cross(outward);
    // A point on the leg's surface: (x − corner)² + y² = r², x along a's axis, y off the plane.
    const double cornerBin = 0.5 * band;
    VoteHistogram histogram(minCorner, maxCorner, cornerBin);
    for (std::uint32_t i : nearby) {
      const Eigen::Vector3d w = input_.cloud.positions[i].cast<double>() - a.point;
      const double distanceAlong = w.dot(along);
      const double y = w.dot(aside);
      if (distanceAlong < firstAlong || distanceAlong > firstAlong + length || std::fabs(y) >= r) continue;
      const double x = w.dot(outward);
      const double half = std::sqrt(r * r - y * y);
      for (const double corner : {x - half, x + half}) {
        if (corner < minCorner || corner > maxCorner) continue;
        const Eigen::Vector3d radial = (x - corner) * outward + y * aside;
        if (normalAgrees(input_.cloud, i, radial / r, kCompletionNormalAngleDeg)) histogram.vote(corner);
      }
    }
    Straight straight;
    straight.radius = r;
    straight.firstAlong = firstAlong;
    straight.clutterFrom = kShortElbowRadii * r;  // As completeAlong's, for a square bend.
    straight.behindStart = r + 2.0 * band;
    straight.minPoints = static_cast<std::size_t>(std::ceil(kLegSupportShare * static_cast<double>(params_.minCompletionPoints)));
    straight.minCoverage = kLegSupportShare * params_.minCompletionCoverage;
    straight.between = true;
    std::optional<Completion> best;
    for (const double peak : histogram.peaks(kCornerPeaks)) {
      // A few scan lines on one side of a thin leg put it a few millimetres off, which the radius
      // test notices: least squares places the corner within the peak's bin.
      const double cornerDistance = refinedCorner(a.point, outward, along, aside, r, firstAlong, firstAlong + length, peak,
                                                 0.5 * cornerBin, nearby);
      // The leg runs to b's axis where it crosses the plane square to a's through the corner: the
      // two axes are not quite parallel, and a degree matters over a thin leg's few points.
      straight.corner = a.point + cornerDistance * outward;
      const Eigen::Vector3d farCorner =
          b.point - ((b.point - straight.corner).dot(outward) / b.outward.dot(outward)) * b.outward;
      const double legSpan = (farCorner - straight.corner).norm();
      straight.along = (farCorner - straight.corner) / legSpan;
      straight.across = (outward - outward.dot(straight.along) * straight.along).normalized();
      straight.aside = straight.along.cross(straight.across);
      straight.length = legSpan - firstAlong - kShortElbowRadii * r;
      if (straight.length < 2.0 * r * params_.minPipeDiameters) continue;
      auto candidate = completeAt(straight, nearby);
      if (!candidate || (best && candidate->inliers.size() <= best->pipe.inliers.size())) continue;
      // The same leg seen from b's end must pass too: a handrail post that two rails end at runs on
      // past one of them, which only that rail's corner sees behind it.
      Straight fromB = straight;
      fromB.corner = farCorner;
      fromB.along = -straight.along;
      fromB.aside = -straight.aside;
      if (completeAt(fromB, nearbyB)) {
        candidate->end = farCorner;
        best = Completion{a, -1, std::move(*candidate), true};
      }
    }
    return best;
  }

  /// The radius around pipe `main`'s axis that holds every point branchesOf() looks at.
  double branchReach(int main) const {
    const double radius = input_.pipes[static_cast<std::size_t>(main)].radius;
    return radius / std::sin(radians(params_.minTeeAngleDeg)) + params_.maxCompletionLength +
           2.0 * (radius + params_.supportDistance);
  }

  /// Branches the earlier stages missed leaving the body of pipe `main` along one of `directions`:
  /// a thin branch seen in a few scan columns has too few points, and too little arc, for the
  /// Gaussian sphere and the placement. Its axis meets the main's, so only where along the main (s)
  /// and how thick (r) are unknown: seen along the branch, with the main's axis across at angle φ
  /// and h the offset from the plane of the two axes, a point with its normal across the branch
  /// votes for the (s, r) that put it on the surface, (q − s sin φ)² + h² = r². Columns on
  /// different sides of the arc meet in one (s, r); the few best peaks are refined by least squares
  /// and each is checked as a completion is (completeAt). `nearby`: the points not explained by
  /// any pipe within branchReach(main).
  std::vector<Completion> branchesOf(int main, const std::vector<Eigen::Vector3d>& directions,
                                     const std::vector<std::uint32_t>& nearby) const {
    const PipeSegment& mainPipe = input_.pipes[static_cast<std::size_t>(main)];
    const double maxRadius = mainPipe.radius;  // A branch is no thicker than its main.
    std::vector<Completion> found;
    if (params_.minBranchRadius <= 0.0 || maxRadius < params_.minBranchRadius) return found;
    const Eigen::Vector3d u = unitAxis(mainPipe);
    const double length = (mainPipe.end - mainPipe.start).norm();
    const double band = params_.supportDistance;
    const double positionBin = 0.5 * band;
    const int radiusBins =
        1 + static_cast<int>(std::floor(std::log(maxRadius / params_.minBranchRadius) / std::log(kBranchRadiusStep)));
    std::vector<double> radii(static_cast<std::size_t>(radiusBins));  // Each bin's radius, for every voter.
    for (int k = 0; k < radiusBins; ++k) {
      radii[static_cast<std::size_t>(k)] = params_.minBranchRadius * std::pow(kBranchRadiusStep, k);
    }
    const auto radiusOf = [&](int k) { return radii[static_cast<std::size_t>(k)]; };
    const double maxLean = std::sin(radians(kCompletionNormalAngleDeg));
    std::vector<Eigen::Vector3d> offsets;  // Of the nearby points from the main's start.
    offsets.reserve(nearby.size());
    for (std::uint32_t i : nearby) offsets.push_back(input_.cloud.positions[i].cast<double>() - mainPipe.start);
    for (const Eigen::Vector3d& direction : directions) {
      const double cosine = direction.dot(u);
      if (std::fabs(cosine) > std::cos(radians(params_.minTeeAngleDeg))) continue;
      const double sine = std::sqrt(1.0 - cosine * cosine);
      const Eigen::Vector3d inPlane = (u - cosine * direction) / sine;
      const double wall = mainPipe.radius / sine;  // From the main's axis to its wall, along the branch.
      // The voters on either side of the main, from one pass: a point lies on one side at most (both
      // sides' offsets are each other's negatives, exactly).
      const Eigen::Vector3d asidePositive = direction.cross(inPlane);
      std::array<std::vector<BranchVoter>, 2> votersBySide;  // Along +direction, along −direction.
      for (std::size_t k = 0; k < nearby.size(); ++k) {
        const Eigen::Vector3d& w = offsets[k];
        const double h = w.dot(asidePositive);
        if (std::fabs(h) >= maxRadius) continue;
        const double ahead = w.dot(direction);
        const double distanceAlong = std::fabs(ahead);
        if (distanceAlong < wall + band || distanceAlong > wall + params_.maxCompletionLength) continue;
        if (!input_.cloud.normals.empty() &&
            std::fabs(input_.cloud.normals[nearby[k]].cast<double>().dot(direction)) > maxLean) {
          continue;
        }
        const bool positive = ahead > 0.0;
        votersBySide[positive ? 0 : 1].push_back({w.dot(inPlane), positive ? h : -h});
      }
      for (const double sign : {1.0, -1.0}) {
        const Eigen::Vector3d along = sign * direction;
        const Eigen::Vector3d aside = along.cross(inPlane);
        const std::vector<BranchVoter>& voters = votersBySide[sign > 0.0 ? 0 : 1];
        if (voters.size() < params_.minCompletionPoints) continue;
        GridVotes votes(static_cast<int>(std::ceil(length / positionBin)) + 1, radiusBins);
        for (const BranchVoter& voter : voters) {
          for (int k = 0; k < radiusBins; ++k) {
            const double r = radiusOf(k);
            if (r <= std::fabs(voter.h)) continue;
            const double half = std::sqrt(r * r - voter.h * voter.h);
            for (const double root : {voter.q - half, voter.q + half}) {
              // Well inside the main's body (see teeAt): nearer an end, the branch is an elbow's.
              const double s = root / sine;
              if (s < 2.0 * r || s > length - 2.0 * r) continue;
              votes.vote(static_cast<int>(std::lround(s / positionBin)), k);
            }
          }
        }
        std::vector<std::pair<double, double>> tried;  // (s, r) of the peaks looked at.
        for (const GridVotes::Peak& peak : votes.peaks(static_cast<float>(params_.minCompletionPoints))) {
          if (tried.size() == kBranchPeaks) break;
          double s = peak.row * positionBin;
          double r = radiusOf(peak.column);
          // One branch makes peaks at several radii around one place.
          if (std::any_of(tried.begin(), tried.end(), [&](const std::pair<double, double>& other) {
                return std::fabs(other.first - s) < other.second + r;
              })) {
            continue;
          }
          tried.emplace_back(s, r);
          refineBranch(voters, sine, s, r);
          if (r < params_.minBranchRadius || r > maxRadius || s < 2.0 * r || s > length - 2.0 * r) continue;
          Straight straight = completionStraight();
          straight.corner = mainPipe.start + s * u;
          straight.along = along;
          straight.across = inPlane;
          straight.aside = aside;
          straight.radius = r;
          straight.firstAlong = wall;
          straight.clutterFrom = wall;
          straight.behindStart = wall + 2.0 * band;
          auto pipe = completeAt(straight, nearby);
          if (!pipe) continue;
          pipe->start = straight.corner + wall * along;  // The branch meets the main at its wall.
          found.push_back(Completion{PipeEnd{}, main, std::move(*pipe)});
        }
      }
    }
    return found;
  }

 private:
  static constexpr double kLocalDirectionSnapDeg = 5.0;  // See complete().
  static constexpr std::size_t kCornerPeaks = 3;  // Corners tried per direction (see completeAlong).
  static constexpr double kMaxLegTiltDeg = 3.0;    // Pipes this close to parallel may hold a leg between
  static constexpr double kLegSupportShare = 0.5;  // them (see legBetween), with this share of a completion's
                                                   // points and coverage.
  static constexpr std::size_t kBranchPeaks = 3;  // Branches tried per direction and side (see branchesOf)...
  static constexpr double kBranchRadiusStep = 1.03;  // ...over radii 3 % apart.
  static constexpr int kBranchRefinements = 5;  // Gauss–Newton steps of refineBranch...
  static constexpr int kCornerRefinements = 5;  // ...and of refinedCorner.
  // A missed pipe is sparse: a normal fitted over a few of its scan columns leans up to about 45°
  // off the radial direction, where one fitted over a dense surface keeps within 30°.
  static constexpr double kCompletionNormalAngleDeg = 40.0;
  static constexpr double kBendRadiusStepRadii = 0.1;  // A bend's major radii voted for this many pipe radii
  static constexpr double kMinBendRadiusStep = 0.002;  // apart, and at least this (m; see legBeyondBend),
  static constexpr double kMinOneSidedBendRadii = 1.8;  // from this many (a short-radius elbow's 2, less a 10 %).
  static constexpr double kMinBendDensityShare = 0.1;  // A bend's points per metre of arc, against its end's...
  static constexpr double kEndDensityLength = 0.12;     // ...inliers per metre over this much of it (m).
  // A bend seen only from its start: covered from its first two sections on (gaps of one) over
  static constexpr double kMinSeenTurnDeg = 35.0;      // this much of its turn at least, in at least
  static constexpr std::size_t kMinSeenSections = 4;   // this many sections (fewer fit a floor's or a flange's
                                                       // edge by a pipe's end as well), with twice a completion's
  static constexpr double kMinSeenDensityShare = 1.0 / 3.0;  // points, this share of its end's density or more.
  static constexpr int kMaxLeadSections = 3;  // The straight starts this close to the elbow...
  static constexpr int kMaxGapSections = 3;   // ...and ends at a gap longer than this, unless...
  static constexpr std::size_t kMaxBridgeSections = 20;  // ...a run as long follows a gap up to this.
  static constexpr std::size_t kBehindSections = 5;  // Sections looked at behind the corner (see completeAt).
  static constexpr double kMaxClutterShare = 0.5;  // Clutter (see isClutter), against points on the surface.
  static constexpr double kFaceNormalAngleDeg = 30.0;  // Normals this close to the axis: a face across it.
  static constexpr double kMaxByPlaneShare = 0.5;     // A leg's inliers lying by a removed plane, at most.
  static constexpr double kMaxFlatShare = 0.4;          // Normals sharing one direction (see flatShare)...
  static constexpr double kLineToCircle = 0.9;          // ...with a line fit's RMS under this share of the
                                                        // circle's: a flat face.
  static constexpr double kTwoLinesToCircle = 0.6;      // Two lines meeting at a corner fitting this much
                                                        // better than the circle: a post's edge...
  static constexpr std::size_t kMinEdgePoints = 20;     // ...over this many points (fewer fit any two lines)...
  static constexpr double kMaxEdgeGapDeg = 20.0;        // ...around the axis with no wider gap between them.
  static constexpr int kSquareToleranceDeg = 15;        // Two normal directions this close to square...
  static constexpr double kMinFaceShare = 0.2;          // ...each holding this share of the points...
  static constexpr double kMinSquareShare = 0.7;        // ...and together this share: two faces at an edge.
  static constexpr int kMinSectorPoints = 5;            // Out-of-roundness over 10° sectors of this many points...
  static constexpr double kMaxOutOfRoundRadii = 0.02;   // ...may be this share of the radius...
  static constexpr double kMinOutOfRound = 0.0025;      // ...or this (m): a placed axis is a little off.
  // Legs taken for normals square to their axis (see straightBeyond): a normal within this of square...
  static constexpr double kSquareNormalAngleDeg = 10.0;
  // ...and where more than this share of a leg's points were taken so, its band points' RMS off the
  // circle at most this many times the scan's noise (the median fit RMS of its pipes, or the end's
  // pipe's when lower) and this (m), and its out-of-roundness at most this (m). A rail-sized circle
  // down a handrail's 5 cm square post has its faces 3.6-5.9 mm RMS off it and 2.0-2.4 mm out of round.
  static constexpr double kMaxSquareNormalShare = 0.3;
  static constexpr double kSquareNormalNoiseFactor = 1.75;
  static constexpr double kMaxSquareNormalBandRms = 0.004;
  static constexpr double kMaxSquareNormalOutOfRound = 0.0015;
  // Gentler bends' straight legs, reaching that far behind an end, fit the end's own elbow's torus
  // (medium seed 4: a 0.4 m leg across a 90° bend's arc, 8° off its pipe).
  static constexpr double kMinOvershootBendDeg = 15.0;
  // A bend's support band (legBeyondBend), in radii of its tube, where narrower than the joints'.
  static constexpr double kBendBandRadii = 0.35;
  static constexpr double kMinRadiusTolerance = 0.0015;  // The mean offset of the points from the radius (m)...
  static constexpr double kRadiusToleranceRadii = 0.03;  // ...may be this share of the radius, or the above.

  /// A point voting for a branch (see branchesOf), seen along the branch: its offsets across it
  /// along the main's axis (q) and off the plane of the two axes (h).
  struct BranchVoter {
    double q;
    double h;
  };

  /// A straight a completion is looked for along: its axis leaves `corner` along `along` (`across`
  /// × `aside` = `along`); its surface is looked at over `length` from `firstAlong` on, the clutter
  /// around it counted from `clutterFrom` on, and its surface behind the corner from `behindStart`
  /// back. It needs `minPoints` on its surface over `minCoverage` of its sections: a run of them from
  /// near the corner, or (`between`) the whole window, a leg whose far end is known.
  struct Straight {
    Eigen::Vector3d corner = Eigen::Vector3d::Zero();
    Eigen::Vector3d along = Eigen::Vector3d::Zero();
    Eigen::Vector3d across = Eigen::Vector3d::Zero();
    Eigen::Vector3d aside = Eigen::Vector3d::Zero();
    double radius = 0.0;
    double firstAlong = 0.0;
    double length = 0.0;
    double clutterFrom = 0.0;
    double behindStart = 0.0;
    std::size_t minPoints = 0;
    double minCoverage = 0.0;
    bool between = false;
    double noise = 0.0;  // The scan's noise, when points with square normals count too (0: they do not).
  };

  /// A straight with a completion's window and the support it needs; the caller places it.
  Straight completionStraight() const {
    Straight straight;
    straight.length = params_.maxCompletionLength;
    straight.minPoints = params_.minCompletionPoints;
    straight.minCoverage = params_.minCompletionCoverage;
    return straight;
  }

  /// How far behind a free end (radius r) the corner of an elbow bending by `bend` may lie: the
  /// found end may pass the corner by a radius, and on slight bends by the length over which the
  /// bent surface stays within the support band.
  double cornerBehindEnd(double r, double bend) const { return r + params_.supportDistance / std::sin(bend); }

  /// How far past a gentle bend's corner `end`'s pipe may run: a straight fit, a cylinder's or a
  /// completion's, takes the bent pipe's first stretch while that stays within about a radius of
  /// its axis (medium seed 3: a 24 mm branch ran 0.12 m past a 17° bend). Not past half the pipe,
  /// and not below kMinOvershootBendDeg (0: no such reach).
  double overshoot(const PipeEnd& end, double bend) const {
    if (bend < radians(kMinOvershootBendDeg)) return 0.0;
    const PipeSegment& pipe = input_.pipes[static_cast<std::size_t>(end.pipe)];
    const double r = end.radius;
    return std::min(0.5 * (pipe.end - pipe.start).norm(), r + (params_.supportDistance + r) / std::tan(bend));
  }

  /// The direction of a pipe leaving the corner ahead of `end`, from the points around it: a point
  /// on a pipe of the end's radius has its axis one radius behind it along its normal, so each
  /// point and each corner on the end's extension give the direction from that corner to that axis
  /// point, for points whose normals are square to it. The most voted (corner, direction) bin gives
  /// the direction. Sloped or one-off legs are no network direction: this finds them.
  std::optional<Eigen::Vector3d> localDirection(const PipeEnd& end, const std::vector<std::uint32_t>& nearby) const {
    if (input_.cloud.normals.empty()) return std::nullopt;
    constexpr double kCornerStep = 0.01;  // Corner bins along the end's extension (m).
    constexpr double kAngleStep = 2.0;    // Direction bins (deg).
    constexpr double kMaxNormalTilt = 15.0;  // A voter's normal is this close to square to the direction (deg).
    constexpr double kVoteLength = 0.5;   // Points this far past a corner vote (m): the start of the leg.
    constexpr double kMinNormalSpread = 0.1;  // Voters' normals turning this much fix the axis (see below)...
    constexpr double kRefinedNormalTilt = 3.0;  // ...refined on those this close to square to it (deg).
    const Eigen::Vector3d u = end.outward;
    const Eigen::Vector3d x = u.unitOrthogonal();
    const Eigen::Vector3d y = u.cross(x);
    const double r = end.radius;
    const double minCorner = -cornerBehindEnd(r, radians(params_.minCompletionBendDeg));
    const double maxCorner = builder_.searchDistance(r);
    const auto corners = static_cast<int>(std::ceil((maxCorner - minCorner) / kCornerStep)) + 1;
    const double maxTilt = std::sin(radians(kMaxNormalTilt));
    const int polarBins = static_cast<int>(std::ceil(180.0 / kAngleStep));
    const int turnBins = static_cast<int>(std::ceil(360.0 / kAngleStep));
    struct Vote {
      std::uint64_t bin;
      std::uint32_t point;
      Eigen::Vector3d direction;
    };
    std::vector<Vote> votes;
    for (std::uint32_t i : nearby) {
      const Eigen::Vector3d p = input_.cloud.positions[i].cast<double>();
      const Eigen::Vector3d normal = input_.cloud.normals[i].cast<double>();
      const Eigen::Vector3d offset = p - end.point;
      if (offset.norm() > maxCorner + kVoteLength + r) continue;
      for (const double sign : {1.0, -1.0}) {
        const Eigen::Vector3d axisPoint = p - sign * r * normal;
        for (int c = 0; c < corners; ++c) {
          const Eigen::Vector3d leg = axisPoint - (end.point + (minCorner + c * kCornerStep) * u);
          const double length = leg.norm();
          if (length < 2.0 * r || length > kVoteLength) continue;
          const Eigen::Vector3d direction = leg / length;
          if (std::fabs(direction.dot(normal)) > maxTilt) continue;
          const double polar = degrees(std::acos(std::clamp(direction.dot(u), -1.0, 1.0)));
          if (polar < params_.minCompletionBendDeg || polar > params_.maxElbowAngleDeg) continue;
          const double turn = degrees(std::atan2(direction.dot(y), direction.dot(x))) + 180.0;
          const auto polarBin = std::min(polarBins - 1, static_cast<int>(polar / kAngleStep));
          // Fewer turn bins near the pole keep the bins' areas alike.
          const int rowBins = std::max(1, static_cast<int>(std::ceil(turnBins * std::sin(radians((polarBin + 0.5) * kAngleStep)))));
          const auto turnBin = std::min(rowBins - 1, static_cast<int>(turn / 360.0 * rowBins));
          const std::uint64_t key = (static_cast<std::uint64_t>(c) * static_cast<std::uint64_t>(polarBins) +
                                     static_cast<std::uint64_t>(polarBin)) * static_cast<std::uint64_t>(turnBins) +
                                    static_cast<std::uint64_t>(turnBin);
          votes.push_back({key, i, direction});
        }
      }
    }
    if (votes.empty()) return std::nullopt;
    std::stable_sort(votes.begin(), votes.end(), [](const Vote& a, const Vote& b) { return a.bin < b.bin; });
    std::size_t bestFirst = 0, bestCount = 0;
    for (std::size_t first = 0; first < votes.size();) {
      std::size_t last = first;
      while (last < votes.size() && votes[last].bin == votes[first].bin) ++last;
      if (last - first > bestCount) {
        bestCount = last - first;
        bestFirst = first;
      }
      first = last;
    }
    if (bestCount < params_.minCompletionPoints) return std::nullopt;
    // The axis is the direction square to the voters' normals when they turn enough to fix it (a
    // square post's faces tilt the binned directions until its points fit a cylinder); on sparse
    // pipes seen from afar the normals all face the scanner, and the binned directions decide.
    // Voters on the elbow, whose normals lean on the leg's axis, are left out in a second pass.
    Eigen::Vector3d axis = Eigen::Vector3d::Zero();
    for (std::size_t k = bestFirst; k < bestFirst + bestCount; ++k) axis += votes[k].direction;
    axis.normalize();
    for (const double tilt : {kMaxNormalTilt, kRefinedNormalTilt}) {
      const double maxLean = std::sin(radians(tilt));
      Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
      for (std::size_t k = bestFirst; k < bestFirst + bestCount; ++k) {
        const Eigen::Vector3d normal = input_.cloud.normals[votes[k].point].cast<double>();
        if (std::fabs(normal.dot(axis)) <= maxLean) scatter += normal * normal.transpose();
      }
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);
      if (solver.eigenvalues()(1) < kMinNormalSpread * solver.eigenvalues()(2)) break;
      const Eigen::Vector3d squareToNormals = solver.eigenvectors().col(0);
      axis = squareToNormals.dot(axis) >= 0.0 ? squareToNormals : Eigen::Vector3d(-squareToNormals);
    }
    return axis;
  }

  /// How the normals of `points` turn around the pipe (`x` × `y` is its axis): the share of them
  /// within ±5° of each direction across it (unoriented, so over 180°, one bin per degree).
  std::array<double, 180> normalWindows(const std::vector<std::uint32_t>& points, const Eigen::Vector3d& x,
                                        const Eigen::Vector3d& y) const {
    constexpr int kDegrees = 180;
    constexpr int kHalfWindow = 5;
    std::array<int, kDegrees> histogram{};
    for (std::uint32_t i : points) {
      const Eigen::Vector3d normal = input_.cloud.normals[i].cast<double>();
      double angle = std::atan2(normal.dot(y), normal.dot(x));
      if (angle < 0.0) angle += kPi;
      ++histogram[static_cast<std::size_t>(std::min(kDegrees - 1, static_cast<int>(angle / kPi * kDegrees)))];
    }
    std::array<double, kDegrees> windows{};
    for (int k = 0; k < kDegrees; ++k) {
      int window = 0;
      for (int j = -kHalfWindow; j <= kHalfWindow; ++j) {
        window += histogram[static_cast<std::size_t>((k + j + kDegrees) % kDegrees)];
      }
      windows[static_cast<std::size_t>(k)] = static_cast<double>(window) / static_cast<double>(points.size());
    }
    return windows;
  }

  /// The largest share of the points whose normals point within 5° of one direction: a pipe's
  /// normals turn with the surface, a flat face's (a post, a box side) stay put.
  static double flatShare(const std::array<double, 180>& windows) {
    return *std::max_element(windows.begin(), windows.end());
  }

  /// Whether the normals gather on two directions at right angles, as on two faces of a square post
  /// or a box seen across its edge (a pipe's normals spread over the arc the scanner sees).
  static bool squareEdge(const std::array<double, 180>& windows) {
    const auto most = std::max_element(windows.begin(), windows.end());
    const int first = static_cast<int>(most - windows.begin());
    double second = 0.0;
    for (int offset = 90 - kSquareToleranceDeg; offset <= 90 + kSquareToleranceDeg; ++offset) {
      second = std::max(second, windows[static_cast<std::size_t>((first + offset) % 180)]);
    }
    return second >= kMinFaceShare && *most + second >= kMinSquareShare;
  }

  /// RMS distance of `points`, seen along the pipe (`x` × `y` is its axis), from the straight line
  /// that fits them best across the pipe.
  double lineRms(const std::vector<std::uint32_t>& points, const Eigen::Vector3d& origin, const Eigen::Vector3d& x,
                 const Eigen::Vector3d& y) const {
    LineFitSums sums;
    for (std::uint32_t i : points) {
      const Eigen::Vector3d d = input_.cloud.positions[i].cast<double>() - origin;
      sums.add(Eigen::Vector2d(d.dot(x), d.dot(y)));
    }
    return std::sqrt(sums.squaresOffLine() / std::max(1.0, sums.count));
  }

  /// RMS distance of `points`, seen along the pipe (`x` × `y` is its axis), from the two straight
  /// lines that fit them best, one on each side of a split in their order around the axis: the two
  /// faces of a post seen across its edge. (The points may span the whole circle: the order starts
  /// past the widest empty arc.)
  double twoLineRms(const std::vector<std::uint32_t>& points, const Eigen::Vector3d& origin, const Eigen::Vector3d& x,
                    const Eigen::Vector3d& y) const {
    constexpr std::size_t kMinSide = 3;
    if (points.size() < 2 * kMinSide) return std::numeric_limits<double>::infinity();
    std::vector<std::pair<double, Eigen::Vector2d>> around;
    for (std::uint32_t i : points) {
      const Eigen::Vector3d d = input_.cloud.positions[i].cast<double>() - origin;
      const Eigen::Vector2d q(d.dot(x), d.dot(y));
      around.emplace_back(std::atan2(q.y(), q.x()), q);
    }
    std::sort(around.begin(), around.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    // The widest empty arc, and the widest of the others: two lines pass through any few scan
    // columns of a thin pipe seen from afar, whatever its shape, so only points that fill their arc
    // tell an edge from a circle.
    std::size_t widest = 0;
    double widestGap = around.front().first + 2.0 * kPi - around.back().first;
    double otherGap = 0.0;
    for (std::size_t k = 1; k < around.size(); ++k) {
      const double gap = around[k].first - around[k - 1].first;
      if (gap > widestGap) {
        otherGap = widestGap;
        widestGap = gap;
        widest = k;
      } else {
        otherGap = std::max(otherGap, gap);
      }
    }
    if (otherGap > radians(kMaxEdgeGapDeg)) return std::numeric_limits<double>::infinity();
    std::rotate(around.begin(), around.begin() + static_cast<std::ptrdiff_t>(widest), around.end());
    // Sums over the first k points: each side's line fit in constant time.
    const std::size_t n = around.size();
    std::vector<LineFitSums> sums(n + 1);
    for (std::size_t k = 0; k < n; ++k) {
      sums[k + 1] = sums[k];
      sums[k + 1].add(around[k].second);
    }
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t k = kMinSide; k + kMinSide <= n; ++k) {
      best = std::min(best, sums[k].squaresOffLine() + (sums[n] - sums[k]).squaresOffLine());
    }
    return std::sqrt(best / static_cast<double>(n));
  }

  /// How far along `along` from `origin` the farthest of `points` lies.
  double farthestAlong(const std::vector<std::uint32_t>& points, const Eigen::Vector3d& origin,
                       const Eigen::Vector3d& along) const {
    double farthest = 0.0;
    for (std::uint32_t i : points) {
      farthest = std::max(farthest, (input_.cloud.positions[i].cast<double>() - origin).dot(along));
    }
    return farthest;
  }

  /// How points lie off the circle of radius r around the axis through `origin` along `along`.
  struct RadialOffsets {
    std::size_t count = 0;
    double mean = 0.0;
    double spread = 0.0;
    double rms = 0.0;
  };

  RadialOffsets radialOffsets(const std::vector<std::uint32_t>& points, const Eigen::Vector3d& origin,
                              const Eigen::Vector3d& along, double r) const {
    RadialOffsets offsets;
    double sum = 0.0;
    double squares = 0.0;
    for (std::uint32_t i : points) {
      const double offset = radialOffset(i, origin, along).norm() - r;
      sum += offset;
      squares += offset * offset;
    }
    offsets.count = points.size();
    const auto count = static_cast<double>(std::max<std::size_t>(1, points.size()));
    offsets.mean = sum / count;
    offsets.spread = std::sqrt(std::max(0.0, squares / count - offsets.mean * offsets.mean));
    offsets.rms = std::sqrt(squares / count);
    return offsets;
  }

  /// Out-of-roundness (see SectorOffsets) of `points` around the circle of radius r about the axis
  /// through `origin` along `along` (`across` × `aside` = `along`).
  double outOfRoundness(const std::vector<std::uint32_t>& points, const Eigen::Vector3d& origin,
                        const Eigen::Vector3d& along, const Eigen::Vector3d& across, const Eigen::Vector3d& aside,
                        double r) const {
    SectorOffsets sectors;
    for (std::uint32_t i : points) {
      const Eigen::Vector3d radial = radialOffset(i, origin, along);
      sectors.add(std::atan2(radial.dot(aside), radial.dot(across)), radial.norm() - r);
    }
    return sectors.outOfRoundness(kMinSectorPoints);
  }

  /// The offset of point i from the axis through `origin` along `along`, square to the axis.
  Eigen::Vector3d radialOffset(std::uint32_t i, const Eigen::Vector3d& origin, const Eigen::Vector3d& along) const {
    const Eigen::Vector3d d = input_.cloud.positions[i].cast<double>() - origin;
    return d - d.dot(along) * along;
  }

  /// How many of an arc's sections, from its start, a run of covered ones spans: beginning in one of
  /// the first two (the first may lie in the end's band) and ending at its last covered section before
  /// a gap of two; none when it begins later.
  static std::size_t sectionsSeenFromStart(const std::vector<char>& covered) {
    std::size_t first = 0;
    while (first < covered.size() && !covered[first]) ++first;
    if (first > 1 || first == covered.size()) return 0;
    std::size_t last = first;
    for (std::size_t k = first + 1; k < covered.size() && k <= last + 2; ++k) {
      if (covered[k]) last = k;
    }
    return last + 1;
  }

  /// Whether points sit on the radius: their mean offset within what their spread and number leave
  /// unsure, and at least a small share of the radius.
  static bool onRadius(const RadialOffsets& offsets, double r) {
    const double tolerance =
        std::max({kMinRadiusTolerance, kRadiusToleranceRadii * r,
                  2.5 * offsets.spread / std::sqrt(static_cast<double>(std::max<std::size_t>(1, offsets.count)))});
    return std::fabs(offsets.mean) <= tolerance;
  }

  /// The completion of `end` along `along`: from its bend (see legBeyondBend) when completing from
  /// bends, else a straight leg from points whose normals agree with its surface, and failing that
  /// from points whose normals are square to its axis as well (see straightBeyond). `networks`:
  /// `along` is one of the network's directions (not one the points near the end voted for).
  std::optional<Completion> completeAlong(const PipeEnd& end, const Eigen::Vector3d& along, bool networks,
                                          const std::vector<std::uint32_t>& nearby) const {
    const double cosine = end.outward.dot(along);
    const double bend = std::acos(std::clamp(cosine, -1.0, 1.0));
    if (bend < radians(params_.minCompletionBendDeg) || bend > radians(params_.maxElbowAngleDeg)) return std::nullopt;
    if (fromBends_) return legBeyondBend(end, along, bend, networks, nearby);
    auto completion = straightBeyond(end, along, nearby, false);
    if (!completion) completion = straightBeyond(end, along, nearby, true);
    return completion;
  }

  /// The straight leg of completeAlong. On a sparse thin pipe a point's neighbourhood runs along the
  /// pipe, so its normal is square to the axis but may point anywhere around it: with
  /// `squareNormals`, such points vote for the corner and count on the surface as well, and the leg
  /// must then sit on its circle as closely as the scan's pipes do (see completeAt).
  std::optional<Completion> straightBeyond(const PipeEnd& end, const Eigen::Vector3d& along,
                                           const std::vector<std::uint32_t>& nearby, bool squareNormals) const {
    const double cosine = end.outward.dot(along);
    const double bend = std::acos(std::clamp(cosine, -1.0, 1.0));
    const double sine = std::sin(bend);
    // In the plane across `along`: `across` points from the end's line towards the corners, `aside`
    // is the bend plane's normal. The new pipe's axis passes at (t sin θ, 0) for a corner t past the end.
    const Eigen::Vector3d across = (end.outward - cosine * along) / sine;
    const Eigen::Vector3d aside = along.cross(across);
    const double r = end.radius;
    const double band = params_.supportDistance;
    // The straight begins past the shortest elbow's tangent point.
    const double firstAlong = params_.minBendRadii * r * std::tan(0.5 * bend);
    const double lastAlong = firstAlong + params_.maxCompletionLength;
    const double minCorner = -std::max(cornerBehindEnd(r, bend), overshoot(end, bend));
    const double maxCorner = builder_.searchDistance(r);

    // Each point votes for the corners that put it on the surface: (α − t sin θ)² + c² = r².
    VoteHistogram histogram(minCorner, maxCorner, 0.5 * band / sine);
    for (std::uint32_t i : nearby) {
      const Eigen::Vector3d w = input_.cloud.positions[i].cast<double>() - end.point;
      const double alpha = w.dot(across);
      const double c = w.dot(aside);
      if (std::fabs(c) >= r) continue;
      const double half = std::sqrt(r * r - c * c);
      for (const double root : {alpha - half, alpha + half}) {
        const double corner = root / sine;
        const double distanceAlong = w.dot(along) - corner * cosine;
        if (corner < minCorner || corner > maxCorner || distanceAlong < firstAlong || distanceAlong > lastAlong) {
          continue;
        }
        const Eigen::Vector3d radial = (alpha - root) * across + c * aside;
        if (normalAgrees(input_.cloud, i, radial / r, kCompletionNormalAngleDeg) || (squareNormals && squareTo(i, along))) {
          histogram.vote(corner);
        }
      }
    }
    // A column down the leg's front fits both roots with its normal, so it votes for a mirror corner
    // 2r from the true one as much as for that; other surfaces nearby, and the elbow short of its
    // tangent point, vote as well. The most voted corner may leave the leg's points inside the
    // tube: the best-supported completion from the highest few peaks wins.
    Straight straight = completionStraight();
    straight.along = along;
    straight.across = across;
    straight.aside = aside;
    straight.radius = r;
    straight.firstAlong = firstAlong;
    // The scan's noise, as its pipes' fits show it: a post taken for a pipe fits worse.
    if (squareNormals) straight.noise = std::min(scanNoise_, input_.pipes[static_cast<std::size_t>(end.pipe)].rms);
    // Up to a short-radius elbow's tangent point (R = 2r, the tightest fitting) the bend may still
    // run, its torus inside the tube's start and outside it: no clutter is counted there.
    straight.clutterFrom = kShortElbowRadii * r * sine / (1.0 + cosine);
    // Behind the corner, past where the end's own pipe meets the surface.
    straight.behindStart = r + 2.0 * r * std::max(0.0, cosine) / sine + 2.0 * band;
    std::optional<Completion> best;
    for (const double cornerDistance : histogram.peaks(kCornerPeaks)) {
      straight.corner = end.point + cornerDistance * end.outward;
      auto candidate = completeAt(straight, nearby);
      if (candidate && (!best || candidate->inliers.size() > best->pipe.inliers.size())) {
        best = Completion{end, -1, std::move(*candidate)};
      }
    }
    return best;
  }

  /// The leg beyond an elbow whose bend was seen but not the leg, or too little of it for
  /// completeAt (hidden past the bend, or shorter than the elbow). Bending from the end's axis
  /// towards `along` by `bend`, the torus has two unknowns, its major radius R and where along the
  /// end's extension it starts: for each R, every point votes for the starts that put it on the
  /// torus with its normal radial (the paper's R vote, with one pipe in place of two). The most
  /// voted torus must be covered along its arc as a completion is along its axis, also past where
  /// it has left the pipe's line by a radius (before, a floor or flange by the end fills it), where
  /// it and the leg beyond hold half a completion's points (a bend that thins out as it turns away
  /// from the scanner shows the turn in the leg's few points), and hold little clutter; the end's
  /// pipe must not carry on straight past where the bend leaves it (a gap, or a bend that was not).
  /// Or, along one of the network's directions (`networks`), the torus may be seen from its start
  /// only, turning far enough there to show its radius, densely enough to be the end's bend: its
  /// elbow is then as sure as the share of its turn seen. The leg runs from the corner over the
  /// sections its points cover past the tangent point, and at least a diameter (a fragment takes no
  /// joint); it must hold too few points for completeAt (which tried it), run into no other pipe,
  /// and take the elbow as every completion does.
  std::optional<Completion> legBeyondBend(const PipeEnd& end, const Eigen::Vector3d& along, double bend,
                                          bool networks, const std::vector<std::uint32_t>& nearby) const {
    const double r = end.radius;
    // A thin tube's support band is narrower than the joints': their default 1 cm is half a 21 mm
    // tube's radius, and a face or post a few centimetres past its end would hold a bend along it.
    const double band = std::min(params_.supportDistance, kBendBandRadii * r);
    const Eigen::Vector3d& outward = end.outward;
    // The bend plane: x along the end's extension, y towards the leg, z across.
    const Eigen::Vector3d toward = (along - std::cos(bend) * outward) / std::sin(bend);
    const Eigen::Vector3d normal = outward.cross(toward);
    // Seen from one pipe only, a bend tighter than a short-radius elbow is a pipe's end against
    // something (a floor, a post).
    const double minBend = std::max(params_.minBendRadii, kMinOneSidedBendRadii) * r;
    const double radiusStep = std::max(kMinBendRadiusStep, kBendRadiusStepRadii * r);
    const auto radii = static_cast<std::size_t>(std::floor((params_.maxBendRadii * r - minBend) / radiusStep)) + 1;
    const double minStart = -cornerBehindEnd(r, bend);
    // Every point a torus's support can count lies within a tube's radius and the band of the bend
    // plane, on the leg's side of the end's line and past the earliest start: with fewer such
    // points than a completion needs, no torus is supported (and none is voted for).
    const double tube = r + band;
    const auto possible = std::count_if(nearby.begin(), nearby.end(), [&](std::uint32_t i) {
      const Eigen::Vector3d w = input_.cloud.positions[i].cast<double>() - end.point;
      return std::fabs(w.dot(normal)) <= tube && w.dot(toward) >= -tube && w.dot(outward) >= minStart - tube;
    });
    if (static_cast<std::size_t>(possible) < params_.minCompletionPoints) return std::nullopt;
    const double startStep = 0.5 * band;
    const auto starts = static_cast<std::size_t>(std::ceil((builder_.searchDistance(r) - minStart) / startStep)) + 1;

    // On the torus of radius R starting `start` past the end: the point at w (from the end) lies
    // at angle `turned` along the arc, `radial` off the tube's centre line.
    struct OnBend {
      double turned;
      Eigen::Vector3d radial;
    };
    const auto onBend = [&](const Eigen::Vector3d& w, double R, double start) -> std::optional<OnBend> {
      const double x = w.dot(outward) - start;
      const double y = w.dot(toward) - R;
      const double distance = std::hypot(x, y);
      if (distance < 1e-12) return std::nullopt;
      const double turned = std::atan2(x, -y);
      if (turned < 0.0 || turned > bend) return std::nullopt;
      const Eigen::Vector3d tubeCenter = (start + R * x / distance) * outward + (R + R * y / distance) * toward;
      return OnBend{turned, w - tubeCenter};
    };
    const auto radialNormal = [&](std::uint32_t i, const Eigen::Vector3d& radial) {
      return normalAgrees(input_.cloud, i, radial / std::max(radial.norm(), 1e-12), kCompletionNormalAngleDeg);
    };

    // Votes over (R, start): the centre circle at distance R ± the tube's half-chord from the
    // point in the bend plane puts the start at x ∓ the half-chord along the extension.
    std::vector<double> votes(radii * starts, 0.0);
    struct Vote {
      std::size_t cell;
      double R;
      double start;
    };
    std::vector<Vote> cast;
    for (std::uint32_t i : nearby) {
      const Eigen::Vector3d w = input_.cloud.positions[i].cast<double>() - end.point;
      const double z = w.dot(normal);
      if (std::fabs(z) >= r) continue;
      const double x = w.dot(outward);
      const double y = w.dot(toward);
      const double halfTube = std::sqrt(r * r - z * z);
      for (std::size_t k = 0; k < radii; ++k) {
        const double R = minBend + static_cast<double>(k) * radiusStep;
        for (const double side : {halfTube, -halfTube}) {
          const double fromCenter = R + side;
          const double squared = fromCenter * fromCenter - (y - R) * (y - R);
          if (squared < 0.0) continue;
          for (const double offset : {std::sqrt(squared), -std::sqrt(squared)}) {
            const double start = x - offset;
            if (start < minStart) continue;
            const auto bin = static_cast<std::size_t>((start - minStart) / startStep + 0.5);
            if (bin >= starts) continue;
            const auto point = onBend(w, R, start);
            if (!point || !radialNormal(i, point->radial)) continue;
            votes[k * starts + bin] += 1.0;
            cast.push_back(Vote{k * starts + bin, R, start});
          }
        }
      }
    }
    if (cast.empty()) return std::nullopt;
    // The peak of the votes summed over 3 × 3 cells, refined to the mean of its votes.
    const auto windowOf = [&](std::size_t cell) {
      const std::size_t k = cell / starts;
      const std::size_t bin = cell % starts;
      return std::make_pair(std::make_pair(k == 0 ? 0 : k - 1, std::min(radii - 1, k + 1)),
                            std::make_pair(bin == 0 ? 0 : bin - 1, std::min(starts - 1, bin + 1)));
    };
    std::size_t peak = 0;
    double most = 0.0;
    for (std::size_t cell = 0; cell < votes.size(); ++cell) {
      if (votes[cell] == 0.0) continue;
      const auto [kRange, binRange] = windowOf(cell);
      double sum = 0.0;
      for (std::size_t k = kRange.first; k <= kRange.second; ++k) {
        for (std::size_t bin = binRange.first; bin <= binRange.second; ++bin) sum += votes[k * starts + bin];
      }
      if (sum > most) {
        most = sum;
        peak = cell;
      }
    }
    const auto [kRange, binRange] = windowOf(peak);
    double sumR = 0.0;
    double sumStart = 0.0;
    double count = 0.0;
    for (const Vote& vote : cast) {
      const std::size_t k = vote.cell / starts;
      const std::size_t bin = vote.cell % starts;
      if (k < kRange.first || k > kRange.second || bin < binRange.first || bin > binRange.second) continue;
      sumR += vote.R;
      sumStart += vote.start;
      count += 1.0;
    }
    const double R = sumR / count;
    const double start = sumStart / count;

    // The torus's support along its arc, and the clutter in and around its tube.
    const double arcLength = R * bend;
    const auto arcSections = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(arcLength / kSectionLength)));
    std::vector<char> arcCovered(arcSections, 0);
    std::vector<double> farthestTurn(arcSections, 0.0);  // In each section, by the points on it.
    std::size_t support = 0;
    std::size_t clutter = 0;
    // Where the bend's centre line has left the end's axis by a radius: from there on its points
    // are none of a straight pipe's carrying on.
    // (R is at least minBend, above 1.8 r, so both angles exist.)
    const double departed = std::acos(1.0 - r / R);
    std::size_t departedSupport = 0;
    // The end's straight extension past where the bend has left it by a diameter.
    const double leaves = start + R * std::sin(std::min(bend, std::acos(1.0 - 2.0 * r / R)));
    std::array<char, kBehindSections> straightOn{};
    const Eigen::Vector3d corner = end.point + (start + R * std::tan(0.5 * bend)) * outward;
    const Eigen::Vector3d tangentB = corner + R * std::tan(0.5 * bend) * along;
    for (std::uint32_t i : nearby) {
      const Eigen::Vector3d w = input_.cloud.positions[i].cast<double>() - end.point;
      if (const auto point = onBend(w, R, start)) {
        const double distance = point->radial.norm();
        if (std::fabs(distance - r) <= band && radialNormal(i, point->radial)) {
          ++support;
          const auto section = std::min(arcSections - 1, static_cast<std::size_t>(point->turned * R / kSectionLength));
          arcCovered[section] = 1;
          farthestTurn[section] = std::max(farthestTurn[section], point->turned);
          if (point->turned >= departed) ++departedSupport;
          continue;
        }
        if (isClutter(distance, r, band, /*unexplained=*/true)) ++clutter;
      }
      const double x = w.dot(outward);
      const double pastLeaving = x - leaves;
      if (pastLeaving < 0.0 || pastLeaving >= kBehindSections * kSectionLength) continue;
      const Eigen::Vector3d radial = w - x * outward;
      const Eigen::Vector3d fromLeg = input_.cloud.positions[i].cast<double>() - tangentB;
      const bool onLeg = fromLeg.dot(along) >= 0.0 && (fromLeg - fromLeg.dot(along) * along).norm() <= r + 2.0 * band;
      if (!onLeg && std::fabs(radial.norm() - r) <= band && radialNormal(i, radial)) {
        straightOn[static_cast<std::size_t>(pastLeaving / kSectionLength)] = 1;
      }
    }
    const auto covered = static_cast<std::size_t>(std::count(arcCovered.begin(), arcCovered.end(), 1));
    const auto departedFrom = std::min(arcSections - 1, static_cast<std::size_t>(departed * R / kSectionLength));
    const auto departedCovered = static_cast<std::size_t>(
        std::count(arcCovered.begin() + static_cast<std::ptrdiff_t>(departedFrom), arcCovered.end(), 1));
    const auto atLeastShare = [&](std::size_t part, std::size_t whole) {
      return static_cast<double>(part) >= params_.minCompletionCoverage * static_cast<double>(whole);
    };
    const bool clear = static_cast<double>(clutter) <= kMaxClutterShare * static_cast<double>(support);
    // The bend lies next to the end the scan saw: seen far more thinly than that end, its points are
    // something else's (a mug's rim, a thinner neighbour's end).
    const PipeSegment& own = input_.pipes[static_cast<std::size_t>(end.pipe)];
    const double endStretch = std::min(kEndDensityLength, (own.end - own.start).norm());
    const auto endPoints = std::count_if(own.inliers.begin(), own.inliers.end(), [&](std::uint32_t i) {
      const double behind = (end.point - input_.cloud.positions[i].cast<double>()).dot(outward);
      return behind >= 0.0 && behind < endStretch;
    });
    const double endDensity = static_cast<double>(endPoints) / endStretch;
    const bool seenAsTheEnd = static_cast<double>(support) / arcLength >= kMinBendDensityShare * endDensity;
    // Covered along its arc; or seen from its start only, turning far enough there to show its radius
    // (the rest hidden, as where it turns behind the pipe it leaves): its elbow is then as sure as
    // the share of its turn seen (see adoptCompletions), and need not be seen leaving the pipe's line
    // (below). How far such a bend turns on only the network's directions say: a direction the
    // points near the end voted for follows the part seen.
    const bool wholeBend = support >= params_.minCompletionPoints && atLeastShare(covered, arcSections);
    const std::size_t seenSections = sectionsSeenFromStart(arcCovered);
    const double seenLength = static_cast<double>(seenSections) * kSectionLength;
    const double seenTurn = seenSections > 0 ? farthestTurn[seenSections - 1] : 0.0;
    const auto coveredSeen = static_cast<std::size_t>(
        std::count(arcCovered.begin(), arcCovered.begin() + static_cast<std::ptrdiff_t>(seenSections), 1));
    const bool turnSeen =
        networks && seenTurn >= radians(kMinSeenTurnDeg) && coveredSeen >= kMinSeenSections &&
        support >= 2 * params_.minCompletionPoints &&
        static_cast<double>(support) / seenLength >= kMinSeenDensityShare * endDensity;
    const bool carriesOn =
        atLeastShare(static_cast<std::size_t>(std::count(straightOn.begin(), straightOn.end(), 1)), kBehindSections);
    if (!(wholeBend || turnSeen) || !clear || carriesOn || !seenAsTheEnd) return std::nullopt;

    // The leg: the sections its points cover from the tangent point on, at least a diameter.
    const auto sections =
        std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(params_.maxCompletionLength / kSectionLength)));
    std::vector<std::vector<std::uint32_t>> bySection(sections);
    for (std::uint32_t i : nearby) {
      const Eigen::Vector3d d = input_.cloud.positions[i].cast<double>() - tangentB;
      const double distanceAlong = d.dot(along);
      if (distanceAlong < 0.0 || distanceAlong >= static_cast<double>(sections) * kSectionLength) continue;
      const Eigen::Vector3d radial = d - distanceAlong * along;
      if (std::fabs(radial.norm() - r) <= band && radialNormal(i, radial)) {
        bySection[static_cast<std::size_t>(distanceAlong / kSectionLength)].push_back(i);
      }
    }
    // A leg with enough points to be tested was, by completeAlong, and failed: a post the end met,
    // or a face, whose edge the bend followed. Unless they all lie in its first section: a straight
    // leg stopping there keeps less than a section past the bend's tangent point, and goes.
    std::size_t legPoints = 0;
    for (const auto& points : bySection) legPoints += points.size();
    if (legPoints - bySection.front().size() >= params_.minCompletionPoints) return std::nullopt;
    // The bend leaves the end's line: points past where it has left by a radius, on the arc or on
    // the leg beyond it, and the arc covered there.
    const bool leavesThePipe = departed < bend && 2 * (departedSupport + legPoints) >= params_.minCompletionPoints &&
                               atLeastShare(departedCovered, arcSections - departedFrom);
    if (!leavesThePipe && !turnSeen) return std::nullopt;
    const auto occupied = [&](std::size_t k) { return !bySection[k].empty(); };
    std::size_t first = 0;
    while (first < sections && !occupied(first)) ++first;
    const auto shortest =
        static_cast<std::size_t>(std::floor(2.0 * r * params_.minPipeDiameters / kSectionLength)) + 1;
    std::size_t last = shortest - 1;
    if (first < static_cast<std::size_t>(kMaxLeadSections)) {
      last = std::max(last, runEnd(first, sections, static_cast<std::size_t>(kMaxGapSections), occupied));
    }
    Completion completion{end, -1, PipeSegment{}};
    PipeSegment& leg = completion.pipe;
    std::size_t legCovered = 0;
    for (std::size_t k = 0; k <= last && k < sections; ++k) {
      legCovered += occupied(k) ? 1 : 0;
      leg.inliers.insert(leg.inliers.end(), bySection[k].begin(), bySection[k].end());
    }
    std::sort(leg.inliers.begin(), leg.inliers.end());
    leg.start = corner;
    leg.end = tangentB + static_cast<double>(last + 1) * kSectionLength * along;
    leg.radius = r;
    leg.rms = radialOffsets(leg.inliers, tangentB, along, r).rms;
    leg.confidence = static_cast<double>(legCovered) / static_cast<double>(last + 1);
    // Little or nothing was seen on the leg: where it runs into another pipe, the bend was that pipe's.
    if (cutsAnotherPipe(leg, {end.pipe}, input_.pipes, params_)) return std::nullopt;
    completion.bendSupport = support;
    if (!wholeBend || !leavesThePipe) completion.bendSeenShare = seenTurn / bend;
    return completion;
  }

  /// The corner (along `outward` from `origin`) of a leg along `along` (`aside` = `along` × `outward`)
  /// that minimises the squared distances from its surface of the points within the support band,
  /// with their normals near radial, from `firstAlong` to `lastAlong` along it (Gauss–Newton from
  /// `corner`), moved by at most `maxShift`.
  double refinedCorner(const Eigen::Vector3d& origin, const Eigen::Vector3d& outward, const Eigen::Vector3d& along,
                       const Eigen::Vector3d& aside, double r, double firstAlong, double lastAlong, double corner,
                       double maxShift, const std::vector<std::uint32_t>& nearby) const {
    const double start = corner;
    for (int step = 0; step < kCornerRefinements; ++step) {
      double normal = 0.0;
      double gradient = 0.0;
      for (std::uint32_t i : nearby) {
        const Eigen::Vector3d w = input_.cloud.positions[i].cast<double>() - origin;
        const double x = w.dot(outward) - corner;
        const double y = w.dot(aside);
        const double distance = std::hypot(x, y);
        if (std::fabs(distance - r) > params_.supportDistance || distance < 1e-9) continue;
        const double distanceAlong = w.dot(along);
        if (distanceAlong < firstAlong || distanceAlong > lastAlong) continue;
        if (!normalAgrees(input_.cloud, i, (x * outward + y * aside) / distance, kCompletionNormalAngleDeg)) continue;
        const double jacobian = -x / distance;
        normal += jacobian * jacobian;
        gradient += jacobian * (distance - r);
      }
      if (normal <= 1e-12) break;
      corner = std::clamp(corner - gradient / normal, start - maxShift, start + maxShift);
    }
    return corner;
  }

  /// Least-squares (s, r) of a branch (see branchesOf) over the voters within the support band of
  /// its surface, from the peak's (s, r).
  void refineBranch(const std::vector<BranchVoter>& voters, double sine, double& s, double& r) const {
    for (int step = 0; step < kBranchRefinements; ++step) {
      // The band narrows to the scan noise as the fit settles: clutter at its edge pulls r out.
      const double band = (step < kBranchRefinements / 2 ? 1.0 : 0.5) * params_.supportDistance;
      Eigen::Matrix2d normal = Eigen::Matrix2d::Zero();
      Eigen::Vector2d gradient = Eigen::Vector2d::Zero();
      for (const BranchVoter& voter : voters) {
        const double dq = voter.q - s * sine;
        const double distance = std::hypot(dq, voter.h);
        const double residual = distance - r;
        if (std::fabs(residual) > band || distance < 1e-9) continue;
        const Eigen::Vector2d jacobian(-dq * sine / distance, -1.0);
        normal += jacobian * jacobian.transpose();
        gradient += jacobian * residual;
      }
      if (normal.determinant() <= 1e-12 * normal.squaredNorm()) return;
      const Eigen::Vector2d change = -normal.ldlt().solve(gradient);
      s += change(0);
      r += change(1);
    }
  }

  /// The pipe along `straight`, if the points support it (see completeAlong), with its coverage
  /// as its confidence.
  std::optional<PipeSegment> completeAt(const Straight& straight, const std::vector<std::uint32_t>& nearby) const {
    const Eigen::Vector3d& corner = straight.corner;
    const Eigen::Vector3d& along = straight.along;
    const Eigen::Vector3d& across = straight.across;
    const Eigen::Vector3d& aside = straight.aside;
    const double r = straight.radius;
    const double band = params_.supportDistance;
    const double firstAlong = straight.firstAlong;
    const double lastAlong = firstAlong + straight.length;

    // Sections along the new pipe holding a point on its surface.
    const auto sections =
        std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(straight.length / kSectionLength)));
    std::vector<std::vector<std::uint32_t>> bySection(sections);
    // Points well inside the tube or in a shell around it, per section: a wall, a box face or a
    // steel flange that grazes the surface carries on past it, a pipe leaves empty space.
    std::vector<std::size_t> clutterBySection(sections, 0);
    // Every point within the band, whatever its normal: the whole arc the scanner saw.
    std::vector<std::vector<std::uint32_t>> bandBySection(sections);
    std::vector<std::uint32_t> squareNormalPoints;  // On the surface by a normal square to the axis alone.
    // Sections behind the corner holding a point on the surface: a post the pipe ends at, or the
    // main of a tee, carries on through the corner.
    const double behindStart = straight.behindStart;
    std::array<char, kBehindSections> behind{};
    for (std::uint32_t i : nearby) {
      const Eigen::Vector3d d = input_.cloud.positions[i].cast<double>() - corner;
      const double distanceAlong = d.dot(along);
      const double pastBehindStart = -distanceAlong - behindStart;
      const bool isBehind = pastBehindStart >= 0.0 && pastBehindStart < kBehindSections * kSectionLength;
      if (!isBehind && (distanceAlong < firstAlong || distanceAlong >= lastAlong)) continue;
      const Eigen::Vector3d radial = d - distanceAlong * along;
      const double distance = radial.norm();
      const bool withinBand = std::fabs(distance - r) <= band;
      const bool radialNormal =
          withinBand && normalAgrees(input_.cloud, i, radial / std::max(distance, 1e-12), kCompletionNormalAngleDeg);
      const bool squareNormal = withinBand && !radialNormal && straight.noise > 0.0 && squareTo(i, along);
      const bool onSurface = radialNormal || squareNormal;
      if (isBehind) {
        if (onSurface) behind[static_cast<std::size_t>(pastBehindStart / kSectionLength)] = 1;
        continue;
      }
      // A face across the axis (a flange, a nozzle's plate, equipment the pipe runs into) is where
      // the pipe ends, not something beside it.
      if (!input_.cloud.normals.empty() && normalAgrees(input_.cloud, i, along, kFaceNormalAngleDeg)) continue;
      const auto section =
          std::min(sections - 1, static_cast<std::size_t>((distanceAlong - firstAlong) / kSectionLength));
      if (isClutter(distance, r, band, /*unexplained=*/true) && distanceAlong >= straight.clutterFrom) {
        ++clutterBySection[section];
      }
      if (withinBand) bandBySection[section].push_back(i);
      if (onSurface) bySection[section].push_back(i);
      if (squareNormal) squareNormalPoints.push_back(i);
    }
    std::sort(squareNormalPoints.begin(), squareNormalPoints.end());
    const auto occupied = [&](std::size_t k) { return !bySection[k].empty(); };
    std::size_t first = 0;
    while (first < sections && !occupied(first)) ++first;
    if (first == sections) return std::nullopt;
    const auto maxGap = static_cast<std::size_t>(kMaxGapSections);
    std::size_t last = sections - 1;
    if (!straight.between) {
      last = runEnd(first, sections, maxGap, occupied);
      // The straight starts next to the elbow, or past an occlusion no longer than the run beyond
      // it. An occlusion between runs is bridged in the same way (as the extents do).
      const bool nextToElbow = first < static_cast<std::size_t>(kMaxLeadSections);
      if (!nextToElbow && (first > kMaxBridgeSections || last - first + 1 < first)) return std::nullopt;
      last = bridgedEnd(last, sections, maxGap, kMaxBridgeSections, occupied);
    }
    std::size_t covered = 0;
    std::size_t clutter = 0;
    PipeSegment pipe;
    std::vector<std::uint32_t> inBand;
    for (std::size_t k = 0; k <= last; ++k) {
      covered += bySection[k].empty() ? 0 : 1;
      clutter += clutterBySection[k];
      pipe.inliers.insert(pipe.inliers.end(), bySection[k].begin(), bySection[k].end());
      inBand.insert(inBand.end(), bandBySection[k].begin(), bandBySection[k].end());
    }
    const double coverage = static_cast<double>(covered) / static_cast<double>(last + 1);
    const double length = firstAlong + static_cast<double>(last + 1) * kSectionLength;
    const auto behindCovered = std::count(behind.begin(), behind.end(), 1);
    if (static_cast<double>(behindCovered) >= params_.minCompletionCoverage * kBehindSections) return std::nullopt;
    if (pipe.inliers.size() < straight.minPoints || coverage < straight.minCoverage ||
        static_cast<double>(clutter) > kMaxClutterShare * static_cast<double>(pipe.inliers.size()) ||
        length - firstAlong < 2.0 * r * params_.minPipeDiameters) {
      return std::nullopt;
    }
    std::sort(pipe.inliers.begin(), pipe.inliers.end());
    // Points by a removed plane (a floor's seam the plane removal left) run along that plane: a
    // leg over them mostly is the plane's.
    const auto byPlane = std::count_if(pipe.inliers.begin(), pipe.inliers.end(),
                                       [&](std::uint32_t i) { return planes_.by(input_.cloud.positions[i].cast<double>()); });
    if (static_cast<double>(byPlane) > kMaxByPlaneShare * static_cast<double>(pipe.inliers.size())) return std::nullopt;
    const RadialOffsets onSurface = radialOffsets(pipe.inliers, corner, along, r);
    const RadialOffsets overBand = radialOffsets(inBand, corner, along, r);
    // The points must sit on the radius of the pipe being continued, not merely within the band: a
    // square post or a flange face next to a pipe end fits the band but not the radius. So must all
    // the points in the band: on thin pipes the normals face the scanner, so those that agree with
    // the surface are the rays down its front, which the face of a post matches as well.
    if (!onRadius(onSurface, r) || !onRadius(overBand, r)) return std::nullopt;
    // ...and around it: a square post's faces sit inside the circle and its corners outside.
    const double outOfRound = outOfRoundness(pipe.inliers, corner, along, across, aside, r);
    if (outOfRound > std::max(kMinOutOfRound, kMaxOutOfRoundRadii * r)) return std::nullopt;
    // A leg taken largely for normals square to its axis (a sparse thin pipe's, whose neighbourhoods
    // run along it) must sit on its circle as closely as the scan's pipes do: a post's faces give
    // such normals too, and sit off the circle. On a scan noisier than a post's faces are off the
    // circle, nothing tells them apart: the cap refuses such legs.
    if (std::count_if(pipe.inliers.begin(), pipe.inliers.end(), [&](std::uint32_t i) {
          return std::binary_search(squareNormalPoints.begin(), squareNormalPoints.end(), i);
        }) > kMaxSquareNormalShare * static_cast<double>(pipe.inliers.size()) &&
        (overBand.rms > std::min(kSquareNormalNoiseFactor * straight.noise, kMaxSquareNormalBandRms) ||
         outOfRound > kMaxSquareNormalOutOfRound)) {
      return std::nullopt;
    }
    // A flat face: normals that keep one direction and points in the band that lie on a line across
    // the pipe at least as well as on its circle. (Normals alone are not enough: on thin, sparse
    // pipes they point at the scanner. The points whose normals agree are not enough either: they
    // are the front of the arc, flat on any thin pipe.)
    const bool hasNormals = !input_.cloud.normals.empty();
    const std::array<double, 180> windows =
        hasNormals ? normalWindows(pipe.inliers, across, aside) : std::array<double, 180>{};
    if (hasNormals && flatShare(windows) > kMaxFlatShare &&
        lineRms(inBand, corner, across, aside) < kLineToCircle * overBand.rms) {
      return std::nullopt;
    }
    if (hasNormals && squareEdge(windows)) return std::nullopt;
    // Two faces seen across a post's edge, with normals that do not tell (towards a far scanner):
    // a circle of the pipe's radius fits them within the band, two lines meeting at the edge far
    // better, where they fit an arc about as well as the circle does.
    if (inBand.size() >= kMinEdgePoints &&
        twoLineRms(inBand, corner, across, aside) < kTwoLinesToCircle * overBand.rms) {
      return std::nullopt;
    }
    pipe.start = corner;
    // A leg ends where its points do, as the extents end a pipe, not on its last section's
    // boundary: up to a section on, more than two radii of a thin pipe, it would reach past the
    // corner of an elbow beyond. A leg between two ends runs to the far one's corner.
    pipe.end = corner + (straight.between ? length : farthestAlong(inBand, corner, along)) * along;
    pipe.radius = r;
    pipe.rms = onSurface.rms;
    pipe.confidence = coverage;
    return pipe;
  }

  /// Whether point i's normal is within kSquareNormalAngleDeg of square to `axis`.
  bool squareTo(std::uint32_t i, const Eigen::Vector3d& axis) const {
    return !input_.cloud.normals.empty() &&
           std::fabs(input_.cloud.normals[i].cast<double>().dot(axis)) < std::sin(radians(kSquareNormalAngleDeg));
  }

  /// The median fit RMS of `pipes` (0 when there are none).
  static double medianFitRms(const std::vector<PipeSegment>& pipes) {
    std::vector<double> rms;
    for (const PipeSegment& pipe : pipes) rms.push_back(pipe.rms);
    if (rms.empty()) return 0.0;
    std::nth_element(rms.begin(), rms.begin() + static_cast<std::ptrdiff_t>(rms.size() / 2), rms.end());
    return rms[rms.size() / 2];
  }

  const JointsInput& input_;
  const JointsParams& params_;
  const JointBuilder& builder_;
  bool fromBends_;
  double scanNoise_;
  const PlaneCells& planes_;
};

/// The pairs (e, f), e < f, of `ends` of different pipes whose points lie within reaches[e] of each
/// other, ordered by e then f (filed by position).
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

/// Completions of the ends no accepted joint took, and branches off the pipes' bodies, of the pipes
/// from `lookingFrom` on; best-supported first, a point supports one completion.
std::vector<Completion> completeFreeEnds(const JointsInput& input, const JointsParams& params,
                                         const std::vector<char>& explained, const Resolution& resolution,
                                         const PlaneCells& planes, std::size_t lookingFrom, const PointCells& cells,
                                         bool fromBends) {
  const JointBuilder builder(input, params, explained);
  const Completer completer(input, params, builder, fromBends, planes);
  // An end that only a proposed joint took is completed too: resolved again with the completion,
  // the better-supported joint takes it.
  const auto takenByAccepted = [&](int key) {
    const int h = resolution.takenBy[static_cast<std::size_t>(key)];
    return h >= 0 && resolution.hypotheses[static_cast<std::size_t>(h)].confidence >= params.acceptConfidence;
  };
  // The pipes that look for what was missed: no fragment, no piece of an elbow's arc.
  std::vector<int> mains;
  for (int p = static_cast<int>(lookingFrom); p < static_cast<int>(input.pipes.size()); ++p) {
    const auto pipe = static_cast<std::size_t>(p);
    if (!isFragment(input.pipes[pipe], params) && !resolution.arcPieces[pipe]) mains.push_back(p);
  }
  std::vector<PipeEnd> ends;
  std::vector<std::pair<Eigen::Vector3d, double>> spheres;
  for (const int p : mains) {
    for (int side = 0; side < 2; ++side) {
      if (takenByAccepted(2 * p + side)) continue;
      ends.push_back(endOf(input.pipes, p, side));
      spheres.emplace_back(ends.back().point, completer.reach(ends.back()));
    }
  }
  const auto nearby = pointsInSpheres(cells, spheres, [&](std::size_t i) { return !explained[i]; });
  const auto directions = networkDirections(input.pipes);
  std::vector<std::optional<Completion>> completed(ends.size());
  tbb::parallel_for(std::size_t{0}, ends.size(),
                    [&](std::size_t e) { completed[e] = completer.complete(ends[e], directions, nearby[e]); });
  // Legs between two ends of parallel pipes, from the pairs of ends within reach of each other.
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  if (!fromBends) {
    std::vector<double> reaches;
    for (const auto& sphere : spheres) reaches.push_back(sphere.second);
    pairs = endPairsWithin(ends, reaches);
  }
  std::vector<std::optional<Completion>> legs(pairs.size());
  tbb::parallel_for(std::size_t{0}, pairs.size(), [&](std::size_t k) {
    const auto [e, f] = pairs[k];
    legs[k] = completer.legBetween(ends[e], ends[f], nearby[e], nearby[f]);
  });

  // Branches off those pipes' bodies, from the unexplained points filed by position.
  std::vector<std::vector<Completion>> branches(mains.size());
  if (params.minBranchRadius > 0.0 && !fromBends) {
    tbb::parallel_for(std::size_t{0}, mains.size(), [&](std::size_t m) {
      const PipeSegment& main = input.pipes[static_cast<std::size_t>(mains[m])];
      const auto near = pointsNearSegment(cells, main.start, main.end, completer.branchReach(mains[m]),
                                          [&](std::size_t i) { return !explained[i]; });
      branches[m] = completer.branchesOf(mains[m], directions, near);
    });
  }

  // Ends first, then legs between ends, then branches by main, each in order: legs between ends
  // first (two pipes fix them, where one end's completion may have taken an elbow's points as
  // well), then the best-supported first.
  std::vector<Completion> found;
  for (auto& completion : completed) {
    if (completion) found.push_back(std::move(*completion));
  }
  for (auto& leg : legs) {
    if (leg) found.push_back(std::move(*leg));
  }
  for (auto& ofMain : branches) {
    for (auto& branch : ofMain) found.push_back(std::move(branch));
  }
  std::vector<std::size_t> order(found.size());
  for (std::size_t c = 0; c < found.size(); ++c) order[c] = c;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
    if (found[x].between != found[y].between) return found[x].between;
    return found[x].support() > found[y].support();
  });
  // A completion whose middle lies inside a pipe's tube is that pipe again, over points its inliers
  // left out: the end it grew from belongs with that pipe (whose joint it is, proposed or not). A
  // fragment's tube does not count: its points are the completion's to take.
  std::vector<char> used(input.cloud.size(), 0);
  std::vector<Completion> completions;
  for (std::size_t e : order) {
    if (insideAnotherPipe(found[e].pipe, input.pipes, params)) continue;
    // Nor does a completion pass through a pipe it runs beside: the points it took are that pipe's
    // and its elbow's (medium seed 13: a leg 0.3 m beside a 16 cm pipe, off that pipe's elbow).
    if (runsThroughAlongside(found[e].pipe, input.pipes, params)) continue;
    // A branch is found from votes alone, and two neighbouring branches' facing walls fit a wide one
    // between them.
    if (found[e].main >= 0 && cutsAnotherPipe(found[e].pipe, {found[e].main}, input.pipes, params)) continue;
    const auto& inliers = found[e].pipe.inliers;
    const auto shared = static_cast<std::size_t>(
        std::count_if(inliers.begin(), inliers.end(), [&](std::uint32_t i) { return used[i] != 0; }));
    // The same pipe, completed from its other side: over the same points, or (a sparse or partly
    // hidden leg, whose two completions take different points) one inside the other's tube or the
    // two ends a boundary joint could join. The elbow at the other end extends the one kept.
    const auto sameLeg = [&](const Completion& kept) {
      const std::vector<PipeSegment> pair{found[e].pipe, kept.pipe};
      if (middleInsideTube(pair[0], pair[1]) || middleInsideTube(pair[1], pair[0])) return true;
      for (int side = 0; side < 4; ++side) {
        if (builder.boundaryBetween(endOf(pair, 0, side / 2), endOf(pair, 1, side % 2))) return true;
      }
      return false;
    };
    if (2 * shared > inliers.size() || std::any_of(completions.begin(), completions.end(), sameLeg)) continue;
    for (std::uint32_t i : inliers) used[i] = 1;
    completions.push_back(std::move(found[e]));
  }
  return completions;
}

/// Completions that each take their joint: an end's completion the elbow with that end, a branch the
/// tee with its main.
struct Adoption {
  std::vector<Completion> completions;
  std::vector<PipeSegment> pipes;  // The input pipes followed by the completions...
  std::vector<char> explained;     // ...the points their inliers explain...
  Resolution resolution;           // ...and their joints.
};

/// The completions adopted among `completions` of `input.pipes`: resolved again with them, those that
/// take no joint go and the rest are resolved again, until all take theirs; nullopt when none does.
/// Pipes from `completionsFrom` on are completions already.
std::optional<Adoption> adoptCompletions(const JointsInput& input, const JointsParams& params,
                                         const std::vector<char>& explained, std::vector<Completion> completions,
                                         std::size_t completionsFrom, const PointCells& cells, Progress& progress) {
  const std::size_t pipeCount = input.pipes.size();
  while (!completions.empty()) {
    std::vector<PipeSegment> augmented = input.pipes;
    std::vector<char> augmentedExplained = explained;
    for (const Completion& completion : completions) {
      augmented.push_back(completion.pipe);
      for (std::uint32_t i : completion.pipe.inliers) augmentedExplained[i] = 1;
    }
    Resolution again =
        resolveJoints({input.cloud, augmented}, params, augmentedExplained, completionsFrom, cells, progress);
    std::vector<char> joined(completions.size(), 0);
    const auto takes = [&](const Hypothesis& hypothesis, std::size_t c) {
      const int startKey = 2 * static_cast<int>(pipeCount + c);
      if (completions[c].main >= 0) {
        return hypothesis.type == JointType::Tee && hypothesis.a.key() == startKey &&
               hypothesis.mainPipe == completions[c].main;
      }
      const int fromKey = completions[c].from.key();
      return hypothesis.type == JointType::Elbow &&
             ((hypothesis.a.key() == fromKey && hypothesis.b.key() == startKey) ||
              (hypothesis.b.key() == fromKey && hypothesis.a.key() == startKey));
    };
    for (std::size_t h : again.chosen) {
      for (std::size_t c = 0; c < completions.size(); ++c) {
        if (!takes(again.hypotheses[h], c)) continue;
        joined[c] = 1;
        // An elbow seen from its start only is as sure as the share of its turn seen.
        double& confidence = again.hypotheses[h].confidence;
        confidence = std::min(confidence, completions[c].bendSeenShare);
      }
    }
    if (std::count(joined.begin(), joined.end(), 1) == static_cast<std::ptrdiff_t>(completions.size())) {
      return Adoption{std::move(completions), std::move(augmented), std::move(augmentedExplained), std::move(again)};
    }
    std::vector<Completion> kept;
    for (std::size_t c = 0; c < completions.size(); ++c) {
      if (joined[c]) kept.push_back(std::move(completions[c]));
    }
    completions = std::move(kept);
  }
  return std::nullopt;
}

/// The ends no chosen joint took, of the pipes that take joints (no fragment, no piece of an
/// elbow's arc), in key order.
std::vector<PipeEnd> freeEnds(const std::vector<PipeSegment>& pipes, const JointsParams& params,
                              const Resolution& resolution) {
  std::vector<PipeEnd> ends;
  for (int p = 0; p < static_cast<int>(pipes.size()); ++p) {
    const auto pipe = static_cast<std::size_t>(p);
    if (isFragment(pipes[pipe], params) || resolution.arcPieces[pipe]) continue;
    for (int side = 0; side < 2; ++side) {
      if (resolution.takenBy[static_cast<std::size_t>(2 * p + side)] < 0) ends.push_back(endOf(pipes, p, side));
    }
  }
  return ends;
}

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

/// Elbows across occlusions. A corner hidden behind equipment or another pipe leaves both its
/// pipes cut short, often farther from it than the search distance, and after the completion no
/// other joint claims their ends. Two such ends look for each other up to
/// `occludedSearchDiameters`, for corners the search distance does not reach. An elbow between
/// them is chosen (the best-supported first) when the stretches it bridges to its tangent points
/// keep out of every other pipe and hold no points near their axes (whatever was seen there stands
/// where the pipe would run). Nothing was seen on those stretches, so the elbow's confidence stays
/// low: it is proposed, for review. Returns the bridged stretches.
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

/// Elbows onto pipes that run on thinly. A long pipe running away from the scanner thins out, and
/// placement and the extents keep only its denser part: its end may stop metres short of the elbow
/// where the pipe it meets is seen right up to the corner. After the hidden corners, a free end
/// whose corner with another pipe's free end lies ahead of it within the search distance, while the
/// other end faces the corner from farther (at most `maxThinStretch`), makes that elbow when the
/// stretch the other pipe would run to its tangent point was seen thinly all along: at least half
/// its 25 cm sections hold a point on its surface that no pipe explains, and at most
/// kMaxThinCorePoints points per metre lie near its axis (stray points, not something in the way);
/// it cuts no other pipe. (Its points are looked at in the preprocessed cloud, which keeps fewer of
/// them than the scan: isolated points go as outliers.) The best-supported go first, an end takes
/// one. The elbow's confidence is capped at the share of the stretch's 4 cm sections seen:
/// proposed, for review, when as thin as such stretches are. A stretch seen less than that, or not
/// at all (hidden behind a pipe running in front of it, or out of the scanner's sight), is carried
/// on as well when the two centre lines meet within kMaxHiddenSkewRadii: a pipe seen up to its
/// tangent point below another's line, which meets it that exactly, turns into it. Either way the
/// bend is voted for only up to the radius that starts it a radius back along the near pipe, seen
/// straight up to its end (other points near the corner vote for wider bends). Returns the
/// stretches carried on.
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

/// Legs between two seen bends. Two pipes may each be seen turning square off their ends, one
/// towards the other's line, while the leg between the bends holds too few points for any
/// completion (a thin or far leg, or one mostly in shadow). After the hidden corners, two ends
/// still free whose lines pass each other askew and near square, or run parallel facing past each
/// other, are joined by the lines' common perpendicular (squareLegCandidates) with an elbow at each
/// corner, when both bends are seen (their tori hold at least a fifth of the points their pipes'
/// density gives an arc, and that is at least ten points), or when the lines pass square or run
/// parallel and the pipes are alike (SquareLeg::mayBeHidden: a leg hidden whole, bends included,
/// behind something), and everything the joints bridge (the leg between its tangent points and the
/// stretches from the ends to theirs) keeps out of every other pipe and holds no points near its
/// axis. The best-supported pair of bends goes first; a leg cuts no leg chosen before it. The
/// elbows' confidence is capped at the share of the leg's sections seen: a leg that little of was
/// seen is proposed, for review. Returns the legs chosen, which follow `input.pipes` in
/// `resolution`.
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

/// Legs hidden between an end and a main. A pipe may turn square off its end into a short leg that
/// meets a thicker pipe's body at a tee, the leg seen in glimpses at most (behind the main, in a
/// station's shadow): too little for a completion. After the legs between bends, an end still free
/// is joined to another pipe, at least as thick, by a leg along one of the network's `directions`
/// square to both: where the end's line passes square to the main's axis (within
/// kSquareLegDirectionDeg), their common perpendicular, its corner within the search distance
/// ahead of the end; where the end's pipe runs beside the main, the perpendicular from where a
/// short-radius elbow's corner would be (the end seen up to its tangent point). The leg's foot lies
/// two of its radii inside the main's body, and it is long enough for an elbow and the main's
/// radius and no longer than a completion. The elbow and the tee are reconstructed as every joint
/// is; the bend must have been seen at the density of the end's pipe (as a short-radius elbow's,
/// beside the main), a section of the leg seen too, and nothing stand where they bridge (see
/// nothingInTheWay). Their confidence is capped at the share of the leg seen: proposed, for review.
/// The best-supported go first, an end takes one. Returns the legs.
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
  const GentleKinks kinks = splitAtGentleKinks(cells, pipes, networkDirections(input.pipes), params);
  const std::size_t foundCount = pipes.size();  // The input pipes and the legs found beyond gentle bends.
  const JointsInput split{input.cloud, pipes};
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
      const JointsInput current{input.cloud, pipes};
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
      static_cast<std::size_t>(std::count(absorbed.begin(), absorbed.end(), 1));
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

JointsResult connectPipes(const JointsInput& input, const JointsParams& params, Progress& progress) {
  const auto started = std::chrono::steady_clock::now();
  // A pipe that must take a joint (a weakly supported circle, few inliers) stays only when it does:
  // without those that took none the network is joined again (their points free for the others),
  // until all left do.
  std::vector<PipeSegment> pipes = input.pipes;
  const PlaneCells planes(input.planes);
  const Ground ground(input.planes, input.cloud);
  const auto pipesBefore = pipes.size();
  pipes.erase(std::remove_if(pipes.begin(), pipes.end(), [&](const PipeSegment& pipe) { return ground.under(pipe); }),
              pipes.end());
  const std::size_t inputUnderGround = pipesBefore - pipes.size();
  // Every search for points near a place reads the cloud filed once by these cells.
  const PointCells cells(input.cloud, std::max(params.minSearchDistance, 0.25));
  std::size_t dropped = 0;
  for (;;) {
    JoinedOnce joined = joinOnce({input.cloud, pipes}, planes, ground, cells, params, progress);
    if (joined.unjoined.empty()) {
      JointsResult& result = joined.result;
      result.diagnostics.unjoinedPipes = dropped;
      result.diagnostics.underGround += inputUnderGround;
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
