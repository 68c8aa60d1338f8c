#pragma once
// A small E57 (ASTM E2807) writer for building test files, written from the standard: paged file
// with CRC-32C checksums, XML section, one CompressedVector binary section per scan with
// bit-packed bytestreams split over data packets. Test-only: it holds the whole file in memory.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace piperun::test {

/// One field of a scan's prototype with its value in every record.
struct E57TestField {
  enum class Type { Float32, Float64, ScaledInteger, Integer };

  std::string name;  // e.g. "cartesianX", "colorRed", "rowIndex", "nor:normalX" (the file declares the nor prefix)
  Type type = Type::Float64;
  std::int64_t minimum = 0;  // Integer, ScaledInteger: range of the raw integers
  std::int64_t maximum = 0;
  double scale = 1.0;  // ScaledInteger: value = raw * scale + offset
  double offset = 0.0;
  std::optional<double> floatMinimum;  // Float: optional declared bounds
  std::optional<double> floatMaximum;
  /// One value per record. Integer: the integer itself; ScaledInteger: the value in its units,
  /// stored as raw = round((value - offset) / scale).
  std::vector<double> values;
};

struct E57TestScan {
  std::string name = "scan";
  std::optional<Eigen::Quaterniond> rotation;  // pose, written when either part is set
  std::optional<Eigen::Vector3d> translation;
  std::vector<E57TestField> fields;
  /// The recordCount written into the XML; by default the number of values of the fields.
  std::optional<std::uint64_t> declaredRecordCount;
};

struct E57TestOptions {
  std::uint64_t pageSize = 1024;
  std::size_t maxPacketBytes = 65536;  // data packets are at most this long; a multiple of 4
  bool emptyAndIndexPackets =
      false;  // an empty packet after the first data packet and an index packet at the end of each section
  std::function<std::string(const std::string&)> editXml;  // rewrites the XML text before it is laid out
};

/// Where the writer put things, as physical offsets, for tests that damage one structure.
struct E57TestLayout {
  struct Section {
    std::uint64_t header = 0;
    std::vector<std::uint64_t> dataPackets;
  };
  std::uint64_t xmlOffset = 0;
  std::vector<Section> sections;
};

/// Writes `scans` as an E57 file; every field's values list must have the scan's record count.
E57TestLayout writeE57(const std::filesystem::path& path, const std::vector<E57TestScan>& scans,
                       const E57TestOptions& options = {});

/// Overwrites bytes of a written file at a physical offset, continuing across page checksums, and
/// recomputes the checksums of the pages touched, so that only the structure under test is wrong.
void patchE57(const std::filesystem::path& path, std::uint64_t physicalOffset, const std::string& bytes,
              std::uint64_t pageSize = 1024);

/// Little-endian bytes of an unsigned integer of `size` bytes, for patchE57.
std::string littleEndianBytes(std::uint64_t value, std::size_t size);

}  // namespace piperun::test
