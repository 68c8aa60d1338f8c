#pragma once
// Checks that a run's outputs can be written, made before the run: a long reconstruction should
// fail on a mistyped folder at once, not after minutes of work.

#include <filesystem>

namespace piperun {

/// Throws OutputError naming `file` when no file can be written there: its folder does not exist,
/// cannot be written in, or `file` is itself a folder. Nothing is left behind.
void requireWritableFile(const std::filesystem::path& file);

/// Makes `folder` (with its parents) if it does not exist; throws OutputError naming it when that
/// fails or no file can be written in it.
void requireWritableFolder(const std::filesystem::path& folder);

}  // namespace piperun
