#include "piperun/io/output_path.h"

#include "piperun/error.h"

#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <optional>
#include <string>
#include <system_error>
#include <unistd.h>

namespace piperun {
namespace {

namespace fs = std::filesystem;

/// Why no file can be made at `probe` (which must not exist), or nothing when one can: it is made
/// and removed again. Trying tells what access() does not (as root, or on a disk mounted read-only).
std::optional<std::string> cannotCreate(const fs::path& probe) {
  const int descriptor = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL, 0600);
  if (descriptor < 0) return std::string(std::strerror(errno));
  ::close(descriptor);
  ::unlink(probe.c_str());
  return std::nullopt;
}

/// A name beside `path` that no other run uses: the atomic writer's temporary one.
fs::path probeBeside(const fs::path& path) { return path.string() + ".tmp-" + std::to_string(::getpid()); }

}  // namespace

void requireWritableFile(const fs::path& file) {
  std::error_code error;
  if (fs::is_directory(file, error)) throw OutputError(file, "cannot create: it is a folder");
  const fs::path folder = file.parent_path();
  if (!folder.empty() && !fs::is_directory(folder, error)) {
    throw OutputError(file, fs::exists(folder, error) ? "cannot create: " + folder.string() + " is not a folder"
                                                      : "cannot create: no folder " + folder.string());
  }
  if (const auto reason = cannotCreate(probeBeside(file))) throw OutputError(file, "cannot create: " + *reason);
}

void requireWritableFolder(const fs::path& folder) {
  std::error_code error;
  fs::create_directories(folder, error);
  if (error) throw OutputError(folder, "cannot create the folder: " + error.message());
  if (!fs::is_directory(folder, error)) throw OutputError(folder, "cannot create the folder: it is a file");
  if (const auto reason = cannotCreate(probeBeside(folder / "piperun"))) {
    throw OutputError(folder, "cannot write in the folder: " + *reason);
  }
}

}  // namespace piperun
