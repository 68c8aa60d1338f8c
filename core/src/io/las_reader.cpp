// LAS reader (ASPRS LAS 1.0-1.4, point data record formats 0-10, uncompressed), written from the
// public ASPRS specifications.
//
// What is read from each point record:
//   X Y Z        int32 at bytes 0, 4, 8, scaled: world = raw * scale + offset (in double)
//   intensity    uint16 at byte 12, delivered as stored
//   label        the classification: formats 0-5 the low 5 bits of byte 15 (the high 3 bits are the
//                synthetic/key-point/withheld flags), formats 6-10 the whole byte 16
//   colour       formats 2, 3, 5, 7, 8, 10: red, green, blue. The specification asks for 16-bit
//                values (scaled to 8 bits as value >> 8), but many writers store 8-bit values in
//                these fields: when every colour of the first 65,536 records is at most 255, the
//                values are taken as 8-bit (the check CloudCompare and PDAL users rely on).
// GPS time, near infrared, wave packets and extra bytes (a record longer than its format's size)
// are skipped.
//
// Of the variable length records (VLRs) only the projection's are read, for the unit of the
// coordinates (CloudInfo::declaredUnits): the GeoTIFF key directory (user ID "LASF_Projection",
// record 34735), whose ProjLinearUnitsGeoKey (3076) gives an EPSG unit code, and the OGC WKT
// (record 2112), whose PROJCS gives a UNIT with its length in metres. The WKT goes first when the
// header's global encoding says the file's CRS is WKT (LAS 1.4). A VLR that does not fit before the
// point data ends the search: the points do not need it. EVLRs are not read.
//
// The header is checked before anything is allocated: the version, the header size, the point data
// offset, the record length against the format, the scale factors, and the point count against the
// bytes that follow the point data offset.

#include "io/binary_file.h"
#include "io/readers.h"
#include "piperun/io/point_reader.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

namespace piperun::io {

namespace {

// Byte offsets of the public header block fields used here.
constexpr std::uint64_t kVersionMajorAt = 24;
constexpr std::uint64_t kVersionMinorAt = 25;
constexpr std::uint64_t kHeaderSizeAt = 94;
constexpr std::uint64_t kPointDataOffsetAt = 96;
constexpr std::uint64_t kPointFormatAt = 104;
constexpr std::uint64_t kRecordLengthAt = 105;
constexpr std::uint64_t kLegacyPointCountAt = 107;
constexpr std::uint64_t kScaleAt = 131;   // x, y, z scale factors, then x, y, z offsets (doubles)
constexpr std::uint64_t kOffsetAt = 155;
constexpr std::uint64_t kPointCount64At = 247;  // LAS 1.4
constexpr std::uint64_t kGlobalEncodingAt = 6;
constexpr std::uint64_t kVlrCountAt = 100;

constexpr std::uint16_t kWktGlobalEncodingBit = 1u << 4;
constexpr std::size_t kVlrHeaderSize = 54;  // reserved, user ID[16], record ID, length after header, description[32]
constexpr std::uint16_t kGeoKeyDirectoryRecord = 34735;
constexpr std::uint16_t kWktRecord = 2112;
constexpr std::uint16_t kProjLinearUnitsGeoKey = 3076;

// Minimum public header block sizes: LAS 1.0-1.2, 1.3 (adds the waveform start), 1.4 (adds the
// EVLR fields and 64-bit point counts).
constexpr std::uint16_t kHeaderSize12 = 227;
constexpr std::uint16_t kHeaderSize13 = 235;
constexpr std::uint16_t kHeaderSize14 = 375;

constexpr std::uint8_t kCompressionBits = 0xC0;  // LASzip marks compressed formats with bits 7 and 6
constexpr unsigned kLastFormat = 10;
constexpr int kNoColor = -1;

struct RecordFormat {
  std::uint16_t size;  // bytes of the standard record
  int colorAt;         // byte offset of red, green, blue (uint16 each), or kNoColor
};

constexpr std::array<RecordFormat, kLastFormat + 1> kRecordFormats = {{
    {20, kNoColor},  // 0: core
    {28, kNoColor},  // 1: + GPS time
    {26, 20},        // 2: + RGB
    {34, 28},        // 3: + GPS time, RGB
    {57, kNoColor},  // 4: + GPS time, wave packet
    {63, 28},        // 5: + GPS time, RGB, wave packet
    {30, kNoColor},  // 6: extended core with GPS time
    {36, 30},        // 7: + RGB
    {38, 30},        // 8: + RGB, NIR
    {59, kNoColor},  // 9: + wave packet
    {67, 30},        // 10: + RGB, NIR, wave packet
}};

// Bytes of point records decoded per file read.
constexpr std::size_t kBufferBytes = 1u << 20;

std::uint16_t minimumHeaderSize(unsigned minorVersion) {
  if (minorVersion >= 4) return kHeaderSize14;
  if (minorVersion == 3) return kHeaderSize13;
  return kHeaderSize12;
}

bool hasLazExtension(const std::filesystem::path& path) {
  std::string extension = path.extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return extension == ".laz";
}

std::string printable(const unsigned char* bytes, std::size_t n) {
  std::string text;
  for (std::size_t i = 0; i < n; ++i) text += std::isprint(bytes[i]) ? static_cast<char>(bytes[i]) : '?';
  return text;
}

constexpr std::uint64_t kColorDepthProbeRecords = 65536;

struct DeclaredUnits {
  std::string name;    // one of lengthUnitNames()
  std::string source;  // where the file says so
};

/// The unit of an EPSG unit-of-measure code, empty for those no scan unit stands for.
std::string unitOfEpsgCode(unsigned code) {
  switch (code) {
    case 9001: return "m";
    case 9002: return "ft";
    case 9003: return "us-ft";
    case 1033: return "cm";
    case 1025: return "mm";
    default: return "";
  }
}

/// The unit whose length in metres is `metres` (to 1e-8), empty for none.
std::string unitOfLength(double metres) {
  for (const std::string& name : lengthUnitNames()) {
    if (std::abs(*metresPerUnit(name) - metres) <= 1e-8 * metres) return name;
  }
  return "";
}

/// The projected linear unit of a GeoTIFF key directory (unsigned shorts: a 4-short header whose
/// last is the key count, then 4 shorts a key: ID, location, count, value).
std::optional<DeclaredUnits> unitsOfGeoKeys(const std::vector<unsigned char>& directory) {
  const auto shortAt = [&](std::size_t i) { return loadLE<std::uint16_t>(&directory[2 * i]); };
  const std::size_t shorts = directory.size() / 2;
  if (shorts < 4) return std::nullopt;
  for (std::size_t key = 0; key < shortAt(3) && 4 * key + 8 <= shorts; ++key) {
    const std::size_t at = 4 + 4 * key;
    // Location 0: the value is the key's own, not in another tag.
    if (shortAt(at) != kProjLinearUnitsGeoKey || shortAt(at + 1) != 0) continue;
    const unsigned code = shortAt(at + 3);
    const std::string name = unitOfEpsgCode(code);
    if (name.empty()) return std::nullopt;
    return DeclaredUnits{name, "GeoTIFF key ProjLinearUnitsGeoKey = " + std::to_string(code)};
  }
  return std::nullopt;
}

/// The unit of an OGC WKT's PROJCS: its own UNIT["name", metres] (not the GEOGCS's angular one).
std::optional<DeclaredUnits> unitsOfWkt(const std::string& wkt) {
  const std::size_t projected = wkt.find("PROJCS");
  if (projected == std::string::npos) return std::nullopt;
  int depth = 0;
  bool quoted = false;
  for (std::size_t i = projected; i < wkt.size(); ++i) {
    const char c = wkt[i];
    if (c == '"') quoted = !quoted;
    if (quoted) continue;
    if (c == '[' || c == '(') ++depth;
    if (c == ']' || c == ')') {
      if (--depth == 0) break;  // the end of the PROJCS
    }
    if (depth != 1 || wkt.compare(i, 5, "UNIT[") != 0 || (wkt[i - 1] != ',' && !std::isspace(static_cast<unsigned char>(wkt[i - 1])))) {
      continue;
    }
    const std::size_t nameStart = wkt.find('"', i);
    const std::size_t nameEnd = nameStart == std::string::npos ? nameStart : wkt.find('"', nameStart + 1);
    const std::size_t comma = nameEnd == std::string::npos ? nameEnd : wkt.find(',', nameEnd);
    if (comma == std::string::npos) return std::nullopt;
    const double metres = std::strtod(wkt.c_str() + comma + 1, nullptr);
    const std::string name = metres > 0.0 ? unitOfLength(metres) : "";
    if (name.empty()) return std::nullopt;
    return DeclaredUnits{name, "WKT UNIT[" + wkt.substr(nameStart, nameEnd - nameStart + 1) + "]"};
  }
  return std::nullopt;
}

class LasReader final : public PointReader {
 public:
  explicit LasReader(const std::filesystem::path& path) : file_(path) {
    readHeader();
    const std::size_t recordsPerBuffer = std::max<std::size_t>(1, kBufferBytes / recordLength_);
    buffer_.resize(std::min<std::uint64_t>(pointsLeft_, recordsPerBuffer) * recordLength_);
    if (colorAt_ != kNoColor) detectColorDepth();
  }

  const CloudInfo& info() const override { return info_; }

  double progress() const override {
    return file_.size() == 0 ? 1.0 : static_cast<double>(file_.tell()) / static_cast<double>(file_.size());
  }

  std::size_t read(PointChunk& chunk, std::size_t maxPoints) override {
    chunk.clear();
    // pointsLeft_ was checked against the file size, so reserving for it is safe.
    const auto wanted = static_cast<std::size_t>(std::min<std::uint64_t>(maxPoints, pointsLeft_));
    chunk.positions.reserve(wanted);
    chunk.intensities.reserve(wanted);
    chunk.labels.reserve(wanted);
    if (colorAt_ != kNoColor) chunk.colors.reserve(wanted);
    const std::size_t recordsPerBuffer = buffer_.size() / recordLength_;
    while (chunk.size() < wanted) {
      const std::size_t batch = std::min(wanted - chunk.size(), recordsPerBuffer);
      file_.read(buffer_.data(), batch * recordLength_, "point records");
      for (std::size_t i = 0; i < batch; ++i) decode(buffer_.data() + i * recordLength_, chunk);
    }
    pointsLeft_ -= wanted;
    return wanted;
  }

 private:
  void readHeader() {
    std::array<unsigned char, kHeaderSize14> header{};
    file_.read(header.data(), 4, "LAS signature");
    if (std::memcmp(header.data(), "LASF", 4) != 0) {
      file_.failAt(0, "signature '" + printable(header.data(), 4) + "' is not 'LASF', expected a LAS file");
    }
    file_.read(header.data() + 4, kHeaderSize12 - 4, "LAS public header block");

    const auto major = static_cast<unsigned>(header[kVersionMajorAt]);
    const auto minor = static_cast<unsigned>(header[kVersionMinorAt]);
    if (major != 1 || minor > 4) {
      file_.failAt(kVersionMajorAt, "LAS version " + std::to_string(major) + "." + std::to_string(minor) +
                                        ", expected 1.0 to 1.4");
    }
    const std::uint16_t minimumSize = minimumHeaderSize(minor);
    if (minimumSize > kHeaderSize12) {
      file_.read(header.data() + kHeaderSize12, minimumSize - kHeaderSize12, "LAS 1.3/1.4 header fields");
    }
    const auto headerSize = loadLE<std::uint16_t>(&header[kHeaderSizeAt]);
    if (headerSize < minimumSize) {
      file_.failAt(kHeaderSizeAt, "header size " + std::to_string(headerSize) + " is smaller than the " +
                                      std::to_string(minimumSize) + " bytes of a LAS 1." + std::to_string(minor) +
                                      " header");
    }

    const auto pointDataOffset = loadLE<std::uint32_t>(&header[kPointDataOffsetAt]);
    if (pointDataOffset < headerSize) {
      file_.failAt(kPointDataOffsetAt, "point data offset " + std::to_string(pointDataOffset) +
                                           " lies inside the header, expected at least " + std::to_string(headerSize));
    }
    if (pointDataOffset > file_.size()) {
      file_.failAt(kPointDataOffsetAt, "point data offset " + std::to_string(pointDataOffset) +
                                           " lies beyond the end of the file (" + std::to_string(file_.size()) +
                                           " bytes)");
    }

    const std::uint8_t formatByte = header[kPointFormatAt];
    if (formatByte & kCompressionBits) {
      file_.failAt(kPointFormatAt,
                   "point data format " + std::to_string(formatByte) + " has the LAZ compression bit set: " +
                       (hasLazExtension(file_.path()) ? "this .laz file" : "the file") +
                       " is LAZ-compressed; decompress it first, e.g. `laszip -i in.laz -o out.las` or "
                       "`pdal translate in.laz out.las`");
    }
    if (formatByte > kLastFormat) {
      file_.failAt(kPointFormatAt, "point data format " + std::to_string(formatByte) + ", expected 0 to 10");
    }
    format_ = formatByte;
    const RecordFormat& recordFormat = kRecordFormats[format_];
    colorAt_ = recordFormat.colorAt;

    recordLength_ = loadLE<std::uint16_t>(&header[kRecordLengthAt]);
    if (recordLength_ < recordFormat.size) {
      file_.failAt(kRecordLengthAt, "point record length " + std::to_string(recordLength_) +
                                        " is too short for point data format " + std::to_string(format_) +
                                        ", expected at least " + std::to_string(recordFormat.size));
    }

    for (int axis = 0; axis < 3; ++axis) {
      const std::uint64_t scaleAt = kScaleAt + 8 * axis;
      const std::uint64_t offsetAt = kOffsetAt + 8 * axis;
      coordinateScale_[axis] = loadLE<double>(&header[scaleAt]);
      coordinateOffset_[axis] = loadLE<double>(&header[offsetAt]);
      const std::string axisName(1, "xyz"[axis]);
      if (!std::isfinite(coordinateScale_[axis]) || coordinateScale_[axis] == 0.0) {
        file_.failAt(scaleAt, axisName + " scale factor " + std::to_string(coordinateScale_[axis]) +
                                  ", expected a finite non-zero number");
      }
      if (!std::isfinite(coordinateOffset_[axis])) {
        file_.failAt(offsetAt, axisName + " offset " + std::to_string(coordinateOffset_[axis]) +
                                   ", expected a finite number");
      }
    }

    const std::uint64_t pointCountAt = minor >= 4 ? kPointCount64At : kLegacyPointCountAt;
    const std::uint64_t pointCount = minor >= 4 ? loadLE<std::uint64_t>(&header[kPointCount64At])
                                                : loadLE<std::uint32_t>(&header[kLegacyPointCountAt]);
    const std::uint64_t bytesAvailable = file_.size() - pointDataOffset;
    if (pointCount > bytesAvailable / recordLength_) {
      file_.failAt(pointCountAt, "point count " + std::to_string(pointCount) + " with " +
                                     std::to_string(recordLength_) + "-byte records does not fit in the " +
                                     std::to_string(bytesAvailable) + " bytes after the point data offset " +
                                     std::to_string(pointDataOffset));
    }
    pointsLeft_ = pointCount;
    const bool wktFirst = loadLE<std::uint16_t>(&header[kGlobalEncodingAt]) & kWktGlobalEncodingBit;
    if (const auto units = readDeclaredUnits(headerSize, loadLE<std::uint32_t>(&header[kVlrCountAt]), pointDataOffset,
                                             wktFirst)) {
      info_.declaredUnits = units->name;
      info_.declaredUnitsSource = units->source;
    }
    file_.seek(pointDataOffset, "point data");

    info_.format = "LAS " + std::to_string(major) + "." + std::to_string(minor) + " format " + std::to_string(format_);
    info_.fields = {"X", "Y", "Z", "intensity", "classification"};
    info_.attributes = kIntensity | kLabels;
    if (colorAt_ != kNoColor) {
      info_.fields.insert(info_.fields.end(), {"red", "green", "blue"});
      info_.attributes |= kColors;
    }
    info_.declaredPoints = pointCount;
  }

  /// The unit of the coordinates from the projection VLRs between the header and the point data.
  std::optional<DeclaredUnits> readDeclaredUnits(std::uint64_t at, std::uint32_t vlrCount, std::uint64_t pointDataOffset,
                                                 bool wktFirst) {
    std::vector<unsigned char> geoKeys, wkt;
    std::array<unsigned char, kVlrHeaderSize> vlr{};
    for (std::uint32_t v = 0; v < vlrCount && at + kVlrHeaderSize <= pointDataOffset; ++v) {
      file_.seek(at, "variable length record");
      file_.read(vlr.data(), vlr.size(), "variable length record header");
      const std::uint64_t payloadAt = at + kVlrHeaderSize;
      const auto length = loadLE<std::uint16_t>(&vlr[20]);
      if (payloadAt + length > pointDataOffset) break;
      const std::string user(reinterpret_cast<const char*>(&vlr[2]), strnlen(reinterpret_cast<const char*>(&vlr[2]), 16));
      const auto record = loadLE<std::uint16_t>(&vlr[18]);
      if (user == "LASF_Projection" && (record == kGeoKeyDirectoryRecord || record == kWktRecord)) {
        std::vector<unsigned char>& payload = record == kWktRecord ? wkt : geoKeys;
        payload.resize(length);
        file_.read(payload.data(), length, "projection record");
      }
      at = payloadAt + length;
    }
    const auto fromWkt = [&] { return unitsOfWkt(std::string(wkt.begin(), wkt.end())); };
    if (wktFirst) {
      if (auto units = fromWkt()) return units;
      return unitsOfGeoKeys(geoKeys);
    }
    if (auto units = unitsOfGeoKeys(geoKeys)) return units;
    return fromWkt();
  }

  // Reads the first records ahead, then returns to the start of the point data.
  void detectColorDepth() {
    const std::uint64_t start = file_.tell();
    const auto probe = std::min<std::uint64_t>({pointsLeft_, kColorDepthProbeRecords, buffer_.size() / recordLength_});
    file_.read(buffer_.data(), static_cast<std::size_t>(probe * recordLength_), "point records");
    bool eightBit = true;
    for (std::uint64_t i = 0; i < probe && eightBit; ++i) {
      const unsigned char* rgb = buffer_.data() + i * recordLength_ + colorAt_;
      for (int k = 0; k < 3; ++k) eightBit = eightBit && loadLE<std::uint16_t>(rgb + 2 * k) <= 255;
    }
    colorShift_ = eightBit && probe > 0 ? 0 : 8;
    file_.seek(start, "point data");
  }

  std::uint8_t color(const unsigned char* bytes) const {
    return static_cast<std::uint8_t>(std::min<unsigned>(255u, loadLE<std::uint16_t>(bytes) >> colorShift_));
  }

  void decode(const unsigned char* record, PointChunk& chunk) const {
    chunk.positions.emplace_back(loadLE<std::int32_t>(record) * coordinateScale_[0] + coordinateOffset_[0],
                                 loadLE<std::int32_t>(record + 4) * coordinateScale_[1] + coordinateOffset_[1],
                                 loadLE<std::int32_t>(record + 8) * coordinateScale_[2] + coordinateOffset_[2]);
    chunk.intensities.push_back(static_cast<float>(loadLE<std::uint16_t>(record + 12)));
    chunk.labels.push_back(format_ <= 5 ? record[15] & 0x1F : record[16]);
    if (colorAt_ != kNoColor) {
      const unsigned char* rgb = record + colorAt_;
      chunk.colors.emplace_back(color(rgb), color(rgb + 2), color(rgb + 4));
    }
  }

  BinaryFile file_;
  CloudInfo info_;
  unsigned format_ = 0;
  int colorAt_ = kNoColor;
  unsigned colorShift_ = 8;
  std::uint16_t recordLength_ = 0;
  std::array<double, 3> coordinateScale_{};
  std::array<double, 3> coordinateOffset_{};
  std::uint64_t pointsLeft_ = 0;
  std::vector<unsigned char> buffer_;
};

}  // namespace

std::unique_ptr<PointReader> openLasReader(const std::filesystem::path& path) {
  return std::make_unique<LasReader>(path);
}

}  // namespace piperun::io
