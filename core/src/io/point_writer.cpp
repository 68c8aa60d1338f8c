#include "piperun/io/point_writer.h"

#include "io/file_extension.h"
#include "piperun/error.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>

namespace piperun {

using io::lowerExtension;

namespace {

// Text output: one point per line, shortest round-trip representation of every number.
class TextPointWriter final : public PointWriter {
 public:
  TextPointWriter(const std::filesystem::path& path, unsigned attributes, char separator, bool header)
      : path_(path), attributes_(attributes), separator_(separator) {
    file_ = std::fopen(path.c_str(), "wb");
    if (!file_) throw OutputError(path, std::string("cannot create: ") + std::strerror(errno));
    std::setvbuf(file_, nullptr, _IOFBF, 1u << 20);
    if (header) writeHeader();
  }

  ~TextPointWriter() override {
    try {
      close();
    } catch (...) {
      // Destructors must not throw; callers that care call close() themselves.
    }
  }

  void write(const PointChunk& chunk) override {
    chunk.checkConsistent();
    if ((chunk.attributes() & attributes_) != attributes_) {
      throw std::invalid_argument(path_.string() + ": chunk lacks attributes the writer was opened with");
    }
    if (!file_) throw std::logic_error(path_.string() + ": write after close");
    std::string line;
    for (std::size_t i = 0; i < chunk.size(); ++i) {
      line.clear();
      append(line, chunk.positions[i].x(), false);
      append(line, chunk.positions[i].y(), true);
      append(line, chunk.positions[i].z(), true);
      if (attributes_ & kNormals) {
        for (int k = 0; k < 3; ++k) append(line, chunk.normals[i][k], true);
      }
      if (attributes_ & kColors) {
        for (int k = 0; k < 3; ++k) append(line, static_cast<int>(chunk.colors[i][k]), true);
      }
      if (attributes_ & kIntensity) append(line, chunk.intensities[i], true);
      if (attributes_ & kLabels) append(line, chunk.labels[i], true);
      line.push_back('\n');
      if (std::fwrite(line.data(), 1, line.size(), file_) != line.size()) failWrite();
    }
  }

  void close() override {
    if (!file_) return;
    const bool flushed = std::fflush(file_) == 0;
    const bool closed = std::fclose(file_) == 0;
    file_ = nullptr;
    if (!flushed || !closed) failWrite();
  }

 private:
  void writeHeader() {
    std::string line = "x" + std::string(1, separator_) + "y" + separator_ + "z";
    const auto add = [&](std::initializer_list<const char*> names) {
      for (const char* name : names) line += separator_ + std::string(name);
    };
    if (attributes_ & kNormals) add({"nx", "ny", "nz"});
    if (attributes_ & kColors) add({"red", "green", "blue"});
    if (attributes_ & kIntensity) add({"intensity"});
    if (attributes_ & kLabels) add({"label"});
    line.push_back('\n');
    if (std::fwrite(line.data(), 1, line.size(), file_) != line.size()) failWrite();
  }

  template <class T>
  void append(std::string& line, T value, bool separated) {
    if (separated) line.push_back(separator_);
    char buffer[32];
    const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
    line.append(buffer, result.ptr);
  }

  [[noreturn]] void failWrite() const {
    throw OutputError(path_, std::string("write failed: ") + std::strerror(errno));
  }

  std::filesystem::path path_;
  unsigned attributes_;
  char separator_;
  std::FILE* file_ = nullptr;
};

}  // namespace

std::unique_ptr<PointWriter> openTextWriter(const std::filesystem::path& path, unsigned attributes) {
  const bool csv = lowerExtension(path) == ".csv";
  // A header line names the columns whenever there is more than x y z (and always in CSV),
  // so the XYZ reader maps them back without guessing.
  const bool header = csv || attributes != kNoAttributes;
  return std::make_unique<TextPointWriter>(path, attributes, csv ? ',' : ' ', header);
}

std::unique_ptr<PointWriter> openPointWriter(const std::filesystem::path& path, unsigned attributes,
                                             const PointWriteOptions& options) {
  const std::string extension = lowerExtension(path);
  const unsigned kept = attributes & options.attributes;
  if (extension == ".ply") return openPlyWriter(path, kept, options.doublePositions);
  if (extension == ".xyz" || extension == ".txt" || extension == ".csv" || extension == ".asc") {
    return openTextWriter(path, kept);
  }
  throw std::invalid_argument(path.string() + ": cannot write '" + extension +
                              "' files; point output formats are .ply, .xyz, .txt, .csv and .asc");
}

void writePointCloud(const std::filesystem::path& path, const PointCloud& cloud, const PointWriteOptions& options) {
  PointWriteOptions effective = options;
  // Far from (0, 0, 0) float world coordinates would lose precision: keep doubles.
  if (cloud.origin.cwiseAbs().maxCoeff() > 0.0) effective.doublePositions = true;
  const unsigned kept = cloud.attributes() & options.attributes;
  auto writer = openPointWriter(path, kept, effective);
  constexpr std::size_t kChunkPoints = 1u << 20;
  PointChunk chunk;
  for (std::size_t first = 0; first < cloud.size(); first += kChunkPoints) {
    cloud.copyTo(chunk, first, std::min(kChunkPoints, cloud.size() - first));
    chunk.keepAttributes(kept);
    writer->write(chunk);
  }
  writer->close();
}

}  // namespace piperun
