#pragma once
// Runs of occupied sections along an axis, and the clutter that ends them, shared by the merge
// stage's end extension and the joints stage's completion: both carry a pipe outward over sections
// holding surface points.

#include <algorithm>
#include <cstddef>

namespace piperun {

/// Whether a point `distance` from the axis of a tube of radius `r` whose surface points lie within
/// `band` is clutter on it: well inside the tube (a wall, a box, another pipe's wall where a branch
/// meets its main), or in a shell around it a radius wide but at most 5 cm (a wall or flange
/// grazing the surface; wider, the shell would take a rack neighbour's wall for clutter).
/// `unexplained` says whether the point is no pipe's inlier: only those count in the shell.
inline bool isClutter(double distance, double r, double band, bool unexplained) {
  constexpr double kMaxShell = 0.05;
  if (distance < r - 2.0 * band) return true;
  return unexplained && distance > r + 2.0 * band && distance <= r + 2.0 * band + std::min(r, kMaxShell);
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
