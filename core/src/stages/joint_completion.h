#pragma once
// The joints stage's completion of free ends (see joints.cpp, step 4): pipes the earlier stages
// missed, found beyond an end or off a pipe's body.

#include "stages/joint_resolution.h"
#include "points_near.h"
#include "sort_by_key.h"

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

namespace piperun::joints {

/// The 1 cm cells holding points removed as large planes: a point lies by a plane when a cell within
/// one of its own holds one (within 1–2 cm of a plane point). Kept as the sorted numbers of the
/// filled cells (CellNumbering over the plane points' bounding box), built once per joining: a large
/// scan's floors hold millions of points, too many to file again each round. They are grouped a slab
/// of numbers at a time, so that only 4 bytes a plane point are held besides (a 100 million point
/// scan's 36 million plane points, sorted whole, took 0.6 GB).
class PlaneCells {
 public:
  explicit PlaneCells(const PointCloud* planes) {
    if (!planes || planes->empty()) return;
    numbering_ = CellNumbering(planes->positions, kCellSize);
    numbers_ = groupItemsByKey(planes->size(), [&](std::size_t i) {
                 return numbering_.numberOf(numbering_.cellOf(planes->positions[i].cast<double>()));
               }).keys;
  }

  /// Whether `points` (indices into `cloud`) run along a plane: more than half of them lie by one,
  /// as along a floor's seam or the edge where a wall meets the floor or the roof, which the plane
  /// removal leaves. A pipe over them is the planes', not a pipe. On the generated scenes the pipes
  /// found along such edges have 27–100 % of their inliers by a plane, and every true pipe under
  /// 20 %; but a 5 cm pipe lying on the floor has about a third, so the share must be over half.
  bool alongPlanes(const PointCloud& cloud, const std::vector<std::uint32_t>& points) const {
    if (numbers_.empty()) return false;
    const double most = kMaxByPlaneShare * static_cast<double>(points.size());
    std::size_t byPlane = 0;
    for (std::size_t k = 0; k < points.size(); ++k) {
      byPlane += by(cloud.positions[points[k]].cast<double>());
      if (static_cast<double>(byPlane) > most) return true;
      if (static_cast<double>(byPlane + points.size() - k - 1) <= most) return false;  // the rest cannot tip it
    }
    return false;
  }

  bool by(const Eigen::Vector3d& p) const {
    if (numbers_.empty()) return false;
    // The 27 cells around p's are nine rows along x, each a range of consecutive numbers: one search
    // a row.
    const Eigen::Vector3i cell = numbering_.cellOf(p);
    const int lowestX = numbering_.lowest().x(), highestX = numbering_.highest().x();
    for (int row = 0; row < 9; ++row) {
      Eigen::Vector3i first = cell + Eigen::Vector3i(-1, row % 3 - 1, row / 3 - 1);
      Eigen::Vector3i last = first + Eigen::Vector3i(2, 0, 0);
      first.x() = std::max(first.x(), lowestX);
      last.x() = std::min(last.x(), highestX);
      if (first.x() > last.x() || !numbering_.contains(first)) continue;
      const auto found = std::lower_bound(numbers_.begin(), numbers_.end(), numbering_.numberOf(first));
      if (found != numbers_.end() && *found <= numbering_.numberOf(last)) return true;
    }
    return false;
  }

 private:
  static constexpr double kCellSize = 0.01;
  static constexpr double kMaxByPlaneShare = 0.5;

  CellNumbering numbering_{{}, kCellSize};
  std::vector<std::uint64_t> numbers_;  // the filled cells, ascending
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

/// Completions of the ends no accepted joint took, and branches off the pipes' bodies, of the pipes
/// from `lookingFrom` on; best-supported first, a point supports one completion.
std::vector<Completion> completeFreeEnds(const JointsInput& input, const JointsParams& params,
                                         const std::vector<char>& explained, const Resolution& resolution,
                                         const PlaneCells& planes, std::size_t lookingFrom, const PointCells& cells,
                                         bool fromBends);

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
                                         std::size_t completionsFrom, const PointCells& cells, Progress& progress);

}  // namespace piperun::joints
