#pragma once
// The joints stage's hypotheses (see joints.cpp): pipe ends, joint hypotheses, and the builder that
// proposes them between ends and pipe bodies and reconstructs them with the scan's points.

#include "piperun/point_cloud.h"
#include "piperun/stages/extents.h"
#include "piperun/stages/joints.h"
#include "angles.h"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

namespace piperun::joints {

constexpr double kSectionLength = 0.04;  // Sections of a gap tested for point support (m).
// A point supports a joint's surface when its normal lies within this of the surface's (deg).
constexpr double kSupportNormalAngleDeg = 30.0;
// An elbow's torus holding at most this share of the points its pipes' density would put there
// shows no bend (see Hypothesis::bendless).
constexpr double kMaxBendlessSupport = 0.2;
// Missing points say the torus is not there only where it would hold this many: a thin pipe seen
// from afar leaves a few on an elbow, which the overshooting pipes take as their inliers.
constexpr double kMinBendlessEvidence = 10.0;
constexpr double kShortElbowRadii = 2.0;  // A short-radius elbow's bend radius, in pipe radii...
constexpr double kLongElbowRadii = 3.0;   // ...and a long-radius elbow's (1.5 diameters), the commonest fitting.

/// Whether point i's normal is within the support angle of the unit `radial` (normals are unoriented).
bool normalAgrees(const PointCloud& cloud, std::uint32_t i, const Eigen::Vector3d& radial,
                  double maxAngleDeg = kSupportNormalAngleDeg);

/// Whether `pipe` is shorter than `params.minPipeDiameters` diameters: a bit of an elbow or flange
/// fitted as a cylinder, which takes no joint.
bool isFragment(const PipeSegment& pipe, const JointsParams& params);

/// Whether the middle of `piece` lies inside the tube of one of `pipes` other than itself; a
/// fragment's tube does not count (its points are a bit of what lies around it).
bool insideAnotherPipe(const PipeSegment& piece, const std::vector<PipeSegment>& pipes, const JointsParams& params);

/// Whether the tube of `piece` cuts the tube of one of `pipes` other than those in `except` (a
/// fragment's does not count): pipes do not pass through each other.
bool cutsAnotherPipe(const PipeSegment& piece, std::initializer_list<int> except, const std::vector<PipeSegment>& pipes,
                     const JointsParams& params);

/// The directions of the network: the pipes' axes grouped within a few degrees (longest pipes
/// first, ties in input order), each group's length-weighted mean, for groups of at least half a
/// metre of pipe.
std::vector<Eigen::Vector3d> networkDirections(const std::vector<PipeSegment>& pipes);

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

/// An end of a pipe, where a joint may take it.
struct PipeEnd {
  int pipe = 0;
  int side = 0;  // 0: start, 1: end
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d outward = Eigen::Vector3d::Zero();  // Unit, pointing away from the pipe's body.
  double radius = 0.0;
  bool seenToEnd = true;  // The pipe was seen up to here (a leg drawn between two corners was not).
  int key() const { return 2 * pipe + side; }
};

/// End `side` (0: start, 1: end) of `pipes[pipe]`.
PipeEnd endOf(const std::vector<PipeSegment>& pipes, int pipe, int side);

/// The pairs (e, f), e < f, of `ends` of different pipes whose points lie within reaches[e] of each
/// other, ordered by e then f (filed by position).
std::vector<std::pair<std::size_t, std::size_t>> endPairsWithin(const std::vector<PipeEnd>& ends,
                                                                const std::vector<double>& reaches);

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
  explicit MovedEnds(const std::vector<PipeSegment>& pipes) : points_(2 * pipes.size()), moved_(2 * pipes.size(), 0) {
    for (std::size_t p = 0; p < pipes.size(); ++p) {
      points_[2 * p] = pipes[p].start;
      points_[2 * p + 1] = pipes[p].end;
    }
  }

  /// Whether `elbow` leaves both its pipes at least a section long.
  bool leaveLength(const Hypothesis& elbow) const {
    return keepsLength(elbow.a, elbow.newA) && keepsLength(elbow.b, elbow.newB);
  }
  /// Whether an elbow chosen before moved the far end of one of `elbow`'s pipes.
  bool farEndMoved(const Hypothesis& elbow) const {
    return moved_[static_cast<std::size_t>(elbow.a.key() ^ 1)] || moved_[static_cast<std::size_t>(elbow.b.key() ^ 1)];
  }
  /// The longest tangent `elbow` may have and leave both its pipes a section long.
  double maxTangent(const Hypothesis& elbow) const {
    const auto room = [&](const PipeEnd& end) {
      return (elbow.corner - points_[static_cast<std::size_t>(end.key() ^ 1)]).dot(end.outward) - kSectionLength;
    };
    return std::min(room(elbow.a), room(elbow.b));
  }
  /// Where the end `key` (2 × pipe + side) lies.
  const Eigen::Vector3d& at(int key) const { return points_[static_cast<std::size_t>(key)]; }
  void move(const Hypothesis& elbow) {
    points_[static_cast<std::size_t>(elbow.a.key())] = elbow.newA;
    points_[static_cast<std::size_t>(elbow.b.key())] = elbow.newB;
    moved_[static_cast<std::size_t>(elbow.a.key())] = moved_[static_cast<std::size_t>(elbow.b.key())] = 1;
  }

 private:
  bool keepsLength(const PipeEnd& end, const Eigen::Vector3d& moved) const {
    return (moved - points_[static_cast<std::size_t>(end.key() ^ 1)]).dot(end.outward) >= kSectionLength;
  }

  std::vector<Eigen::Vector3d> points_;
  std::vector<char> moved_;
};

/// Proposes joint hypotheses between pipe ends and pipe bodies within the limits of the parameters,
/// and reconstructs them with the scan's points (steps 1–3 of the stage, see joints.cpp).
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
  std::optional<Hypothesis> boundaryBetween(const PipeEnd& a, const PipeEnd& b) const;

  /// Hypotheses from an end and an end of another pipe (elbow or boundary joint).
  void tryEndPair(const PipeEnd& a, const PipeEnd& b, std::vector<Hypothesis>& out) const;

  /// A reducing corner: the thinner `branch`'s extension meets the line of the thicker pipe past
  /// its `mainEnd`, both hidden at the junction for no farther than the branch looks for a partner.
  /// Too unequal for an elbow, it is a tee whose main was seen on one side only, and it counts half
  /// its confidence like teeForBendlessCorner's. (A thinner cylinder fitted inside another pipe's
  /// tube meets the lines of the pipes that pipe joins in just such corners: it is no branch.)
  void tryTeeBeyondEnd(const PipeEnd& branch, const PipeEnd& mainEnd, std::vector<Hypothesis>& out) const;

  /// A T-junction hypothesis: `branch`'s extension meets the body of pipe `main`.
  void tryTee(const PipeEnd& branch, int main, std::vector<Hypothesis>& out) const {
    if (auto h = teeAt(branch, main, /*mainSeenBeyond=*/true)) out.push_back(std::move(*h));
  }

  /// The tee that replaces an elbow hypothesis with no bend (Hypothesis::bendless), at a near-square
  /// corner. Its main pipe is the one whose end reaches nearer the corner (in radii of the other);
  /// the main's far side was not seen, so the tee counts half its confidence and is proposed for
  /// review.
  std::optional<Hypothesis> teeForBendlessCorner(const Hypothesis& elbow,
                                                 const std::vector<std::uint32_t>& nearby) const;

  /// The tee where `branch`'s extension meets the axis of pipe `main`: inside its body when the
  /// main pipe is seen beyond the branch, anywhere along its line otherwise.
  std::optional<Hypothesis> teeAt(const PipeEnd& branch, int main, bool mainSeenBeyond) const;

  /// Whether another pipe, one a boundary joint could join to the nearer end of pipe `main`, covers
  /// the main's line to `along` (from the main's start along its axis) past that end.
  bool lineCarriesOn(int main, double along) const;

  /// Completes a hypothesis with its points (indices into the cloud within its reach).
  void reconstruct(Hypothesis& h, const std::vector<std::uint32_t>& nearby) const;

  /// Share of the straight piece from `from` to `to` (radius r) whose sections hold a point on its
  /// surface; collects those points.
  double straightCoverage(const Eigen::Vector3d& from, const Eigen::Vector3d& to, double r,
                          const std::vector<std::uint32_t>& nearby, std::vector<std::uint32_t>& supportPoints) const;

 private:
  Eigen::Vector3d position(std::uint32_t i) const { return input_.cloud.positions[i].cast<double>(); }

  /// Whether the pipe of `end` holds past its corner (`along` its extension, behind the end) a small
  /// share of its linear density: carried on there over scattered points, not seen running on.
  bool sparselyPast(const PipeEnd& end, double along) const;

  /// Inliers per metre of axis of a pipe: the density a joint of the same size should show.
  double linearDensity(int pipe) const;

  void reconstructElbow(Hypothesis& h, const std::vector<std::uint32_t>& nearby) const;

  void reconstructTee(Hypothesis& h, const std::vector<std::uint32_t>& nearby) const;

  void reconstructBoundary(Hypothesis& h, const std::vector<std::uint32_t>& nearby) const;

  const JointsInput& input_;
  const JointsParams& params_;
  const std::vector<char>& explained_;
};

}  // namespace piperun::joints
