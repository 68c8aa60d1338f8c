#pragma once
// Carrying review decisions and hand edits onto the network of a re-run stage.

#include "piperun/edit/edit_session.h"

#include <map>
#include <string>
#include <vector>

namespace piperun {

/// Whether pipe `b` is pipe `a` found again (docs/STUDIO.md, "Carry-over"): radii within 20 % of
/// each other, axes within 10°, b's centre line within max(a's radius, 2 cm) of a's over their
/// overlap, and the overlap along a's axis at least half the shorter pipe. Returns the overlap
/// length (m) when they match, 0 otherwise.
double pipeMatchOverlap(const Pipe& a, const Pipe& b);

/// Pairs the pipes of `from` with those of `to`, one to one, largest overlap first: the id in `to`
/// for each matched pipe id of `from`. Deleted pipes of `to` take no part.
std::map<int, int> matchPipes(const PipeNetwork& from, const PipeNetwork& to);

/// An edit that could not be carried over, and why.
struct DroppedEdit {
  std::string command;  ///< The edit as its command line, with the ids it had.
  std::string reason;   ///< One line.
};

struct CarryOver {
  EditSession session;               ///< Starts from the new network; holds the carried steps.
  std::vector<DroppedEdit> dropped;  ///< Every applied edit that was not carried, in history order.
};

/// Replays the applied steps of `session` (the undone ones are left behind) onto `newBase`, the
/// network of the re-run pipeline. Element ids are translated: a pipe by matchPipes() from the old
/// base (pipes the edits created, by the step that created them), a joint by the pipes it joins.
/// An edit whose elements have no counterpart, or that no longer applies, is returned in
/// `dropped`; a fitted pipe the new network already has is dropped as such (later edits of it go
/// to the pipeline's pipe).
CarryOver carryOver(const EditSession& session, const PipeNetwork& newBase, const EditContext& context);

}  // namespace piperun
