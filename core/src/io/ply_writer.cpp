// Streaming binary little-endian PLY writer.
//
// The header goes out when the file is opened, with the vertex count as a fixed-width field that
// close() overwrites, so clouds of any size stream through in bounded memory.

#include "piperun/io/point_writer.h"

#include "piperun/error.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace piperun {

namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "the PLY writer stores values in host byte order");

// Wide enough for any 64-bit count. The field is padded with leading zeros: readers parse the
// count as a decimal integer, while trailing spaces draw warnings (PCL) and repeated spaces trip
// readers that split on single spaces.
constexpr std::size_t kCountFieldWidth = 20;
// Records are encoded in blocks of this many points, bounding the writer's buffer.
constexpr std::size_t kBlockPoints = 1u << 16;

class PlyWriter final : public PointWriter {
 public:
  PlyWriter(const std::filesystem::path& path, unsigned attributes, bool doublePositions)
      : path_(path), attributes_(attributes), doublePositions_(doublePositions) {
    file_ = std::fopen(path.c_str(), "wb");
    if (!file_) throw OutputError(path, std::string("cannot create: ") + std::strerror(errno));
    std::setvbuf(file_, nullptr, _IOFBF, 1u << 20);
    writeHeader();
  }

  ~PlyWriter() override {
    try {
      close();
    } catch (...) {
      // Destructors must not throw; callers that care call close() themselves.
    }
  }

  void write(const PointChunk& chunk) override {
    if (!file_) throw std::logic_error(path_.string() + ": write after close");
    if (chunk.empty()) return;
    chunk.checkConsistent();
    if (chunk.attributes() != attributes_) {
      throw std::invalid_argument(path_.string() + ": chunk carries attributes {" + names(chunk.attributes()) +
                                  "}, expected exactly {" + names(attributes_) + "} as declared at open");
    }
    for (std::size_t first = 0; first < chunk.size(); first += kBlockPoints) {
      const std::size_t last = std::min(chunk.size(), first + kBlockPoints);
      block_.clear();
      for (std::size_t i = first; i < last; ++i) encode(chunk, i);
      if (std::fwrite(block_.data(), 1, block_.size(), file_) != block_.size()) failWrite("write failed");
    }
    written_ += chunk.size();
  }

  void close() override {
    if (!file_) return;
    std::FILE* file = file_;
    file_ = nullptr;
    const std::string count = paddedCount(written_);
    const bool patched = std::fflush(file) == 0 && fseeko(file, countOffset_, SEEK_SET) == 0 &&
                         std::fwrite(count.data(), 1, count.size(), file) == count.size() && std::fflush(file) == 0;
    const int patchError = errno;
    const bool closed = std::fclose(file) == 0;
    if (!patched) {
      errno = patchError;
      failWrite("cannot finish the file (vertex count)");
    }
    if (!closed) failWrite("cannot close");
  }

 private:
  static std::string names(unsigned attributes) {
    std::string text;
    for (const char* name : attributeNames(attributes)) text += (text.empty() ? "" : ", ") + std::string(name);
    return text;
  }

  static std::string paddedCount(std::uint64_t count) {
    const std::string digits = std::to_string(count);
    return std::string(kCountFieldWidth - digits.size(), '0') + digits;
  }

  void writeHeader() {
    std::string header =
        "ply\n"
        "format binary_little_endian 1.0\n"
        "comment written by PipeRun\n"
        "element vertex ";
    countOffset_ = static_cast<off_t>(header.size());
    header += paddedCount(0) + "\n";
    const char* positionType = doublePositions_ ? "double" : "float";
    for (const char* axis : {"x", "y", "z"}) header += "property " + std::string(positionType) + " " + axis + "\n";
    if (attributes_ & kNormals) header += "property float nx\nproperty float ny\nproperty float nz\n";
    if (attributes_ & kColors) header += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
    if (attributes_ & kIntensity) header += "property float intensity\n";
    if (attributes_ & kLabels) header += "property int label\n";
    header += "end_header\n";
    if (std::fwrite(header.data(), 1, header.size(), file_) != header.size()) failWrite("write failed");
  }

  template <class T>
  void put(T value) {
    const auto* bytes = reinterpret_cast<const char*>(&value);
    block_.insert(block_.end(), bytes, bytes + sizeof(T));
  }

  void encode(const PointChunk& chunk, std::size_t i) {
    const Eigen::Vector3d& p = chunk.positions[i];
    for (int k = 0; k < 3; ++k) {
      if (doublePositions_) {
        put(p[k]);
      } else {
        put(static_cast<float>(p[k]));
      }
    }
    if (attributes_ & kNormals) {
      for (int k = 0; k < 3; ++k) put(chunk.normals[i][k]);
    }
    if (attributes_ & kColors) {
      for (int k = 0; k < 3; ++k) put(chunk.colors[i][k]);
    }
    if (attributes_ & kIntensity) put(chunk.intensities[i]);
    if (attributes_ & kLabels) put(chunk.labels[i]);
  }

  [[noreturn]] void failWrite(const char* what) const {
    throw OutputError(path_, std::string(what) + ": " + std::strerror(errno));
  }

  std::filesystem::path path_;
  unsigned attributes_;
  bool doublePositions_;
  std::FILE* file_ = nullptr;
  off_t countOffset_ = 0;
  std::uint64_t written_ = 0;
  std::vector<char> block_;
};

}  // namespace

std::unique_ptr<PointWriter> openPlyWriter(const std::filesystem::path& path, unsigned attributes,
                                           bool doublePositions) {
  return std::make_unique<PlyWriter>(path, attributes, doublePositions);
}

}  // namespace piperun
