#pragma once
// Whole-file writes that never leave a half-written file behind.

#include <filesystem>
#include <string>

namespace piperun::io {

/// Writes `bytes` to a temporary file beside `path`, flushes it to disk and renames it over `path`,
/// so readers see either the old file or the complete new one. Throws OutputError naming `path`.
void writeFileAtomically(const std::filesystem::path& path, const std::string& bytes);

}  // namespace piperun::io
