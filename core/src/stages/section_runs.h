#pragma once
// Runs of occupied sections along an axis, and the clutter that ends them, shared by the merge
// stage's end extension and the joints stage's completion and legs beyond gentle bends: all carry
// a pipe outward over sections holding surface points.

#include <algorithm>
#include <cstddef>

namespace piperun {

/// The outer edge of the clutter shell around a tube of radius `r` (see isClutter): no point
/// farther from its axis counts for the tube in any way.
inline double clutterReach(double r, double band) {
  constexpr double kMaxShell = 0.05;
  return r + 2.0 * band + std::min(r, kMaxShell);
}

/// Whether a point `distance` from the axis of a tube of radius `r` whose surface points lie within
/// `band` is clutter on it: well inside the tube (a wall, a box, another pipe's wall where a branch
/// meets its main), or in a shell around it a radius wide but at most 5 cm (a wall or flange
/// grazing the surface; wider, the shell would take a rack neighbour's wall for clutter).
/// `unexplained` says whether the point is no pipe's inlier: only those count in the shell.
inline bool isClutter(double distance, double r, double band, bool unexplained) {
  if (distance < r - 2.0 * band) return true;
  return unexplained && distance > r + 2.0 * band && distance <= clutterReach(r, band);
}

/// The last section of the run from the occupied section `from`, over gaps of at most `maxGap`
/// empty sections, among the first `count`; `occupied(k)` says whether section k holds a point.
template <class Occupied>
std::size_t runEnd(std::size_t from, std::size_t count, std::size_t maxGap, const Occupied& occupied) {
  std::size_t end = from;
  for (std::size_t k = from + 1; k < count && k - end <= maxGap; ++k) {
    if (occupied(k)) end = k;
  }
  return end;
}

/// The last section of the run from section `first` to the occupied section `last` once a tail of
/// stray points is gone: while `last` holds a single point and the last ten sections up to it hold
/// points in under 35 % of them, the run ends at the occupied section before it. A pipe seen up to
/// its end has points in most of its sections there, sparse or not; outliers lying on its line
/// beyond, a few sections apart, do not (the extents' rule for their runs' ends, see closeThenOpen).
/// `pointsIn(k)` says how many points section k holds.
template <class PointsIn>
std::size_t withoutStrayTail(std::size_t first, std::size_t last, const PointsIn& pointsIn) {
  constexpr std::size_t kWindow = 10;
  constexpr double kMaxStrayShare = 0.35;
  const auto sparse = [&](std::size_t end) {
    std::size_t occupied = 0;
    for (std::size_t k = end + 1 - kWindow; k <= end; ++k) occupied += pointsIn(k) > 0 ? 1 : 0;
    return static_cast<double>(occupied) < kMaxStrayShare * static_cast<double>(kWindow);
  };
  while (last >= first + kWindow && pointsIn(last) == 1 && sparse(last)) {
    do --last;
    while (last > first && pointsIn(last) == 0);
  }
  return last;
}

/// From a run ending at section `last`, the last section reached across occlusions: a gap of at
/// most `maxBridge` sections is crossed when the run beyond it is at least as long (the extents'
/// rule: a long stretch of pipe beyond a gap says the pipe runs on behind whatever hides it).
template <class Occupied>
std::size_t bridgedEnd(std::size_t last, std::size_t count, std::size_t maxGap, std::size_t maxBridge,
                       const Occupied& occupied) {
  for (std::size_t next = last + 1; next < count && next - last - 1 <= maxBridge; ++next) {
    if (!occupied(next)) continue;
    const std::size_t end = runEnd(next, count, maxGap, occupied);
    if (end - next + 1 < next - last - 1) break;
    last = end;
  }
  return last;
}

}  // namespace piperun
