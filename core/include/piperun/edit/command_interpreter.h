#pragma once
// The named-command vocabulary of reviews and hand edits (docs/STUDIO.md, "Commands"), run one line
// at a time by the studio's keys and buttons and by `piperun-render --script`.

#include "piperun/edit/carry_over.h"
#include "piperun/edit/nominal_sizes.h"
#include "piperun/edit/project.h"
#include "piperun/pipeline.h"
#include "piperun/progress.h"

#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace piperun {

/// A command that failed. what() is one line: "<script>: line <n>: <command>: <why>" (the script
/// and line when known).
class CommandError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// What a command did, for the status line.
struct CommandOutcome {
  std::string message;               ///< One line, e.g. "joint 14 rejected" or "undid: pipe 3 delete".
  bool networkChanged = false;       ///< The reviewed network changed (an edit, undo, redo or a new network): redraw it.
  std::vector<DroppedEdit> dropped;  ///< After a re-run: the edits that could not be carried over.
};

class CommandInterpreter {
 public:
  /// Edits `project`; `pipeline` (may be null: a project opened without its scan) serves `run`,
  /// `rerun` and the edits that look at the points. Both must outlive the interpreter. Without
  /// `sizes`, the shipped table is read (when it cannot be, `snap` fails saying why).
  CommandInterpreter(Project& project, Pipeline* pipeline, std::optional<NominalSizes> sizes = std::nullopt);

  /// Runs one command line (blank lines and `#` comments do nothing). Throws CommandError.
  CommandOutcome execute(const std::string& line, Progress& progress = Progress::none());
  /// Runs a script, one command per line; stops at the first failing line (its error names the
  /// script and line).
  std::vector<CommandOutcome> runScript(const std::filesystem::path& path, Progress& progress = Progress::none());

  /// Adds a command word handled by the caller (the studio adds `select`, `view`...): `handler`
  /// gets the words after it, returns the status line, throws std::exception to report an error.
  void addCommand(const std::string& word, std::function<std::string(const std::vector<std::string>&)> handler);

  /// Autosave after this many edits (undo and redo count too); 0 turns autosave off. Default 5.
  void setAutosaveInterval(int edits) { autosaveInterval_ = edits; }

  /// `run` and `rerun` in halves, for callers that run the stages on another thread (the studio):
  /// prepareRun() checks the words and sets the parameters (nullopt when the line is no run
  /// command); the caller runs the pipeline up to `last`, from any thread, touching neither the
  /// pipeline nor the project meanwhile; finishRun() then records the pipeline's state and, when
  /// the joints stage ran anew, carries the review over. finishRun() also suits a cancelled run
  /// (it keeps what finished) and a run the caller started itself (newNetwork false: the stages'
  /// results are recomputed, the reviewed network stays).
  struct PendingRun {
    Stage last = Stage::Joints;
    bool newNetwork = false;  ///< The joints stage was stale: its new network replaces the reviewed one.
  };
  std::optional<PendingRun> prepareRun(const std::string& line);
  CommandOutcome finishRun(const PendingRun& run);

  /// The context edits run with: the preprocessed cloud when the pipeline has one, the current
  /// joints and placement parameters, the nominal sizes.
  EditContext editContext() const;
  /// The nominal sizes' table; nullptr when it could not be read.
  const NominalSizes* sizes() const { return sizes_ ? &*sizes_ : nullptr; }

 private:
  CommandOutcome dispatch(const std::vector<std::string>& words, Progress& progress);
  PendingRun parseRun(const std::vector<std::string>& words);
  void countEdit();

  Project& project_;
  Pipeline* pipeline_;
  std::optional<NominalSizes> sizes_;
  std::string sizesError_;  ///< Why the shipped table could not be read.
  std::map<std::string, std::function<std::string(const std::vector<std::string>&)>> extraCommands_;
  int autosaveInterval_ = 5;
  int editsSinceAutosave_ = 0;
};

}  // namespace piperun
