// PLY (Stanford polygon file) reader: ascii, binary_little_endian and binary_big_endian 1.0.
//
// Only the "vertex" element is delivered; every other element (faces, edges, materials), before
// or after the vertices, is skipped, as are list properties and unknown vertex properties.

#include "io/binary_file.h"
#include "io/readers.h"
#include "io/text_lines.h"
#include "piperun/error.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace piperun::io {

namespace {

enum class ScalarType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

struct TypeName {
  std::string_view name;
  ScalarType type;
};

constexpr TypeName kTypeNames[] = {
    {"char", ScalarType::Int8},     {"int8", ScalarType::Int8},       {"uchar", ScalarType::UInt8},
    {"uint8", ScalarType::UInt8},   {"short", ScalarType::Int16},     {"int16", ScalarType::Int16},
    {"ushort", ScalarType::UInt16}, {"uint16", ScalarType::UInt16},   {"int", ScalarType::Int32},
    {"int32", ScalarType::Int32},   {"uint", ScalarType::UInt32},     {"uint32", ScalarType::UInt32},
    {"float", ScalarType::Float32}, {"float32", ScalarType::Float32}, {"double", ScalarType::Float64},
    {"float64", ScalarType::Float64},
};

std::size_t scalarBytes(ScalarType type) {
  switch (type) {
    case ScalarType::Int8:
    case ScalarType::UInt8: return 1;
    case ScalarType::Int16:
    case ScalarType::UInt16: return 2;
    case ScalarType::Int32:
    case ScalarType::UInt32:
    case ScalarType::Float32: return 4;
    case ScalarType::Float64: return 8;
  }
  return 0;
}

template <class T>
T load(const unsigned char* bytes, bool bigEndian) {
  return bigEndian ? loadBE<T>(bytes) : loadLE<T>(bytes);
}

double decodeScalar(ScalarType type, const unsigned char* bytes, bool bigEndian) {
  switch (type) {
    case ScalarType::Int8: return static_cast<std::int8_t>(bytes[0]);
    case ScalarType::UInt8: return bytes[0];
    case ScalarType::Int16: return load<std::int16_t>(bytes, bigEndian);
    case ScalarType::UInt16: return load<std::uint16_t>(bytes, bigEndian);
    case ScalarType::Int32: return load<std::int32_t>(bytes, bigEndian);
    case ScalarType::UInt32: return load<std::uint32_t>(bytes, bigEndian);
    case ScalarType::Float32: return load<float>(bytes, bigEndian);
    case ScalarType::Float64: return load<double>(bytes, bigEndian);
  }
  return 0.0;
}

/// What a vertex property contributes to a point: an index into the values of one record.
enum Role : int {
  kIgnored = -1,
  kX,
  kY,
  kZ,
  kNormalX,
  kNormalY,
  kNormalZ,
  kRed,
  kGreen,
  kBlue,
  kIntensityRole,  // (kIntensity is the PointAttribute bit)
  kLabel,
  kRoleCount
};

struct RoleName {
  std::string_view name;
  Role role;
};

constexpr RoleName kRoleNames[] = {
    {"x", kX},
    {"y", kY},
    {"z", kZ},
    {"nx", kNormalX},
    {"ny", kNormalY},
    {"nz", kNormalZ},
    {"red", kRed},
    {"green", kGreen},
    {"blue", kBlue},
    {"r", kRed},
    {"g", kGreen},
    {"b", kBlue},
    {"diffuse_red", kRed},
    {"diffuse_green", kGreen},
    {"diffuse_blue", kBlue},
    {"intensity", kIntensityRole},
    {"scalar_intensity", kIntensityRole},
    {"scalar_Intensity", kIntensityRole},
    {"label", kLabel},
    {"scalar_label", kLabel},
    {"class", kLabel},
    {"segment", kLabel},
};

Role roleOf(std::string_view name) {
  for (const auto& entry : kRoleNames) {
    if (entry.name == name) return entry.role;
  }
  return kIgnored;
}

/// Colour channels come as 8-bit, 16-bit (scaled down) or floating point in [0, 1].
double toColor8(double value, ScalarType type) {
  if (!(value > 0.0)) return 0.0;  // also maps NaN to black
  switch (type) {
    case ScalarType::Float32:
    case ScalarType::Float64: value *= 255.0; break;
    case ScalarType::Int16:
    case ScalarType::UInt16: value /= 257.0; break;
    default: break;
  }
  return std::min(std::round(value), 255.0);
}

std::int32_t toLabel(double value) {
  if (std::isnan(value)) return -1;
  const double clamped = std::clamp(value, double(std::numeric_limits<std::int32_t>::min()),
                                    double(std::numeric_limits<std::int32_t>::max()));
  return static_cast<std::int32_t>(clamped);
}

struct Property {
  std::string name;
  ScalarType type = ScalarType::Float32;      // the value type, or the item type of a list
  std::optional<ScalarType> listCountType;    // set for list properties
  Role role = kIgnored;
};

struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::uint64_t headerLine = 0;
  std::vector<Property> properties;

  /// Bytes of one binary record when it has no list property.
  std::optional<std::size_t> fixedRecordBytes() const {
    std::size_t bytes = 0;
    for (const auto& property : properties) {
      if (property.listCountType) return std::nullopt;
      bytes += scalarBytes(property.type);
    }
    return bytes;
  }

  /// Smallest number of bytes a binary record can take (lists counted as empty).
  std::size_t minimumBinaryBytes() const {
    std::size_t bytes = 0;
    for (const auto& property : properties) bytes += scalarBytes(property.listCountType.value_or(property.type));
    return bytes;
  }

  /// Smallest number of bytes an ascii record can take: one digit per value, a separator or a
  /// newline after each (lists counted as empty).
  std::size_t minimumAsciiBytes() const { return std::max<std::size_t>(1, 2 * properties.size()); }
};

enum class Encoding { Ascii, BinaryLittleEndian, BinaryBigEndian };

struct Header {
  Encoding encoding = Encoding::Ascii;
  std::string formatName;
  std::vector<Element> elements;
  std::size_t vertexIndex = 0;
  std::uint64_t dataOffset = 0;
  std::uint64_t lineCount = 0;  // lines of the header, end_header included
  unsigned attributes = kNoAttributes;
};

// Header lines are short; a longer one means the file is not a PLY header.
constexpr std::size_t kMaxHeaderLineBytes = 64 * 1024;

/// Reads one header line without its "\n" or "\r\n"; false at the end of the file.
bool readHeaderLine(BinaryFile& file, std::uint64_t lineNumber, std::string& line) {
  line.clear();
  char c = 0;
  while (file.readSome(&c, 1) == 1) {
    if (c == '\n') {
      if (!line.empty() && line.back() == '\r') line.pop_back();
      return true;
    }
    if (line.size() == kMaxHeaderLineBytes) {
      throw InputError(file.path(), lineLocation(lineNumber),
                       "header line longer than " + std::to_string(kMaxHeaderLineBytes) +
                           " bytes, expected 'end_header' before the data");
    }
    line.push_back(c);
  }
  return !line.empty();
}

class HeaderParser {
 public:
  explicit HeaderParser(BinaryFile& file) : file_(file) {}

  Header parse() {
    char magic[3] = {};
    if (file_.readSome(magic, 3) != 3 || std::string_view(magic, 3) != "ply") {
      file_.failAt(0, "expected the PLY magic 'ply' at the start of the file");
    }
    file_.seek(0, "the PLY header");
    std::string line;
    readHeaderLine(file_, 1, line);
    lineNumber_ = 1;
    if (line != "ply") fail("found " + excerpt(line) + ", expected 'ply' alone on the first line");

    bool haveFormat = false;
    for (;;) {
      ++lineNumber_;
      if (!readHeaderLine(file_, lineNumber_, line)) {
        fail("unexpected end of file in the header, expected 'end_header'");
      }
      const auto tokens = splitWords(line);
      if (tokens.empty()) continue;
      const std::string_view keyword = tokens[0];
      if (keyword == "comment" || keyword == "obj_info") continue;
      if (keyword == "format") {
        parseFormat(tokens);
        haveFormat = true;
        continue;
      }
      if (keyword != "element" && keyword != "property" && keyword != "end_header") {
        fail("unknown header keyword " + excerpt(keyword) +
             ", expected format, comment, obj_info, element, property or end_header");
      }
      if (!haveFormat) {
        fail("found '" + std::string(keyword) +
             "' before the format line, expected 'format ascii|binary_little_endian|binary_big_endian 1.0'");
      }
      if (keyword == "element") {
        parseElement(tokens);
      } else if (keyword == "property") {
        parseProperty(tokens);
      } else {
        break;
      }
    }
    header_.lineCount = lineNumber_;
    header_.dataOffset = file_.tell();
    findVertexElement();
    return std::move(header_);
  }

 private:
  [[noreturn]] void fail(const std::string& message) const {
    throw InputError(file_.path(), lineLocation(lineNumber_), message);
  }

  void parseFormat(const std::vector<std::string_view>& tokens) {
    if (tokens.size() != 3) fail("expected 'format <encoding> 1.0'");
    if (tokens[1] == "ascii") {
      header_.encoding = Encoding::Ascii;
    } else if (tokens[1] == "binary_little_endian") {
      header_.encoding = Encoding::BinaryLittleEndian;
    } else if (tokens[1] == "binary_big_endian") {
      header_.encoding = Encoding::BinaryBigEndian;
    } else {
      fail("unknown format " + excerpt(tokens[1]) + ", expected ascii, binary_little_endian or binary_big_endian");
    }
    if (tokens[2] != "1.0" && tokens[2] != "1") {
      fail("unsupported PLY version " + excerpt(tokens[2]) + ", expected 1.0");
    }
    header_.formatName = "PLY " + std::string(tokens[1]) + " 1.0";
  }

  void parseElement(const std::vector<std::string_view>& tokens) {
    if (tokens.size() != 3) fail("expected 'element <name> <count>'");
    std::int64_t count = 0;
    if (!parseNumber(tokens[2], count) || count < 0) {
      fail("element count " + excerpt(tokens[2]) + " is not a non-negative integer");
    }
    Element element;
    element.name = std::string(tokens[1]);
    element.count = static_cast<std::uint64_t>(count);
    element.headerLine = lineNumber_;
    header_.elements.push_back(std::move(element));
  }

  ScalarType parseType(std::string_view name) const {
    for (const auto& entry : kTypeNames) {
      if (entry.name == name) return entry.type;
    }
    fail("unknown property type " + excerpt(name) +
         ", expected char, uchar, short, ushort, int, uint, float, double or int8 ... float64");
  }

  void parseProperty(const std::vector<std::string_view>& tokens) {
    if (header_.elements.empty()) fail("property before any element, expected 'element <name> <count>' first");
    Property property;
    if (tokens.size() >= 2 && tokens[1] == "list") {
      if (tokens.size() != 5) fail("expected 'property list <count type> <item type> <name>'");
      property.listCountType = parseType(tokens[2]);
      if (*property.listCountType == ScalarType::Float32 || *property.listCountType == ScalarType::Float64) {
        fail("list count type " + excerpt(tokens[2]) + " is not an integer type");
      }
      property.type = parseType(tokens[3]);
      property.name = std::string(tokens[4]);
    } else {
      if (tokens.size() != 3) fail("expected 'property <type> <name>'");
      property.type = parseType(tokens[1]);
      property.name = std::string(tokens[2]);
    }
    header_.elements.back().properties.push_back(std::move(property));
  }

  void findVertexElement() {
    const auto vertex = std::find_if(header_.elements.begin(), header_.elements.end(),
                                     [](const Element& element) { return element.name == "vertex"; });
    if (vertex == header_.elements.end()) fail("no 'vertex' element in the header, expected one with x, y and z");
    header_.vertexIndex = static_cast<std::size_t>(vertex - header_.elements.begin());

    std::array<bool, kRoleCount> taken{};
    for (auto& property : vertex->properties) {
      const Role role = roleOf(property.name);
      if (role == kIgnored || taken[role]) continue;
      if (property.listCountType) {
        if (role <= kZ) {
          throw InputError(file_.path(), lineLocation(vertex->headerLine),
                           "vertex property " + property.name + " is a list, expected a scalar");
        }
        continue;
      }
      property.role = role;
      taken[role] = true;
    }
    for (const char* axis : {"x", "y", "z"}) {
      if (!taken[roleOf(axis)]) {
        throw InputError(file_.path(), lineLocation(vertex->headerLine),
                         std::string("vertex element has no property '") + axis + "', expected x, y and z");
      }
    }
    // Normals and colours count only when all three channels are there.
    const auto keepGroup = [&](Role first, unsigned attribute) {
      const bool complete = taken[first] && taken[first + 1] && taken[first + 2];
      if (complete) {
        header_.attributes |= attribute;
        return;
      }
      for (auto& property : vertex->properties) {
        if (property.role >= first && property.role <= first + 2) property.role = kIgnored;
      }
    };
    keepGroup(kNormalX, kNormals);
    keepGroup(kRed, kColors);
    if (taken[kIntensityRole]) header_.attributes |= kIntensity;
    if (taken[kLabel]) header_.attributes |= kLabels;
  }

  BinaryFile& file_;
  Header header_;
  std::uint64_t lineNumber_ = 0;
};

/// Rejects element counts the file cannot hold, before anything is reserved or looped over.
void checkCountsFitFile(const Header& header, const BinaryFile& file) {
  std::uint64_t available = file.size() - header.dataOffset;
  const bool ascii = header.encoding == Encoding::Ascii;
  if (ascii) available += 1;  // the last line needs no newline
  for (const auto& element : header.elements) {
    const std::uint64_t recordBytes = ascii ? element.minimumAsciiBytes() : element.minimumBinaryBytes();
    if (recordBytes == 0) continue;
    if (element.count > available / recordBytes) {
      const std::string records = std::to_string(element.count) + " records of at least " +
                                  std::to_string(recordBytes) + (ascii ? " characters" : " bytes");
      throw InputError(file.path(), lineLocation(element.headerLine),
                       "element " + element.name + " declares " + records + ", but only " +
                           std::to_string(file.size() - header.dataOffset) +
                           " bytes follow the header (truncated file or wrong count)");
    }
    available -= element.count * recordBytes;
  }
}

/// Buffered binary input over a BinaryFile, handing out records without a copy.
class ByteReader {
 public:
  explicit ByteReader(BinaryFile& file) : file_(file), buffer_(kBufferBytes) {}

  /// The next n bytes (n ≤ kBufferBytes), or nullptr when the file ends first.
  const unsigned char* take(std::size_t n) {
    if (end_ - begin_ < n && !refill(n)) return nullptr;
    const unsigned char* bytes = buffer_.data() + begin_;
    begin_ += n;
    return bytes;
  }

  /// Skips n bytes; false when the file ends first.
  bool skip(std::uint64_t n) {
    const std::uint64_t buffered = end_ - begin_;
    if (n <= buffered) {
      begin_ += static_cast<std::size_t>(n);
      return true;
    }
    const std::uint64_t target = offset() + n;
    if (target > file_.size()) return false;
    begin_ = end_ = 0;
    file_.seek(target, "skipped PLY data");
    return true;
  }

  /// File offset of the next unread byte.
  std::uint64_t offset() const { return file_.tell() - (end_ - begin_); }

  static constexpr std::size_t kBufferBytes = 1u << 20;

 private:
  bool refill(std::size_t n) {
    const std::size_t tail = end_ - begin_;
    std::memmove(buffer_.data(), buffer_.data() + begin_, tail);
    begin_ = 0;
    end_ = tail;
    end_ += file_.readSome(buffer_.data() + end_, buffer_.size() - end_);
    return end_ >= n;
  }

  BinaryFile& file_;
  std::vector<unsigned char> buffer_;
  std::size_t begin_ = 0;
  std::size_t end_ = 0;
};

class PlyReader final : public PointReader {
 public:
  explicit PlyReader(const std::filesystem::path& path) : path_(path), file_(path) {
    header_ = HeaderParser(file_).parse();
    checkCountsFitFile(header_, file_);
    const Element& vertex = vertexElement();
    info_.format = header_.formatName;
    for (const auto& property : vertex.properties) info_.fields.push_back(property.name);
    info_.declaredPoints = vertex.count;
    info_.attributes = header_.attributes;
    bigEndian_ = header_.encoding == Encoding::BinaryBigEndian;
    if (header_.encoding == Encoding::Ascii) {
      lines_.emplace(path);
      std::string_view skipped;
      for (std::uint64_t i = 0; i < header_.lineCount; ++i) lines_->next(skipped);
    } else {
      bytes_.emplace(file_);
    }
  }

  const CloudInfo& info() const override { return info_; }

  std::size_t read(PointChunk& chunk, std::size_t maxPoints) override {
    chunk.clear();
    if (!atVertices_) {
      for (std::size_t i = 0; i < header_.vertexIndex; ++i) skipElement(header_.elements[i]);
      atVertices_ = true;
    }
    const Element& vertex = vertexElement();
    const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(maxPoints, vertex.count - delivered_));
    if (n == 0) return 0;
    reserve(chunk, n);
    for (std::size_t i = 0; i < n; ++i) {
      if (lines_) {
        readAsciiVertex(vertex);
      } else {
        readBinaryVertex(vertex);
      }
      store(chunk);
      ++delivered_;
    }
    return n;
  }

  double progress() const override {
    if (delivered_ == vertexElement().count) return 1.0;  // later elements are never read
    const std::uint64_t consumed = lines_ ? lines_->bytesConsumed() : bytes_->offset();
    return std::min(1.0, static_cast<double>(consumed) / static_cast<double>(file_.size()));
  }

 private:
  const Element& vertexElement() const { return header_.elements[header_.vertexIndex]; }

  void reserve(PointChunk& chunk, std::size_t n) const {
    chunk.positions.reserve(n);
    if (info_.attributes & kNormals) chunk.normals.reserve(n);
    if (info_.attributes & kColors) chunk.colors.reserve(n);
    if (info_.attributes & kIntensity) chunk.intensities.reserve(n);
    if (info_.attributes & kLabels) chunk.labels.reserve(n);
  }

  void store(PointChunk& chunk) const {
    const auto& v = values_;
    chunk.positions.emplace_back(v[kX], v[kY], v[kZ]);
    if (info_.attributes & kNormals) {
      chunk.normals.emplace_back(float(v[kNormalX]), float(v[kNormalY]), float(v[kNormalZ]));
    }
    if (info_.attributes & kColors) {
      chunk.colors.emplace_back(std::uint8_t(v[kRed]), std::uint8_t(v[kGreen]), std::uint8_t(v[kBlue]));
    }
    if (info_.attributes & kIntensity) chunk.intensities.push_back(float(v[kIntensityRole]));
    if (info_.attributes & kLabels) chunk.labels.push_back(toLabel(v[kLabel]));
  }

  void assign(const Property& property, double value) {
    if (property.role == kIgnored) return;
    values_[property.role] = (property.role >= kRed && property.role <= kBlue) ? toColor8(value, property.type) : value;
  }

  [[noreturn]] void failTruncated(const Element& element, std::uint64_t record) const {
    throw InputError(path_, byteLocation(bytes_->offset()),
                     "unexpected end of file in " + element.name + " " + std::to_string(record) + ", expected " +
                         std::to_string(element.count) + " " + element.name + " records");
  }

  const unsigned char* takeScalar(const Element& element, std::uint64_t record, ScalarType type) {
    const unsigned char* bytes = bytes_->take(scalarBytes(type));
    if (!bytes) failTruncated(element, record);
    return bytes;
  }

  /// Skips a binary list property: its count, then its items.
  void skipBinaryList(const Element& element, std::uint64_t record, const Property& property) {
    const std::uint64_t at = bytes_->offset();
    const double count = decodeScalar(*property.listCountType, takeScalar(element, record, *property.listCountType),
                                      bigEndian_);
    if (count < 0) {
      throw InputError(path_, byteLocation(at),
                       "list " + property.name + " of " + element.name + " " + std::to_string(record) +
                           " has " + std::to_string(static_cast<std::int64_t>(count)) +
                           " items, expected a non-negative count");
    }
    if (!bytes_->skip(static_cast<std::uint64_t>(count) * scalarBytes(property.type))) failTruncated(element, record);
  }

  void readBinaryVertex(const Element& vertex) {
    for (const auto& property : vertex.properties) {
      if (property.listCountType) {
        skipBinaryList(vertex, delivered_, property);
      } else {
        const unsigned char* bytes = takeScalar(vertex, delivered_, property.type);
        if (property.role != kIgnored) assign(property, decodeScalar(property.type, bytes, bigEndian_));
      }
    }
  }

  /// The next non-blank data line, split into fields.
  std::size_t nextAsciiRecord(const Element& element, std::uint64_t record) {
    std::string_view line;
    for (;;) {
      if (!lines_->next(line)) {
        throw InputError(path_, lineLocation(lines_->lineNumber() + 1),
                         "unexpected end of file in " + element.name + " " + std::to_string(record) +
                             ", expected " + std::to_string(element.count) + " " + element.name + " lines");
      }
      std::size_t count = splitFields(line, fields_);
      if (count > fields_.size()) {
        fields_.resize(count);
        count = splitFields(line, fields_);
      }
      if (count > 0) return count;
    }
  }

  void readAsciiVertex(const Element& vertex) {
    const std::size_t count = nextAsciiRecord(vertex, delivered_);
    std::size_t next = 0;
    const auto expectValue = [&](const Property& property) {
      if (next >= count) {
        lines_->fail("found " + std::to_string(count) + " values, expected more: property " + property.name +
                     " of vertex " + std::to_string(delivered_) + " is missing");
      }
      return fields_[next++];
    };
    for (const auto& property : vertex.properties) {
      if (property.listCountType) {
        const std::string_view field = expectValue(property);
        std::int64_t items = 0;
        if (!parseNumber(field, items) || items < 0) {
          lines_->fail("list count " + excerpt(field) + " of property " + property.name +
                       " is not a non-negative integer");
        }
        if (static_cast<std::uint64_t>(items) > count - next) {
          lines_->fail("list " + property.name + " declares " + std::to_string(items) + " items, but only " +
                       std::to_string(count - next) + " values follow on the line");
        }
        next += static_cast<std::size_t>(items);
        continue;
      }
      const std::string_view field = expectValue(property);
      double value = 0.0;
      if (!parseNumber(field, value)) {
        lines_->fail("value " + excerpt(field) + " of property " + property.name + " is not a number");
      }
      assign(property, value);
    }
    if (next != count) {
      lines_->fail("found " + std::to_string(count) + " values, expected " + std::to_string(next) +
                   " (the vertex properties of the header)");
    }
  }

  void skipElement(const Element& element) {
    if (lines_) {
      for (std::uint64_t record = 0; record < element.count; ++record) nextAsciiRecord(element, record);
      return;
    }
    if (const auto recordBytes = element.fixedRecordBytes()) {
      // checkCountsFitFile guarantees the product fits the file.
      if (!bytes_->skip(element.count * *recordBytes)) failTruncated(element, 0);
      return;
    }
    for (std::uint64_t record = 0; record < element.count; ++record) {
      for (const auto& property : element.properties) {
        if (property.listCountType) {
          skipBinaryList(element, record, property);
        } else {
          takeScalar(element, record, property.type);
        }
      }
    }
  }

  std::filesystem::path path_;
  BinaryFile file_;
  Header header_;
  CloudInfo info_;
  bool bigEndian_ = false;
  std::optional<TextLines> lines_;   // ascii data
  std::optional<ByteReader> bytes_;  // binary data
  std::vector<std::string_view> fields_ = std::vector<std::string_view>(16);
  std::array<double, kRoleCount> values_{};
  bool atVertices_ = false;
  std::uint64_t delivered_ = 0;
};

}  // namespace

std::unique_ptr<PointReader> openPlyReader(const std::filesystem::path& path) {
  return std::make_unique<PlyReader>(path);
}

}  // namespace piperun::io
