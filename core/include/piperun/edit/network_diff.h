#pragma once
// The change one edit makes to a network, kept small (only the elements it touched) so that undo
// and redo are unlimited and project files store the whole history.

#include "piperun/pipe_network.h"

#include <cstddef>
#include <vector>

namespace piperun {

/// Elements removed, added and changed between two networks whose surviving elements keep their
/// relative order (which every edit preserves). Runs are not part of it: they follow from the
/// pipes and joints (assignRuns), and a pipe's runId is ignored when comparing.
template <class Element>
struct ElementChanges {
  struct Placed {
    std::size_t index = 0;  ///< Position in the network's list (before the change for removed, after for added).
    Element element;
  };
  struct Changed {
    Element before;
    Element after;
  };
  std::vector<Placed> removed;  ///< Ascending index.
  std::vector<Placed> added;    ///< Ascending index.
  std::vector<Changed> changed;

  bool empty() const { return removed.empty() && added.empty() && changed.empty(); }
};

struct NetworkDiff {
  ElementChanges<Pipe> pipes;
  ElementChanges<Joint> joints;

  bool empty() const { return pipes.empty() && joints.empty(); }
};

/// What turns `before` into `after`.
NetworkDiff diffNetworks(const PipeNetwork& before, const PipeNetwork& after);
/// Applies `diff` to the network it was taken from (redo), or back (undo). Runs are left as they
/// were: call assignRuns() afterwards.
void applyDiff(PipeNetwork& network, const NetworkDiff& diff);
void revertDiff(PipeNetwork& network, const NetworkDiff& diff);

/// Equal in every field but the pipe's runId (which assignRuns() derives).
bool sameElement(const Pipe& a, const Pipe& b);
bool sameElement(const Joint& a, const Joint& b);

}  // namespace piperun
