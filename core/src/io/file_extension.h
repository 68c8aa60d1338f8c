#pragma once
// The extension of a path in lower case (".ply"), for choosing a format by file name.

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <string>

namespace piperun::io {

inline std::string lowerExtension(const std::filesystem::path& path) {
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension;
}

}  // namespace piperun::io
