// Completion of free ends: pipes the earlier stages missed (see joint_completion.h).

#include "stages/joint_completion.h"

#include "angles.h"
#include "points_near.h"
#include "sector_offsets.h"
#include "stages/section_runs.h"
#include "stages/segment_axis.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

namespace piperun::joints {

namespace {

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
  /// points `nearby` (not explained by any pipe), unless it is a bend's chord (see legBeyondChord).
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
    std::vector<Completion> candidates;
    std::vector<char> alongNetwork;
    std::size_t best = 0;
    for (std::size_t d = 0; d < directions.size(); ++d) {
      const bool networks = d < networkDirections.size();
      for (const double sign : {1.0, -1.0}) {
        auto candidate = completeAlong(end, sign * directions[d], networks, nearby);
        if (!candidate) continue;
        if (candidates.empty() || candidate->support() > candidates[best].support()) best = candidates.size();
        candidates.push_back(std::move(*candidate));
        alongNetwork.push_back(networks ? 1 : 0);
      }
    }
    if (candidates.empty()) return std::nullopt;
    if (!fromBends_) {
      if (const auto beyond = legBeyondChord(end, candidates[best], candidates, alongNetwork)) best = *beyond;
    }
    return std::move(candidates[best]);
  }

  /// Of the straight `legs` from `end` (those along a network direction, `alongNetwork`), the one
  /// that a bend of `end`'s pipe turns into, when `chord` took that bend's points: where a leg is
  /// hardly seen past its bend, the bend's points fit a straight halfway round the turn (a network
  /// direction when pipes elsewhere run at 45°), better supported than the leg itself (large seed
  /// 2). Such a leg turns farther than `chord`, in its plane; nearly all `chord`'s points lie within
  /// the reach of a long-radius elbow onto it, and the leg runs on past that elbow's tangent point
  /// by a diameter at least, seen there by as many points as a completion needs. Of several, the
  /// one seen farthest beyond.
  std::optional<std::size_t> legBeyondChord(const PipeEnd& end, const Completion& chord,
                                            const std::vector<Completion>& legs,
                                            const std::vector<char>& alongNetwork) const {
    const auto turnFromEnd = [&](const Eigen::Vector3d& along) {
      return std::acos(std::clamp(along.dot(end.outward), -1.0, 1.0));
    };
    const Eigen::Vector3d chordAlong = unitAxis(chord.pipe);
    const double chordBend = turnFromEnd(chordAlong);
    const Eigen::Vector3d planeNormal = chordAlong.cross(end.outward).normalized();
    std::optional<std::size_t> found;
    std::size_t mostBeyond = 0;
    for (std::size_t l = 0; l < legs.size(); ++l) {
      const Eigen::Vector3d along = unitAxis(legs[l].pipe);
      const double bend = turnFromEnd(along);
      if (!alongNetwork[l] || bend < chordBend + radians(kMinFurtherTurnDeg) ||
          std::fabs(along.dot(planeNormal)) > std::sin(radians(kMaxChordPlaneDeg))) {
        continue;
      }
      const Eigen::Vector3d& corner = legs[l].pipe.start;
      const double tangent = kLongElbowRadii * end.radius * std::tan(0.5 * bend);
      // The elbow onto the leg leaves it a pipe, not a fragment.
      if ((legs[l].pipe.end - corner).dot(along) < tangent + params_.minPipeDiameters * 2.0 * end.radius) continue;
      const double reach = tangent + end.radius + params_.supportDistance;
      const auto& chordPoints = chord.pipe.inliers;
      const auto inBend = std::count_if(chordPoints.begin(), chordPoints.end(), [&](std::uint32_t i) {
        return (input_.cloud.positions[i].cast<double>() - corner).norm() <= reach;
      });
      const auto& legPoints = legs[l].pipe.inliers;
      const auto beyond = static_cast<std::size_t>(std::count_if(legPoints.begin(), legPoints.end(), [&](std::uint32_t i) {
        return (input_.cloud.positions[i].cast<double>() - corner).dot(along) > tangent;
      }));
      if (static_cast<double>(inBend) >= kMinChordShareInBend * static_cast<double>(chordPoints.size()) &&
          beyond >= params_.minCompletionPoints && beyond > mostBeyond) {
        found = l;
        mostBeyond = beyond;
      }
    }
    return found;
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
  static constexpr double kMinFurtherTurnDeg = 15.0;      // A leg beyond a chord turns this much farther,
  static constexpr double kMaxChordPlaneDeg = 10.0;       // this close to the chord's plane, and the chord
  static constexpr double kMinChordShareInBend = 0.9;     // has this share of its points in the bend onto it.
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
  // The mean offset of a leg's points from its radius may be this (m), or this share of the radius:
  // the leg takes the end's axis and radius, fitted on one side of its pipe, and a wide end's axis
  // is a few millimetres off along the view (medium seed 1: 2 mm on a 57 mm pipe, its leg's points
  // 1.8 mm outside the radius; 3 % allowed 1.7). Wider, posts and faces by thin ends pass.
  static constexpr double kMinRadiusTolerance = 0.0015;
  static constexpr double kRadiusToleranceRadii = 0.035;
  // Rounding room of the points kept by nearPlane (m): the offsets it reads and those the tests read
  // are computed from different origins.
  static constexpr double kNearPlaneSlack = 1e-6;

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
    // The end's extension, the bend and the leg lie in the plane of `outward` and `along`: a point's
    // offset across it is its least distance from any of their axes, and no point beyond the clutter
    // shell counts for any (see isClutter; a bend's band is the joints' or narrower). Those are
    // left out of the sphere around the end once, not at every corner and bend radius tried.
    const Eigen::Vector3d planeNormal = along.cross(end.outward) / std::sin(bend);
    const std::vector<std::uint32_t> beside =
        nearPlane(nearby, end.point, planeNormal, clutterReach(end.radius, params_.supportDistance));
    if (fromBends_) return legBeyondBend(end, along, bend, networks, beside);
    auto completion = straightBeyond(end, along, beside, false);
    if (!completion) completion = straightBeyond(end, along, beside, true);
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
    if (planes_.alongPlanes(input_.cloud, pipe.inliers)) return std::nullopt;
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

  /// The points of `nearby`, in order, within `reach` of the plane through `origin` square to the
  /// unit `normal`.
  std::vector<std::uint32_t> nearPlane(const std::vector<std::uint32_t>& nearby, const Eigen::Vector3d& origin,
                                       const Eigen::Vector3d& normal, double reach) const {
    std::vector<std::uint32_t> kept;
    for (const std::uint32_t i : nearby) {
      if (std::fabs((input_.cloud.positions[i].cast<double>() - origin).dot(normal)) <= reach + kNearPlaneSlack) {
        kept.push_back(i);
      }
    }
    return kept;
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

}  // namespace

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

}  // namespace piperun::joints
