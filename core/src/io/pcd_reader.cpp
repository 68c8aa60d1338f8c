// PCD (Point Cloud Library) reader: header versions 0.5 to 0.7, DATA ascii, binary and
// binary_compressed (LZF). Written from the format description rather than with PCL's loader,
// which holds the whole file twice.

#include "free_storage.h"
#include "io/binary_file.h"
#include "io/readers.h"
#include "io/text_lines.h"
#include "piperun/error.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace piperun::io {

namespace {

/// What a field contributes to a point: an index into the values of one record.
enum Role : int {
  kIgnored = -1,
  kX,
  kY,
  kZ,
  kNormalX,
  kNormalY,
  kNormalZ,
  kPackedColor,
  kIntensityRole,  // (kIntensity is the PointAttribute bit)
  kLabel,
  kRoleCount
};

Role roleOf(std::string_view name) {
  if (name == "x") return kX;
  if (name == "y") return kY;
  if (name == "z") return kZ;
  if (name == "normal_x") return kNormalX;
  if (name == "normal_y") return kNormalY;
  if (name == "normal_z") return kNormalZ;
  if (name == "rgb" || name == "rgba") return kPackedColor;
  if (name == "intensity") return kIntensityRole;
  if (name == "label") return kLabel;
  return kIgnored;
}

struct Field {
  std::string name;
  std::size_t size = 4;    // bytes of one element
  char type = 'F';         // F (floating point), U (unsigned) or I (signed)
  std::size_t count = 1;   // elements (fpfh descriptors have 33)
  std::size_t offset = 0;  // within a row-major record
  Role role = kIgnored;

  std::size_t bytes() const { return size * count; }
};

enum class DataKind { Ascii, Binary, BinaryCompressed };

struct Header {
  std::vector<Field> fields;
  std::size_t recordBytes = 0;
  std::size_t valuesPerRecord = 0;  // ascii values on a line
  std::uint64_t width = 0;
  std::uint64_t height = 0;
  std::uint64_t points = 0;
  DataKind data = DataKind::Ascii;
  std::string dataName;
  std::string version;  // as written, empty when the header has no VERSION line
  std::uint64_t dataOffset = 0;
  unsigned attributes = kNoAttributes;
};

/// Parses the header line by line up to and including DATA; reports problems at their line.
class HeaderParser {
 public:
  explicit HeaderParser(TextLines& lines) : lines_(lines) {}

  Header parse() {
    std::string_view line;
    for (;;) {
      if (!lines_.next(line)) {
        throw InputError(lines_.path(), lineLocation(lines_.lineNumber() + 1),
                         "unexpected end of file in the header, expected a DATA line");
      }
      const auto tokens = splitWords(line);
      if (tokens.empty() || tokens[0].front() == '#') continue;
      const std::string_view keyword = tokens[0];
      const std::vector<std::string_view> values(tokens.begin() + 1, tokens.end());
      if (keyword == "VERSION") {
        parseVersion(values);
      } else if (keyword == "FIELDS" || keyword == "COLUMNS") {
        parseFields(values);
      } else if (keyword == "SIZE") {
        parseSizes(values);
      } else if (keyword == "TYPE") {
        parseTypes(values);
      } else if (keyword == "COUNT") {
        parseCounts(values);
      } else if (keyword == "WIDTH") {
        width_ = single(keyword, values);
      } else if (keyword == "HEIGHT") {
        height_ = single(keyword, values);
      } else if (keyword == "POINTS") {
        points_ = single(keyword, values);
        pointsLine_ = lines_.lineNumber();
      } else if (keyword == "VIEWPOINT") {
        parseViewpoint(values);
      } else if (keyword == "DATA") {
        parseData(values);
        break;
      } else {
        lines_.fail("found " + excerpt(line) +
                    ", expected a header line (VERSION, FIELDS, SIZE, TYPE, COUNT, WIDTH, HEIGHT, VIEWPOINT, "
                    "POINTS) or DATA");
      }
    }
    header_.dataOffset = lines_.bytesConsumed();
    finish();
    return std::move(header_);
  }

 private:
  std::uint64_t unsignedValue(std::string_view keyword, std::string_view text) const {
    std::int64_t value = 0;
    if (!parseNumber(text, value) || value < 0) {
      lines_.fail(std::string(keyword) + " value " + excerpt(text) + " is not a non-negative integer");
    }
    return static_cast<std::uint64_t>(value);
  }

  std::uint64_t single(std::string_view keyword, const std::vector<std::string_view>& values) const {
    if (values.size() != 1) lines_.fail("expected '" + std::string(keyword) + " <count>'");
    return unsignedValue(keyword, values[0]);
  }

  void parseVersion(const std::vector<std::string_view>& values) {
    double version = 0.0;
    if (values.size() != 1 || !parseNumber(values[0], version) || version < 0.45 || version > 0.75) {
      lines_.fail("unsupported PCD version " + excerpt(values.empty() ? "" : values[0]) + ", expected 0.5 to 0.7");
    }
    header_.version = std::string(values[0]);
  }

  void parseFields(const std::vector<std::string_view>& values) {
    if (values.empty()) lines_.fail("FIELDS names no field, expected at least x y z");
    header_.fields.clear();
    for (const auto& name : values) header_.fields.push_back(Field{std::string(name)});
    fieldsLine_ = lines_.lineNumber();
  }

  /// A per-field line (SIZE, TYPE, COUNT) must come after FIELDS and name one value per field.
  void checkPerField(std::string_view keyword, const std::vector<std::string_view>& values) const {
    if (fieldsLine_ == 0) lines_.fail(std::string(keyword) + " before FIELDS, expected FIELDS first");
    if (values.size() != header_.fields.size()) {
      lines_.fail(std::string(keyword) + " has " + std::to_string(values.size()) + " entries, expected " +
                  std::to_string(header_.fields.size()) + " (one per field of FIELDS)");
    }
  }

  void parseSizes(const std::vector<std::string_view>& values) {
    checkPerField("SIZE", values);
    for (std::size_t i = 0; i < values.size(); ++i) {
      const auto size = unsignedValue("SIZE", values[i]);
      if (size != 1 && size != 2 && size != 4 && size != 8) {
        lines_.fail("SIZE " + excerpt(values[i]) + " of field " + header_.fields[i].name + ", expected 1, 2, 4 or 8");
      }
      header_.fields[i].size = static_cast<std::size_t>(size);
    }
    sizesLine_ = lines_.lineNumber();
  }

  void parseTypes(const std::vector<std::string_view>& values) {
    checkPerField("TYPE", values);
    for (std::size_t i = 0; i < values.size(); ++i) {
      if (values[i] != "F" && values[i] != "U" && values[i] != "I") {
        lines_.fail("TYPE " + excerpt(values[i]) + " of field " + header_.fields[i].name + ", expected F, U or I");
      }
      header_.fields[i].type = values[i][0];
    }
    typesLine_ = lines_.lineNumber();
  }

  void parseCounts(const std::vector<std::string_view>& values) {
    checkPerField("COUNT", values);
    for (std::size_t i = 0; i < values.size(); ++i) {
      const auto count = unsignedValue("COUNT", values[i]);
      // Descriptors reach a few hundred elements; far beyond is a corrupt header.
      constexpr std::uint64_t kMaxCount = 1u << 20;
      if (count == 0 || count > kMaxCount) {
        lines_.fail("COUNT " + excerpt(values[i]) + " of field " + header_.fields[i].name + ", expected 1 to " +
                    std::to_string(kMaxCount));
      }
      header_.fields[i].count = static_cast<std::size_t>(count);
    }
    countsLine_ = lines_.lineNumber();
  }

  // The viewpoint is the sensor's pose. Like PCL's loader (and the clouds PCL users exchange),
  // points are returned as stored, in the frame they were saved in; the line is only validated.
  void parseViewpoint(const std::vector<std::string_view>& values) {
    std::array<double, 7> pose{};
    if (values.size() != pose.size()) lines_.fail("expected 'VIEWPOINT tx ty tz qw qx qy qz'");
    for (std::size_t i = 0; i < pose.size(); ++i) {
      if (!parseNumber(values[i], pose[i]) || !std::isfinite(pose[i])) {
        lines_.fail("VIEWPOINT value " + excerpt(values[i]) + " is not a finite number");
      }
    }
    const Eigen::Quaterniond rotation(pose[3], pose[4], pose[5], pose[6]);
    if (rotation.norm() < 1e-12) lines_.fail("VIEWPOINT quaternion is zero, expected a rotation (w x y z)");
  }

  void parseData(const std::vector<std::string_view>& values) {
    if (values.size() == 1 && values[0] == "ascii") {
      header_.data = DataKind::Ascii;
    } else if (values.size() == 1 && values[0] == "binary") {
      header_.data = DataKind::Binary;
    } else if (values.size() == 1 && values[0] == "binary_compressed") {
      header_.data = DataKind::BinaryCompressed;
    } else {
      lines_.fail("unknown DATA " + excerpt(values.empty() ? "" : values[0]) +
                  ", expected ascii, binary or binary_compressed");
    }
    header_.dataName = std::string(values[0]);
  }

  [[noreturn]] void failAtLine(std::uint64_t line, const std::string& message) const {
    throw InputError(lines_.path(), lineLocation(line), message);
  }

  void finish() {
    const std::uint64_t dataLine = lines_.lineNumber();
    if (fieldsLine_ == 0) failAtLine(dataLine, "no FIELDS line before DATA, expected the field names");
    if (sizesLine_ == 0) failAtLine(dataLine, "no SIZE line before DATA, expected one size per field");
    if (typesLine_ == 0) failAtLine(dataLine, "no TYPE line before DATA, expected one type per field");

    std::array<bool, kRoleCount> taken{};
    for (auto& field : header_.fields) {
      if (field.type == 'F' && field.size != 4 && field.size != 8) {
        failAtLine(typesLine_, "field " + field.name + " has TYPE F with SIZE " + std::to_string(field.size) +
                                   ", expected SIZE 4 or 8");
      }
      field.offset = header_.recordBytes;
      header_.recordBytes += field.bytes();
      header_.valuesPerRecord += field.count;
      const Role role = roleOf(field.name);
      if (role == kIgnored || taken[role]) continue;
      if (field.count != 1) {
        failAtLine(countsLine_, "field " + field.name + " has COUNT " + std::to_string(field.count) + ", expected 1");
      }
      if (role == kPackedColor && field.size != 4) {
        failAtLine(sizesLine_, "field " + field.name + " has SIZE " + std::to_string(field.size) +
                                   ", expected 4 (packed 0x00RRGGBB)");
      }
      field.role = role;
      taken[role] = true;
    }
    for (const char* axis : {"x", "y", "z"}) {
      if (!taken[roleOf(axis)]) {
        failAtLine(fieldsLine_, std::string("no field '") + axis + "', expected x, y and z");
      }
    }
    if (taken[kNormalX] && taken[kNormalY] && taken[kNormalZ]) {
      header_.attributes |= kNormals;
    } else {
      for (auto& field : header_.fields) {
        if (field.role >= kNormalX && field.role <= kNormalZ) field.role = kIgnored;
      }
    }
    if (taken[kPackedColor]) header_.attributes |= kColors;
    if (taken[kIntensityRole]) header_.attributes |= kIntensity;
    if (taken[kLabel]) header_.attributes |= kLabels;

    // v0.5 files may lack WIDTH/HEIGHT, others POINTS: each can be derived from the rest.
    if (!height_) height_ = 1;
    if (!width_ && !points_) failAtLine(dataLine, "neither WIDTH nor POINTS before DATA, expected the point count");
    if (!width_) width_ = *points_ / std::max<std::uint64_t>(1, *height_);
    const bool productOverflows = *height_ != 0 && *width_ > std::numeric_limits<std::uint64_t>::max() / *height_;
    const std::uint64_t product = productOverflows ? 0 : *width_ * *height_;
    if (!points_) {
      if (productOverflows) failAtLine(dataLine, "WIDTH x HEIGHT overflows, expected a sensible point count");
      points_ = product;
      pointsLine_ = dataLine;
    }
    if (productOverflows || product != *points_) {
      failAtLine(pointsLine_, "POINTS " + std::to_string(*points_) + " differs from WIDTH x HEIGHT = " +
                                  std::to_string(*width_) + " x " + std::to_string(*height_) + ", expected equal");
    }
    header_.width = *width_;
    header_.height = *height_;
    header_.points = *points_;
  }

  TextLines& lines_;
  Header header_;
  std::optional<std::uint64_t> width_;
  std::optional<std::uint64_t> height_;
  std::optional<std::uint64_t> points_;
  std::uint64_t pointsLine_ = 0;
  std::uint64_t fieldsLine_ = 0;
  std::uint64_t sizesLine_ = 0;
  std::uint64_t typesLine_ = 0;
  std::uint64_t countsLine_ = 0;
};

/// A field element as a double.
double decodeValue(const Field& field, const unsigned char* bytes) {
  switch (field.type) {
    case 'F': return field.size == 4 ? double(loadLE<float>(bytes)) : loadLE<double>(bytes);
    case 'U':
      switch (field.size) {
        case 1: return bytes[0];
        case 2: return loadLE<std::uint16_t>(bytes);
        case 4: return loadLE<std::uint32_t>(bytes);
        default: return double(loadLE<std::uint64_t>(bytes));
      }
    default:
      switch (field.size) {
        case 1: return static_cast<std::int8_t>(bytes[0]);
        case 2: return loadLE<std::int16_t>(bytes);
        case 4: return loadLE<std::int32_t>(bytes);
        default: return double(loadLE<std::int64_t>(bytes));
      }
  }
}

std::int32_t toLabel(double value) {
  if (std::isnan(value)) return -1;
  return static_cast<std::int32_t>(std::clamp(value, double(std::numeric_limits<std::int32_t>::min()),
                                              double(std::numeric_limits<std::int32_t>::max())));
}

// One LZF back-reference (3 bytes) expands to at most 264 bytes: no stream can grow beyond this.
constexpr std::uint64_t kMaxLzfExpansion = 88;

/// Decompresses an LZF stream (liblzf's format) into exactly `outputSize` bytes. Every literal
/// run and back-reference is checked against both buffers, so a corrupt stream throws instead
/// of reading or writing out of bounds. `fileOffset` is where the stream starts, for messages.
void decompressLzf(const std::vector<unsigned char>& input, std::vector<unsigned char>& output,
                   const std::filesystem::path& path, std::uint64_t fileOffset) {
  const std::size_t inputSize = input.size();
  const std::size_t outputSize = output.size();
  std::size_t in = 0;
  std::size_t out = 0;
  const auto fail = [&](std::size_t at, const std::string& message) {
    throw InputError(path, byteLocation(fileOffset + at), "corrupt LZF data: " + message);
  };
  while (in < inputSize) {
    const std::size_t controlAt = in;
    const unsigned control = input[in++];
    if (control < 32) {
      const std::size_t length = control + 1;
      if (length > inputSize - in) {
        fail(controlAt, "literal run of " + std::to_string(length) + " bytes passes the end of the compressed data");
      }
      if (length > outputSize - out) {
        fail(controlAt, "literal run passes the declared uncompressed size " + std::to_string(outputSize));
      }
      std::copy_n(input.begin() + static_cast<std::ptrdiff_t>(in), length,
                  output.begin() + static_cast<std::ptrdiff_t>(out));
      in += length;
      out += length;
      continue;
    }
    std::size_t length = control >> 5;
    if (length == 7) {
      if (in >= inputSize) fail(controlAt, "back-reference cut off by the end of the compressed data");
      length += input[in++];
    }
    if (in >= inputSize) fail(controlAt, "back-reference cut off by the end of the compressed data");
    const std::size_t distance = ((control & 0x1fu) << 8) + input[in++] + 1;
    length += 2;
    if (distance > out) {
      fail(controlAt, "back-reference " + std::to_string(distance) + " bytes back from output byte " +
                          std::to_string(out) + ", expected at most " + std::to_string(out));
    }
    if (length > outputSize - out) {
      fail(controlAt, "back-reference passes the declared uncompressed size " + std::to_string(outputSize));
    }
    // Byte by byte: a reference may overlap the bytes it produces (repeating a pattern).
    for (std::size_t k = 0; k < length; ++k, ++out) output[out] = output[out - distance];
  }
  if (out != outputSize) {
    fail(inputSize, "stream ends after " + std::to_string(out) + " bytes, expected " + std::to_string(outputSize));
  }
}

class PcdReader final : public PointReader {
 public:
  explicit PcdReader(const std::filesystem::path& path) : path_(path), lines_(path) {
    header_ = HeaderParser(lines_).parse();
    info_.format = "PCD " + (header_.version.empty() ? "" : "v" + header_.version + " ") + header_.dataName;
    for (const auto& field : header_.fields) info_.fields.push_back(field.name);
    info_.declaredPoints = header_.points;
    info_.attributes = header_.attributes;

    const std::uint64_t fileSize = lines_.fileSize();
    const std::uint64_t available = fileSize - std::min(fileSize, header_.dataOffset);
    switch (header_.data) {
      case DataKind::Ascii: {
        // Shortest possible line: one character per value, each followed by a separator.
        const std::uint64_t minimumLine = 2 * header_.valuesPerRecord;
        if (header_.points > (available + 1) / minimumLine) {
          failAtData("POINTS " + std::to_string(header_.points) + " ascii lines of " +
                     std::to_string(header_.valuesPerRecord) + " values cannot fit in the " +
                     std::to_string(available) + " bytes after the header (truncated file or wrong count)");
        }
        if (header_.points > 0) fields_.resize(header_.valuesPerRecord + 1);  // bounded by the check above
        break;
      }
      case DataKind::Binary:
        if (header_.points > available / header_.recordBytes) {
          failAtData("POINTS " + std::to_string(header_.points) + " records of " + std::to_string(header_.recordBytes) +
                     " bytes need more than the " + std::to_string(available) +
                     " bytes after the header (truncated file or wrong count)");
        }
        binary_.emplace(path);
        binary_->seek(header_.dataOffset, "the PCD binary data");
        break;
      case DataKind::BinaryCompressed:
        if (header_.points > 0) loadCompressed(path);
        break;
    }
  }

  const CloudInfo& info() const override { return info_; }

  std::size_t read(PointChunk& chunk, std::size_t maxPoints) override {
    chunk.clear();
    const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(maxPoints, header_.points - delivered_));
    if (n == 0) return 0;
    reserve(chunk, n);
    switch (header_.data) {
      case DataKind::Ascii:
        for (std::size_t i = 0; i < n; ++i) {
          readAsciiPoint();
          store(chunk);
          ++delivered_;
        }
        break;
      case DataKind::Binary: readBinaryPoints(chunk, n); break;
      case DataKind::BinaryCompressed:
        for (std::size_t i = 0; i < n; ++i) {
          for (std::size_t f = 0; f < header_.fields.size(); ++f) {
            const Field& field = header_.fields[f];
            if (field.role != kIgnored) assign(field, columns_.data() + columnStart_[f] + delivered_ * field.bytes());
          }
          store(chunk);
          ++delivered_;
        }
        if (delivered_ == header_.points) freeStorage(columns_);  // the decompressed data, no longer needed
        break;
    }
    return n;
  }

  double progress() const override {
    if (header_.points == 0) return 1.0;
    return static_cast<double>(delivered_) / static_cast<double>(header_.points);
  }

 private:
  [[noreturn]] void failAtData(const std::string& message) const {
    throw InputError(path_, byteLocation(header_.dataOffset), message);
  }

  /// binary_compressed stores each field as one column over all points, LZF-compressed as a
  /// whole: no point can be decoded before the whole stream is, so the compressed stream and the
  /// decompressed columns are both held in memory (the compressed one only while decompressing).
  void loadCompressed(const std::filesystem::path& path) {
    BinaryFile file(path);
    file.seek(header_.dataOffset, "the PCD compressed data");
    const auto compressedSize = file.readLE<std::uint32_t>("the compressed size");
    const auto uncompressedSize = file.readLE<std::uint32_t>("the uncompressed size");
    const std::uint64_t streamOffset = file.tell();
    if (compressedSize > file.remaining()) {
      file.failAt(header_.dataOffset, "compressed size " + std::to_string(compressedSize) + " is larger than the " +
                                          std::to_string(file.remaining()) + " bytes left in the file");
    }
    const bool recordsFit = header_.points <= std::numeric_limits<std::uint32_t>::max() / header_.recordBytes;
    if (!recordsFit || uncompressedSize != header_.points * header_.recordBytes) {
      file.failAt(header_.dataOffset + 4, "uncompressed size " + std::to_string(uncompressedSize) +
                                              ", expected POINTS x record size = " + std::to_string(header_.points) +
                                              " x " + std::to_string(header_.recordBytes));
    }
    if (uncompressedSize > kMaxLzfExpansion * compressedSize) {
      file.failAt(header_.dataOffset, "uncompressed size " + std::to_string(uncompressedSize) +
                                          " cannot come from " + std::to_string(compressedSize) +
                                          " bytes of LZF data, expected at most " +
                                          std::to_string(kMaxLzfExpansion) + " times as many");
    }
    std::vector<unsigned char> compressed(compressedSize);
    file.read(compressed.data(), compressed.size(), "the compressed point data");
    columns_.resize(uncompressedSize);
    decompressLzf(compressed, columns_, path, streamOffset);

    std::uint64_t start = 0;
    for (const auto& field : header_.fields) {
      columnStart_.push_back(static_cast<std::size_t>(start));
      start += header_.points * field.bytes();
    }
  }

  void reserve(PointChunk& chunk, std::size_t n) const {
    chunk.positions.reserve(n);
    if (info_.attributes & kNormals) chunk.normals.reserve(n);
    if (info_.attributes & kColors) chunk.colors.reserve(n);
    if (info_.attributes & kIntensity) chunk.intensities.reserve(n);
    if (info_.attributes & kLabels) chunk.labels.reserve(n);
  }

  void assign(const Field& field, const unsigned char* bytes) {
    if (field.role == kPackedColor) {
      packedColor_ = loadLE<std::uint32_t>(bytes);  // the bits, whether TYPE is F or U
    } else {
      values_[field.role] = decodeValue(field, bytes);
    }
  }

  void store(PointChunk& chunk) const {
    const auto& v = values_;
    chunk.positions.emplace_back(v[kX], v[kY], v[kZ]);
    if (info_.attributes & kNormals) {
      chunk.normals.emplace_back(static_cast<float>(v[kNormalX]), static_cast<float>(v[kNormalY]),
                                 static_cast<float>(v[kNormalZ]));
    }
    if (info_.attributes & kColors) {
      chunk.colors.emplace_back(std::uint8_t(packedColor_ >> 16), std::uint8_t(packedColor_ >> 8),
                                std::uint8_t(packedColor_));
    }
    if (info_.attributes & kIntensity) chunk.intensities.push_back(float(v[kIntensityRole]));
    if (info_.attributes & kLabels) chunk.labels.push_back(toLabel(v[kLabel]));
  }

  void readBinaryPoints(PointChunk& chunk, std::size_t n) {
    // Blocks bound the buffer when records are wide (descriptors) and chunks large.
    const std::size_t blockRecords = std::max<std::size_t>(1, (std::size_t(1) << 22) / header_.recordBytes);
    for (std::size_t done = 0; done < n;) {
      const std::size_t records = std::min(blockRecords, n - done);
      block_.resize(records * header_.recordBytes);
      binary_->read(block_.data(), block_.size(), "PCD point records");
      for (std::size_t r = 0; r < records; ++r) {
        const unsigned char* record = block_.data() + r * header_.recordBytes;
        for (const auto& field : header_.fields) {
          if (field.role != kIgnored) assign(field, record + field.offset);
        }
        store(chunk);
      }
      done += records;
      delivered_ += records;
    }
  }

  void readAsciiPoint() {
    std::string_view line;
    std::size_t count = 0;
    do {
      if (!lines_.next(line)) {
        throw InputError(path_, lineLocation(lines_.lineNumber() + 1),
                         "unexpected end of file after " + std::to_string(delivered_) + " points, expected POINTS " +
                             std::to_string(header_.points));
      }
      count = splitFields(line, fields_);
    } while (count == 0);
    if (count != header_.valuesPerRecord) {
      lines_.fail("found " + std::to_string(count) + " values, expected " + std::to_string(header_.valuesPerRecord) +
                  " (the COUNT of each field of FIELDS)");
    }
    std::size_t next = 0;
    for (const auto& field : header_.fields) {
      const std::string_view text = fields_[next];
      next += field.count;
      if (field.role == kIgnored) continue;
      if (field.role == kPackedColor) {
        packedColor_ = parsePackedColor(field, text);
        continue;
      }
      double value = 0.0;
      if (!parseNumber(text, value)) {
        lines_.fail("value " + excerpt(text) + " of field " + field.name + " is not a number");
      }
      values_[field.role] = value;
    }
  }

  /// PCL writes packed colours in ascii as the uint32 integer (since PCL 1.9, even for TYPE F);
  /// older writers printed the float whose bits hold the colour.
  std::uint32_t parsePackedColor(const Field& field, std::string_view text) const {
    std::int64_t integer = 0;
    if (parseNumber(text, integer)) return static_cast<std::uint32_t>(integer);
    float packed = 0.0f;
    if (field.type != 'F' || !parseNumber(text, packed)) {
      lines_.fail("value " + excerpt(text) + " of field " + field.name + " is not a packed colour number");
    }
    return loadLE<std::uint32_t>(&packed);
  }

  std::filesystem::path path_;
  TextLines lines_;
  Header header_;
  CloudInfo info_;
  std::optional<BinaryFile> binary_;       // DATA binary
  std::vector<unsigned char> block_;       // DATA binary: records being decoded
  std::vector<unsigned char> columns_;     // DATA binary_compressed: all columns, decompressed
  std::vector<std::size_t> columnStart_;   // DATA binary_compressed: offset of each field's column
  std::vector<std::string_view> fields_;     // DATA ascii: values of the current line
  std::array<double, kRoleCount> values_{};
  std::uint32_t packedColor_ = 0;
  std::uint64_t delivered_ = 0;
};

}  // namespace

std::unique_ptr<PointReader> openPcdReader(const std::filesystem::path& path) {
  return std::make_unique<PcdReader>(path);
}

}  // namespace piperun::io
