#pragma once
// Runs of occupied sections along an axis, shared by the merge stage's end extension and the
// joints stage's completion: both carry a pipe outward over sections holding surface points.

#include <cstddef>

namespace piperun {

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
