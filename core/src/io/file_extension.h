#pragma once
// Names in lower case: a path's extension (".ply"), for choosing a format by file name, and any
// name a user may type in either case.

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <string>

namespace piperun::io {

inline std::string lowercase(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

inline std::string lowerExtension(const std::filesystem::path& path) { return lowercase(path.extension().string()); }

}  // namespace piperun::io
