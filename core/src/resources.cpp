#include "piperun/resources.h"

#include "piperun/error.h"

#include <cstdlib>
#include <vector>

namespace piperun {

namespace {

std::vector<std::filesystem::path> resourceFolders() {
  std::vector<std::filesystem::path> folders;
  if (const char* configured = std::getenv("PIPERUN_RESOURCE_DIR"); configured && *configured) folders.emplace_back(configured);
  std::error_code error;
  const std::filesystem::path executable = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error) folders.push_back(executable.parent_path().parent_path() / "share" / "piperun");
  folders.emplace_back(PIPERUN_INSTALL_RESOURCE_DIR);
  folders.emplace_back(PIPERUN_SOURCE_RESOURCE_DIR);
  return folders;
}

}  // namespace

std::filesystem::path findResource(const std::string& name) {
  std::string searched;
  for (const auto& folder : resourceFolders()) {
    const std::filesystem::path candidate = folder / name;
    std::error_code error;
    if (std::filesystem::is_regular_file(candidate, error)) return candidate;
    searched += (searched.empty() ? "" : ", ") + folder.string();
  }
  throw InputError(name, "", "shipped data file not found in " + searched + " (set PIPERUN_RESOURCE_DIR)");
}

}  // namespace piperun
