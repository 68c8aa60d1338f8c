#include "piperun/edit/project.h"

#include "io/atomic_file.h"
#include "io/file_extension.h"
#include "io/network_json.h"
#include "json_text.h"
#include "piperun/error.h"
#include "piperun/io/point_reader.h"
#include "piperun/params.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace piperun {

using nlohmann::json;

namespace {

constexpr const char* kAutosaveSuffix = ".autosave";

[[noreturn]] void fail(const std::filesystem::path& source, const std::string& pointer, const std::string& message) {
  throw InputError(source, pointer.empty() ? "/" : pointer, message);
}

const json& member(const json& object, const std::filesystem::path& source, const std::string& pointer, const char* key) {
  if (!object.is_object()) fail(source, pointer, "expected an object");
  const auto found = object.find(key);
  if (found == object.end()) fail(source, pointer, std::string("missing required field \"") + key + "\"");
  return *found;
}

PipeNetwork readEmbeddedNetwork(const json& value, const std::filesystem::path& source, const std::string& pointer) {
  try {
    return networkFromJsonValue(value, source);
  } catch (const InputError& error) {
    // Locations inside the embedded document are relative to it.
    fail(source, pointer + (error.location() == "/" ? "" : error.location()), error.message());
  }
}

bool sameElements(const PipeNetwork& a, const PipeNetwork& b) {
  const auto same = [](const auto& x, const auto& y) {
    return std::equal(x.begin(), x.end(), y.begin(), y.end(), [](const auto& p, const auto& q) { return sameElement(p, q); });
  };
  return same(a.pipes, b.pipes) && same(a.joints, b.joints);
}

std::vector<std::string> splitWords(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> words;
  for (std::string word; in >> word;) words.push_back(word);
  return words;
}

template <class Element>
json changesToJson(const ElementChanges<Element>& changes, const char* key, json (*toJson)(const Element&)) {
  json removed = json::array(), added = json::array(), changed = json::array();
  for (const auto& placed : changes.removed) removed.push_back({{"index", placed.index}, {key, toJson(placed.element)}});
  for (const auto& placed : changes.added) added.push_back({{"index", placed.index}, {key, toJson(placed.element)}});
  for (const auto& change : changes.changed) changed.push_back({{"before", toJson(change.before)}, {"after", toJson(change.after)}});
  return {{"removed", removed}, {"added", added}, {"changed", changed}};
}

template <class Element>
ElementChanges<Element> changesFromJson(const json& value, const std::filesystem::path& source, const std::string& pointer,
                                        const char* key,
                                        Element (*fromJson)(const json&, const std::filesystem::path&, const std::string&)) {
  ElementChanges<Element> changes;
  const auto placedList = [&](const char* list, std::vector<typename ElementChanges<Element>::Placed>& out) {
    const json& items = member(value, source, pointer, list);
    const std::string at = pointer + "/" + list;
    if (!items.is_array()) fail(source, at, "expected an array");
    for (std::size_t i = 0; i < items.size(); ++i) {
      const std::string item = at + "/" + std::to_string(i);
      const json& index = member(items[i], source, item, "index");
      if (!index.is_number_unsigned()) fail(source, item + "/index", "expected a non-negative integer");
      out.push_back({index.get<std::size_t>(), fromJson(member(items[i], source, item, key), source, item + "/" + key)});
    }
  };
  placedList("removed", changes.removed);
  placedList("added", changes.added);
  const json& changed = member(value, source, pointer, "changed");
  if (!changed.is_array()) fail(source, pointer + "/changed", "expected an array");
  for (std::size_t i = 0; i < changed.size(); ++i) {
    const std::string item = pointer + "/changed/" + std::to_string(i);
    changes.changed.push_back({fromJson(member(changed[i], source, item, "before"), source, item + "/before"),
                               fromJson(member(changed[i], source, item, "after"), source, item + "/after")});
  }
  return changes;
}

std::filesystem::path withSuffix(const std::filesystem::path& path, const std::string& suffix) {
  return path.string() + suffix;
}

}  // namespace

std::string hashFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open to compute its hash");
  std::uint64_t hash = 0xcbf29ce484222325ull;  // FNV-1a offset basis
  std::vector<char> buffer(1 << 20);
  while (in) {
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    const auto count = static_cast<std::size_t>(in.gcount());
    for (std::size_t i = 0; i < count; ++i) {
      hash ^= static_cast<unsigned char>(buffer[i]);
      hash *= 0x100000001b3ull;  // FNV prime
    }
  }
  char text[32];
  std::snprintf(text, sizeof text, "fnv1a64:%016" PRIx64, hash);
  return text;
}

void recordPipelineState(Project& project, const Pipeline& pipeline) {
  project.params = pipeline.params();
  for (Stage stage : kAllStages) project.freshStages[static_cast<std::size_t>(stage)] = pipeline.isFresh(stage);
}

Project newProject(const std::filesystem::path& scanPath, const Pipeline& pipeline, const std::string& scanUnits) {
  Project project;
  project.scanPath = std::filesystem::absolute(scanPath).lexically_normal();
  project.scanHash = hashFile(project.scanPath);
  project.scanUnits = scanUnits;
  recordPipelineState(project, pipeline);
  project.edits = EditSession(pipeline.network());
  return project;
}

std::string projectToJson(const Project& project) {
  // Ordered so that a reader meets the format, the scan and the parameters before the networks.
  nlohmann::ordered_json document;
  document["format"] = kProjectFormatName;
  document["version"] = kProjectFormatVersion;
  document["scan"] = project.scanPath.empty() ? json(nullptr)
                                              : json{{"path", project.scanPath.string()},
                                                     {"hash", project.scanHash},
                                                     {"units", project.scanUnits}};
  document["parameters"] = json::parse(paramsToJson(project.params, -1));
  nlohmann::ordered_json stages;
  for (Stage stage : kAllStages) stages[stageName(stage)] = project.freshStages[static_cast<std::size_t>(stage)] ? "fresh" : "stale";
  document["stages"] = std::move(stages);
  document["network"] = networkToJsonValue(project.edits.network());
  document["base"] = networkToJsonValue(project.edits.base());
  json steps = json::array();
  for (const EditStep& step : project.edits.steps()) {
    steps.push_back({{"command", toCommand(step.edit)},
                     {"pipes", changesToJson<Pipe>(step.diff.pipes, "pipe", &pipeToJson)},
                     {"joints", changesToJson<Joint>(step.diff.joints, "joint", &jointToJson)}});
  }
  document["history"] = {{"position", project.edits.position()}, {"steps", std::move(steps)}};
  return document.dump(1) + "\n";
}

Project projectFromJson(const std::string& text, const std::filesystem::path& source, std::vector<std::string>* warnings) {
  const json document = parseJsonText<json>(text, source);
  const json& format = member(document, source, "", "format");
  if (format != kProjectFormatName) fail(source, "/format", "expected \"piperun-project\"");
  const json& version = member(document, source, "", "version");
  if (version != kProjectFormatVersion) {
    fail(source, "/version", "unsupported piperun-project version " + version.dump() + "; this build reads version " +
                                 std::to_string(kProjectFormatVersion));
  }

  Project project;
  const json& scan = member(document, source, "", "scan");
  if (!scan.is_null()) {
    const json& path = member(scan, source, "/scan", "path");
    const json& hash = member(scan, source, "/scan", "hash");
    if (!path.is_string()) fail(source, "/scan/path", "expected a string");
    if (!hash.is_string()) fail(source, "/scan/hash", "expected a string");
    project.scanPath = path.get<std::string>();
    project.scanHash = hash.get<std::string>();
    // Projects saved before scans had a unit were all in metres.
    if (scan.contains("units")) {
      const json& units = scan["units"];
      if (!units.is_string() || !metresPerUnit(units.get<std::string>())) {
        std::string names;
        for (const std::string& name : lengthUnitNames()) names += (names.empty() ? "\"" : ", \"") + name + "\"";
        fail(source, "/scan/units", "expected one of " + names);
      }
      project.scanUnits = units.get<std::string>();
    }
  }
  project.params = paramsFromJson(member(document, source, "", "parameters").dump(), source);
  const json& stages = member(document, source, "", "stages");
  for (Stage stage : kAllStages) {
    const std::string pointer = std::string("/stages/") + stageName(stage);
    const json& state = member(stages, source, "/stages", stageName(stage));
    if (state != "fresh" && state != "stale") fail(source, pointer, "expected \"fresh\" or \"stale\"");
    project.freshStages[static_cast<std::size_t>(stage)] = state == "fresh";
  }
  PipeNetwork network = readEmbeddedNetwork(member(document, source, "", "network"), source, "/network");
  PipeNetwork base = readEmbeddedNetwork(member(document, source, "", "base"), source, "/base");

  const json& history = member(document, source, "", "history");
  const json& position = member(history, source, "/history", "position");
  const json& steps = member(history, source, "/history", "steps");
  if (!position.is_number_unsigned()) fail(source, "/history/position", "expected a non-negative integer");
  if (!steps.is_array()) fail(source, "/history/steps", "expected an array");
  if (position.get<std::size_t>() > steps.size()) fail(source, "/history/position", "beyond the last step");
  std::vector<EditStep> restored;
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const std::string pointer = "/history/steps/" + std::to_string(i);
    const json& command = member(steps[i], source, pointer, "command");
    if (!command.is_string()) fail(source, pointer + "/command", "expected a string");
    std::optional<Edit> edit;
    try {
      edit = parseEdit(splitWords(command.get<std::string>()));
    } catch (const EditError& error) {
      fail(source, pointer + "/command", error.what());
    }
    if (!edit) fail(source, pointer + "/command", "expected an edit command, found \"" + command.get<std::string>() + "\"");
    restored.push_back({*edit,
                       {changesFromJson<Pipe>(member(steps[i], source, pointer, "pipes"), source, pointer + "/pipes", "pipe", &pipeFromJson),
                        changesFromJson<Joint>(member(steps[i], source, pointer, "joints"), source, pointer + "/joints", "joint",
                                               &jointFromJson)}});
  }
  try {
    project.edits = EditSession(base, std::move(restored), position.get<std::size_t>());
  } catch (const std::exception& error) {
    fail(source, "/history", std::string("does not apply to the base network: ") + error.what());
  }
  // The history must lead to the saved network; if it does not, the network wins.
  if (!sameElements(project.edits.network(), network)) {
    if (warnings) warnings->push_back(source.string() + ": the edit history does not lead to the saved network; undo history dropped");
    project.edits = EditSession(std::move(network));
  }
  return project;
}

void saveProject(const std::filesystem::path& path, Project& project) {
  const std::filesystem::path previousAutosave = autosavePath(project);
  io::writeFileAtomically(path, projectToJson(project));
  project.file = path;
  std::error_code ignored;
  if (!previousAutosave.empty()) std::filesystem::remove(previousAutosave, ignored);
  std::filesystem::remove(autosavePath(project), ignored);
}

std::filesystem::path autosavePath(const Project& project) {
  if (!project.file.empty()) return withSuffix(project.file, kAutosaveSuffix);
  if (!project.scanPath.empty()) return withSuffix(project.scanPath, std::string(".piperun") + kAutosaveSuffix);
  return {};
}

void autosaveProject(const Project& project) {
  const std::filesystem::path path = autosavePath(project);
  if (!path.empty()) io::writeFileAtomically(path, projectToJson(project));
}

namespace {

std::string projectText(const std::filesystem::path& path) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) throw InputError(path, "", "no such file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open");
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

}  // namespace

bool isProjectFile(const std::filesystem::path& path) { return io::lowerExtension(path) == ".piperun"; }

Project readProject(const std::filesystem::path& path) {
  Project project = projectFromJson(projectText(path), path);
  project.file = path;
  return project;
}

OpenedProject openProject(const std::filesystem::path& path) {
  std::error_code error;
  OpenedProject opened;
  opened.project = projectFromJson(projectText(path), path, &opened.warnings);
  Project& project = opened.project;
  project.file = path;

  if (!project.scanPath.empty()) {
    if (!std::filesystem::is_regular_file(project.scanPath, error)) {
      // A project moved with its scan finds it beside itself.
      const std::filesystem::path beside = path.parent_path() / project.scanPath.filename();
      if (std::filesystem::is_regular_file(beside, error)) {
        opened.warnings.push_back(path.string() + ": scan " + project.scanPath.string() + " not found; using " + beside.string());
        project.scanPath = std::filesystem::absolute(beside).lexically_normal();
      }
    }
    if (!std::filesystem::is_regular_file(project.scanPath, error)) {
      opened.warnings.push_back(path.string() + ": scan " + project.scanPath.string() +
                                " not found; the network opens, re-running stages needs the scan");
    } else if (const std::string hash = hashFile(project.scanPath); hash != project.scanHash) {
      opened.warnings.push_back(path.string() + ": scan " + project.scanPath.string() +
                                " changed since the project was saved (hash " + hash + ", saved " + project.scanHash +
                                "); the saved network opens as it was");
    }
  }

  const std::filesystem::path autosave = autosavePath(project);
  if (std::filesystem::is_regular_file(autosave, error) &&
      std::filesystem::last_write_time(autosave, error) > std::filesystem::last_write_time(path, error)) {
    opened.newerAutosave = autosave;
  }
  return opened;
}

}  // namespace piperun
