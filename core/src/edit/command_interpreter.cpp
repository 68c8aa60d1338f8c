#include "piperun/edit/command_interpreter.h"

#include "piperun/edit/runs.h"
#include "piperun/error.h"
#include "piperun/io/network_export.h"
#include "piperun/params.h"

#include <fstream>
#include <set>
#include <sstream>

namespace piperun {

namespace {

std::vector<std::string> splitWords(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> words;
  for (std::string word; in >> word;) words.push_back(word);
  return words;
}

std::string joined(const std::vector<std::string>& words) {
  std::string text;
  for (const auto& word : words) text += (text.empty() ? "" : " ") + word;
  return text;
}

/// The status line of an applied edit.
std::string describe(const EditStep& step) {
  const Edit& edit = step.edit;
  const std::string joint = "joint " + std::to_string(edit.id), pipe = "pipe " + std::to_string(edit.id);
  const NetworkDiff& diff = step.diff;
  switch (edit.kind) {
    case EditKind::AcceptJoint: return joint + " accepted";
    case EditKind::RejectJoint: return joint + " rejected";
    case EditKind::ProposeJoint: return joint + " back in the review queue";
    case EditKind::AddJoint:
      return "joint " + std::to_string(diff.joints.added.at(0).element.id) + " (" + toString(diff.joints.added[0].element.type) +
             ") joins pipes " + std::to_string(edit.id) + " and " + std::to_string(edit.otherId);
    case EditKind::DeletePipe: return pipe + " deleted";
    case EditKind::RestorePipe: return pipe + " restored";
    case EditKind::AcceptPipe: return pipe + " accepted";
    case EditKind::MergePipes: return "pipe " + std::to_string(edit.otherId) + " merged into " + pipe;
    case EditKind::SplitPipe: return pipe + " split; the far piece is pipe " + std::to_string(diff.pipes.added.at(0).element.id);
    case EditKind::SetRadius:
    case EditKind::SnapRadius: {
      for (const auto& change : diff.pipes.changed) {
        if (change.after.id == edit.id) return pipe + " radius " + std::to_string(change.after.radius) + " m";
      }
      return pipe + " radius unchanged";
    }
    case EditKind::MoveEnd: return pipe + (edit.side == 0 ? " start" : " end") + " moved";
    case EditKind::FitInBox:
    case EditKind::FitAround: {
      const Pipe& fitted = diff.pipes.added.at(0).element;
      return "fitted pipe " + std::to_string(fitted.id) + ": radius " + std::to_string(fitted.radius) + " m, length " +
             std::to_string(fitted.length()) + " m, " + std::to_string(fitted.inlierCount) + " points";
    }
  }
  return toCommand(edit);
}

const char* kUsage =
    "expected one of: run [STAGE] | rerun STAGE key=value... | undo | redo | save PATH | export FILE [accepted] | "
    "joint ID accept|reject|propose | joint add A B | "
    "pipe ID delete|restore|snap|radius R|merge ID|split X Y Z|move-end start|end X Y Z | pipe fit-box X0 Y0 Z0 X1 Y1 Z1 | "
    "pipe fit-point X Y Z [REACH]";

}  // namespace

CommandInterpreter::CommandInterpreter(Project& project, Pipeline* pipeline, std::optional<NominalSizes> sizes)
    : project_(project), pipeline_(pipeline), sizes_(std::move(sizes)) {
  if (sizes_) return;
  try {
    sizes_ = NominalSizes::shipped();
  } catch (const InputError& error) {
    sizesError_ = error.what();
  }
}

EditContext CommandInterpreter::editContext() const {
  EditContext context;
  if (pipeline_ && pipeline_->preprocessResult()) context.cloud = &pipeline_->preprocessResult()->points;
  context.joints = project_.params.joints;
  context.placement = project_.params.placement;
  context.sizes = sizes_ ? &*sizes_ : nullptr;
  return context;
}

void CommandInterpreter::addCommand(const std::string& word,
                                    std::function<std::string(const std::vector<std::string>&)> handler) {
  extraCommands_[word] = std::move(handler);
}

void CommandInterpreter::countEdit() {
  if (autosaveInterval_ <= 0 || ++editsSinceAutosave_ < autosaveInterval_) return;
  editsSinceAutosave_ = 0;
  autosaveProject(project_);
}

CommandInterpreter::PendingRun CommandInterpreter::parseRun(const std::vector<std::string>& words) {
  const std::string& verb = words.front();
  if (!pipeline_) throw EditError("no scan is open: " + verb + " needs the scan the project was made from");
  const auto stageNamed = [](const std::string& name) {
    const auto stage = stageFromName(name);
    if (!stage) throw EditError("unknown stage \"" + name + "\" (preprocess, directions, placement, extents, merge, joints)");
    return *stage;
  };
  PendingRun run;
  if (verb == "run") {
    if (words.size() > 2) throw EditError("expected \"run [STAGE]\"");
    if (words.size() == 2) run.last = stageNamed(words[1]);
  } else {
    if (words.size() < 2) throw EditError("expected \"rerun STAGE key=value ...\"");
    run.last = stageNamed(words[1]);
    PipelineParams params = pipeline_->params();
    std::set<std::string> keys;
    for (const ParamDescription& description : describeParams()) keys.insert(description.key);
    for (std::size_t i = 2; i < words.size(); ++i) {
      // Keys are the stage's own ("center_bandwidth=0.012") or top-level ones ("seed=3", "up=y");
      // "section.key=value" names any.
      const bool qualified = words[i].find('.') < words[i].find('=');
      const std::string key = words[i].substr(0, words[i].find('='));
      const bool topLevel = !keys.count(words[1] + "." + key) && keys.count(key);
      try {
        setParam(params, qualified || topLevel ? words[i] : words[1] + "." + words[i]);
      } catch (const std::invalid_argument& error) {
        throw EditError(error.what());
      }
    }
    pipeline_->setParams(params);
    pipeline_->invalidate(run.last);
  }
  run.newNetwork = run.last == Stage::Joints && !pipeline_->isFresh(Stage::Joints);
  return run;
}

std::optional<CommandInterpreter::PendingRun> CommandInterpreter::prepareRun(const std::string& line) {
  const std::vector<std::string> words = splitWords(line.substr(0, line.find('#')));
  if (words.empty() || (words.front() != "run" && words.front() != "rerun")) return std::nullopt;
  try {
    return parseRun(words);
  } catch (const std::exception& error) {
    throw CommandError(joined(words) + ": " + error.what());
  }
}

CommandOutcome CommandInterpreter::finishRun(const PendingRun& run) {
  recordPipelineState(project_, *pipeline_);
  if (!run.newNetwork || !pipeline_->isFresh(Stage::Joints)) {
    std::string message = "ran up to " + std::string(stageName(run.last));
    for (Stage stage : kAllStages) {
      if (!pipeline_->isFresh(stage)) return {message + "; " + stageName(stage) + " and later are stale (\"run\" runs them)", false, {}};
    }
    return {message + "; every stage is fresh", false, {}};
  }
  // A new network: the review carries over to it.
  CarryOver carried = carryOver(project_.edits, pipeline_->network(), editContext());
  CommandOutcome outcome;
  outcome.networkChanged = true;
  const std::size_t kept = carried.session.position();
  project_.edits = std::move(carried.session);
  outcome.dropped = std::move(carried.dropped);
  outcome.message = "network: " + std::to_string(project_.edits.network().pipes.size()) + " pipes, " +
                    std::to_string(project_.edits.network().joints.size()) + " joints";
  // Only a review in progress has something to carry over.
  if (kept > 0 || !outcome.dropped.empty()) {
    outcome.message += "; " + std::to_string(kept) + " edits carried over, " + std::to_string(outcome.dropped.size()) +
                       " not";
  }
  return outcome;
}

CommandOutcome CommandInterpreter::dispatch(const std::vector<std::string>& words, Progress& progress) {
  const std::string& verb = words.front();
  if (verb == "run" || verb == "rerun") {
    const PendingRun run = parseRun(words);
    pipeline_->run(progress, run.last);
    return finishRun(run);
  }
  if (verb == "undo" || verb == "redo") {
    if (words.size() != 1) throw EditError("expected \"" + verb + "\"");
    const EditStep& step = verb == "undo" ? project_.edits.undo() : project_.edits.redo();
    countEdit();
    return {(verb == "undo" ? "undid: " : "redid: ") + toCommand(step.edit), true, {}};
  }
  if (verb == "save") {
    if (words.size() != 2) throw EditError("expected \"save PATH\"");
    saveProject(words[1], project_);
    editsSinceAutosave_ = 0;
    return {"saved " + words[1], false, {}};
  }
  if (verb == "export") {
    const bool acceptedOnly = words.size() == 3 && words[2] == "accepted";
    if (words.size() != 2 && !acceptedOnly) {
      throw EditError("expected \"export FILE [accepted]\" (" + exportFileKinds() + ")");
    }
    const auto format = exportFormatFromPath(words[1]);
    if (!format) {
      throw EditError("cannot tell the export format from \"" + words[1] + "\": name a " + exportFileKinds() + " file");
    }
    const PipeNetwork& network = project_.edits.network();
    ExportOptions options;
    options.up = project_.params.up;
    exportNetwork(acceptedOnly ? acceptedPart(network) : network, *format, words[1], options);
    return {"exported " + words[1] + " (" + toString(*format) + (acceptedOnly ? ", accepted only)" : ")"), false, {}};
  }
  if (const auto edit = parseEdit(words)) {
    if (edit->kind == EditKind::SnapRadius && !sizes_) throw EditError(sizesError_);
    const EditStep& step = project_.edits.apply(*edit, editContext());
    countEdit();
    return {describe(step), true, {}};
  }
  if (const auto found = extraCommands_.find(verb); found != extraCommands_.end()) {
    return {found->second(std::vector<std::string>(words.begin() + 1, words.end())), false, {}};
  }
  throw EditError(std::string("unknown command; ") + kUsage);
}

CommandOutcome CommandInterpreter::execute(const std::string& line, Progress& progress) {
  const std::vector<std::string> words = splitWords(line.substr(0, line.find('#')));
  if (words.empty()) return {};
  try {
    return dispatch(words, progress);
  } catch (const Cancelled&) {
    throw;
  } catch (const std::exception& error) {
    throw CommandError(joined(words) + ": " + error.what());
  }
}

std::vector<CommandOutcome> CommandInterpreter::runScript(const std::filesystem::path& path, Progress& progress) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "", "cannot open the script");
  std::vector<CommandOutcome> outcomes;
  std::string line;
  for (std::uint64_t number = 1; std::getline(in, line); ++number) {
    try {
      outcomes.push_back(execute(line, progress));
    } catch (const CommandError& error) {
      throw CommandError(path.string() + ": " + lineLocation(number) + ": " + error.what());
    }
  }
  return outcomes;
}

}  // namespace piperun
