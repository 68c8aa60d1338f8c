#pragma once
// Helpers shared by the core tests.

#include "piperun/pipe_network.h"

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

namespace piperun::test {

/// A fresh directory under the system temp folder, removed with its contents on destruction.
class TempDir {
 public:
  TempDir() {
    std::random_device device;
    const auto name = "piperun-test-" + std::to_string(device()) + "-" + std::to_string(device());
    path_ = std::filesystem::temp_directory_path() / name;
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

inline void writeFile(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

inline std::string readFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// A pipe of `radius` from `start` to `end`, confidence 0.9, in run `run` (-1: none).
inline Pipe makePipe(int id, double radius, const Eigen::Vector3d& start, const Eigen::Vector3d& end, int run = -1,
                     PipeStatus status = PipeStatus::Accepted) {
  Pipe pipe;
  pipe.id = id;
  pipe.radius = radius;
  pipe.start = start;
  pipe.end = end;
  pipe.runId = run;
  pipe.status = status;
  pipe.confidence = 0.9;
  return pipe;
}

/// Folder holding the real scans (../shared/data/real beside the repository).
inline std::filesystem::path realDataDir() { return PIPERUN_REAL_DATA_DIR; }

}  // namespace piperun::test
