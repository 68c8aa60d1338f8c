#pragma once
// The network under review: edits applied one undoable step at a time, undo and redo without limit.

#include "piperun/edit/edit.h"
#include "piperun/edit/network_diff.h"
#include "piperun/pipe_network.h"

#include <cstddef>
#include <vector>

namespace piperun {

/// One undoable step: the edit as the user gave it and the change it made.
struct EditStep {
  Edit edit;
  NetworkDiff diff;
};

/// Holds the network the pipeline produced (the base), the edited network and the history.
/// After every edit, undo and redo the runs are rebuilt (assignRuns), so rejected joints and
/// deleted pipes leave their runs at once.
class EditSession {
 public:
  /// Starts a review of `base` (its runs are rebuilt with assignRuns so every state is comparable).
  explicit EditSession(PipeNetwork base = {});
  /// Restores a saved session: `steps` were made on `base`, the first `position` of them are
  /// applied (the others can be redone). Throws std::invalid_argument when position > steps.size().
  EditSession(PipeNetwork base, std::vector<EditStep> steps, std::size_t position);

  const PipeNetwork& base() const { return base_; }
  const PipeNetwork& network() const { return network_; }
  const std::vector<EditStep>& steps() const { return steps_; }
  /// How many steps are applied: steps()[0, position()) are done, the rest can be redone.
  std::size_t position() const { return position_; }

  /// Applies `edit` as a new step (dropping the steps that could be redone) and returns it.
  /// Throws EditError when it does not apply; the network is then unchanged.
  const EditStep& apply(const Edit& edit, const EditContext& context);

  bool canUndo() const { return position_ > 0; }
  bool canRedo() const { return position_ < steps_.size(); }
  /// Return the step undone / redone; throw EditError when there is nothing to undo / redo.
  const EditStep& undo();
  const EditStep& redo();

 private:
  PipeStatus statusBeforeDeletion(const Pipe& pipe) const;

  PipeNetwork base_;
  PipeNetwork network_;
  std::vector<EditStep> steps_;
  std::size_t position_ = 0;
};

/// Applies one edit to `network` in place (runs untouched; see assignRuns). `restoredStatus` is the
/// status a restored pipe takes back. Throws EditError when the edit does not apply; the network
/// may then be partly changed, so callers edit a copy.
void applyEdit(PipeNetwork& network, const Edit& edit, const EditContext& context,
               PipeStatus restoredStatus = PipeStatus::Accepted);

/// The smallest id above every pipe and joint id: new elements take it (ids stay unique across both lists).
int nextElementId(const PipeNetwork& network);

}  // namespace piperun
