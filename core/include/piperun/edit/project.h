#pragma once
// `.piperun` project files (docs/FORMATS.md): the scan's path and content hash, every parameter,
// the reviewed network, the network the pipeline produced and the whole edit history.

#include "piperun/edit/edit_session.h"
#include "piperun/pipeline.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace piperun {

constexpr const char* kProjectFormatName = "piperun-project";
constexpr int kProjectFormatVersion = 1;

struct Project {
  std::filesystem::path file;      ///< Where it was last opened from or saved to; empty for a new project.
  std::filesystem::path scanPath;  ///< The scan it reconstructs (absolute); empty when it holds only a network.
  std::string scanHash;            ///< hashFile(scanPath) when the project was made; empty without a scan.
  std::string scanUnits = "m";     ///< The unit of the scan's coordinates (lengthUnitNames()), read as metres.
  PipelineParams params;
  std::array<bool, kStageCount> freshStages{};  ///< Which stages were fresh when the network was made.
  EditSession edits;               ///< The network, its base and the history.
};

/// A project reviewing what `pipeline` made of the scan at `scanPath` (made absolute and hashed),
/// whose coordinates are in `scanUnits`.
Project newProject(const std::filesystem::path& scanPath, const Pipeline& pipeline, const std::string& scanUnits = "m");
/// Records the pipeline's parameters and fresh stages in the project.
void recordPipelineState(Project& project, const Pipeline& pipeline);

/// "fnv1a64:" and the 16 hex digits of the 64-bit FNV-1a hash of the file's bytes. Throws
/// InputError when the file cannot be read.
std::string hashFile(const std::filesystem::path& path);

/// The project as a JSON document.
std::string projectToJson(const Project& project);

/// Writes atomically (a temporary file beside `path`, flushed to disk, renamed over it: a crash
/// or kill leaves the old file or the new one, never a torn file), sets project.file and removes
/// the autosave that the save makes obsolete. Throws OutputError.
void saveProject(const std::filesystem::path& path, Project& project);

/// The sidecar autosaves go to: PROJECT.piperun.autosave, or SCAN.piperun.autosave for a project
/// not saved yet; empty when the project has neither a file nor a scan.
std::filesystem::path autosavePath(const Project& project);
/// Writes the project to autosavePath() atomically, leaving project.file as it is.
void autosaveProject(const Project& project);

struct OpenedProject {
  Project project;
  std::vector<std::string> warnings;  ///< One line each: the scan changed or moved, history dropped...
  /// An autosave sidecar newer than the project file: offer to open it instead (openProject(*newerAutosave)).
  std::optional<std::filesystem::path> newerAutosave;
};

/// Reads a project. A scan whose hash differs, or that is missing, is a warning: the network
/// opens all the same. Throws InputError (file, JSON pointer, what was expected) for a malformed
/// or unsupported document.
OpenedProject openProject(const std::filesystem::path& path);
/// Reads a project as it was saved, looking neither at its scan nor at an autosave (for exports
/// and figures of its reviewed network). Throws InputError as openProject does.
Project readProject(const std::filesystem::path& path);
/// Whether the path names a project file (`.piperun`, any case).
bool isProjectFile(const std::filesystem::path& path);
Project projectFromJson(const std::string& text, const std::filesystem::path& source, std::vector<std::string>* warnings = nullptr);

}  // namespace piperun
