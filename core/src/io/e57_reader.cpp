// E57 point reader (ASTM E2807), written from the standard.
//
// An E57 file is a sequence of pages (normally 1024 bytes), each ending with the big-endian
// CRC-32C of the rest of the page. Leaving those checksums out gives the "logical" byte stream in
// which the XML section and the binary sections lie; offsets stored in the file are physical.
// The XML describes each scan (/data3D/N): its pose and a CompressedVector whose prototype lists
// the fields of one record. The CompressedVector's binary section holds packets; a data packet
// carries the next piece of every field's bytestream, and a bytestream is a little-endian bit
// stream of fixed-width values that runs on from one packet into the next.

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <optional>
#include <pugixml.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "io/binary_file.h"
#include "io/e57_checksum.h"
#include "io/readers.h"
#include "io/text_lines.h"

namespace piperun::io {
namespace {

namespace fs = std::filesystem;

constexpr std::size_t kFileHeaderBytes = 48;
constexpr std::uint64_t kChecksumBytes = 4;
constexpr std::uint64_t kMinPageSize = 64;
constexpr std::uint64_t kMaxPageSize = 1u << 20;
constexpr std::size_t kSectionHeaderBytes = 32;
constexpr std::uint8_t kCompressedVectorSectionId = 1;
constexpr std::size_t kPacketHeaderBytes = 4;      // type, flags, logical length - 1
constexpr std::size_t kDataPacketHeaderBytes = 6;  // ... then bytestreamCount
constexpr std::uint8_t kIndexPacket = 0;
constexpr std::uint8_t kDataPacket = 1;
constexpr std::uint8_t kEmptyPacket = 2;
constexpr double kInvalidStateValid = 0.0;
// Surface normals extension: fields <prefix>:normalX/Y/Z, the prefix bound to this namespace.
constexpr std::string_view kNormalsNamespace = "http://www.libe57.org/E57_NOR_surface_normals.txt";

// ---------------------------------------------------------------------------------------------
// Pages and checksums

/// The file seen through its pages: validates the file header, translates between physical and
/// logical offsets and reads logical bytes through a one-page cache, verifying the checksum of
/// every page it loads (a sequential read loads and verifies each page once).
class PagedFile {
 public:
  explicit PagedFile(const fs::path& path) : file_(path) { readHeader(); }

  const fs::path& path() const { return file_.path(); }
  std::uint32_t majorVersion() const { return majorVersion_; }
  std::uint32_t minorVersion() const { return minorVersion_; }
  std::uint64_t xmlLogicalOffset() const { return xmlLogicalOffset_; }
  std::uint64_t xmlLogicalLength() const { return xmlLogicalLength_; }
  std::uint64_t logicalLength() const { return pageCount_ * payloadBytes_; }

  /// Whether a physical offset stored in the file points at data (not into a checksum, not
  /// beyond the end).
  bool holdsData(std::uint64_t physical) const {
    return physical / pageSize_ < pageCount_ && physical % pageSize_ < payloadBytes_;
  }
  std::uint64_t toLogical(std::uint64_t physical) const {
    return physical / pageSize_ * payloadBytes_ + physical % pageSize_;
  }
  std::uint64_t toPhysical(std::uint64_t logical) const {
    return logical / payloadBytes_ * pageSize_ + logical % payloadBytes_;
  }

  void readLogical(std::uint64_t logical, void* destination, std::size_t size, const char* what) {
    auto* out = static_cast<unsigned char*>(destination);
    while (size > 0) {
      const std::uint64_t page = logical / payloadBytes_;
      const std::uint64_t within = logical % payloadBytes_;
      if (page >= pageCount_) {
        failAt(toPhysical(logical), std::string("unexpected end of file, expected ") + what);
      }
      loadPage(page);
      const std::size_t take = static_cast<std::size_t>(std::min<std::uint64_t>(size, payloadBytes_ - within));
      std::memcpy(out, pageBytes_.data() + within, take);
      out += take;
      logical += take;
      size -= take;
    }
  }

  template <class T>
  T readLogicalLE(std::uint64_t logical, const char* what) {
    unsigned char bytes[sizeof(T)];
    readLogical(logical, bytes, sizeof(T), what);
    return loadLE<T>(bytes);
  }

  [[noreturn]] void failAt(std::uint64_t physical, const std::string& message) const {
    file_.failAt(physical, message);
  }

 private:
  void readHeader() {
    unsigned char header[kFileHeaderBytes] = {};
    const std::size_t got = file_.readSome(header, kFileHeaderBytes);
    if (got < 8 || std::memcmp(header, "ASTM-E57", 8) != 0) {
      failAt(0, "expected the signature \"ASTM-E57\": not an E57 file");
    }
    if (got < kFileHeaderBytes) {
      failAt(got, "file is truncated: " + std::to_string(got) + " bytes, expected a " +
                      std::to_string(kFileHeaderBytes) + "-byte E57 file header");
    }
    majorVersion_ = loadLE<std::uint32_t>(header + 8);
    minorVersion_ = loadLE<std::uint32_t>(header + 12);
    const auto physicalLength = loadLE<std::uint64_t>(header + 16);
    const auto xmlPhysicalOffset = loadLE<std::uint64_t>(header + 24);
    xmlLogicalLength_ = loadLE<std::uint64_t>(header + 32);
    pageSize_ = loadLE<std::uint64_t>(header + 40);

    if (majorVersion_ != 1) {
      failAt(8, "E57 version " + std::to_string(majorVersion_) + "." + std::to_string(minorVersion_) +
                    " is not supported, expected 1.x");
    }
    const bool powerOfTwo = (pageSize_ & (pageSize_ - 1)) == 0;
    if (!powerOfTwo || pageSize_ < kMinPageSize || pageSize_ > kMaxPageSize) {
      failAt(40, "bad page size " + std::to_string(pageSize_) + ", expected a power of two from " +
                     std::to_string(kMinPageSize) + " to " + std::to_string(kMaxPageSize) + " (normally 1024)");
    }
    if (physicalLength != file_.size()) {
      failAt(16, "filePhysicalLength " + std::to_string(physicalLength) + " disagrees with the file size " +
                     std::to_string(file_.size()) + " (truncated or damaged file?)");
    }
    if (physicalLength % pageSize_ != 0) {
      failAt(16, "filePhysicalLength " + std::to_string(physicalLength) + " is not a whole number of " +
                     std::to_string(pageSize_) + "-byte pages");
    }
    payloadBytes_ = pageSize_ - kChecksumBytes;
    pageCount_ = physicalLength / pageSize_;
    pageBytes_.resize(static_cast<std::size_t>(pageSize_));
    loadPage(0);

    if (!holdsData(xmlPhysicalOffset)) {
      failAt(24, "xmlPhysicalOffset " + std::to_string(xmlPhysicalOffset) +
                     " points into a page checksum or past the end, expected the start of the XML section");
    }
    xmlLogicalOffset_ = toLogical(xmlPhysicalOffset);
    if (xmlLogicalLength_ == 0 || xmlLogicalLength_ > logicalLength() - xmlLogicalOffset_) {
      failAt(32, "xmlLogicalLength " + std::to_string(xmlLogicalLength_) + " does not fit in the file: " +
                     std::to_string(logicalLength() - xmlLogicalOffset_) + " data bytes follow the XML offset");
    }
  }

  void loadPage(std::uint64_t page) {
    if (page == loadedPage_) return;
    const std::uint64_t physical = page * pageSize_;
    file_.seek(physical, "E57 page");
    file_.read(pageBytes_.data(), pageBytes_.size(), "E57 page");
    const std::uint32_t stored = loadBE<std::uint32_t>(pageBytes_.data() + payloadBytes_);
    const std::uint32_t computed = crc32c(pageBytes_.data(), static_cast<std::size_t>(payloadBytes_));
    if (stored != computed) {
      char detail[96];
      std::snprintf(detail, sizeof detail, "page checksum mismatch: stored CRC-32C 0x%08X, computed 0x%08X",
                    static_cast<unsigned>(stored), static_cast<unsigned>(computed));
      failAt(physical, detail);
    }
    loadedPage_ = page;
  }

  BinaryFile file_;
  std::uint32_t majorVersion_ = 0;
  std::uint32_t minorVersion_ = 0;
  std::uint64_t pageSize_ = 0;
  std::uint64_t payloadBytes_ = 0;
  std::uint64_t pageCount_ = 0;
  std::uint64_t xmlLogicalOffset_ = 0;
  std::uint64_t xmlLogicalLength_ = 0;
  std::vector<unsigned char> pageBytes_;
  std::uint64_t loadedPage_ = std::numeric_limits<std::uint64_t>::max();
};

// ---------------------------------------------------------------------------------------------
// XML

/// Throws InputError located at an element path such as /data3D/0/points.
[[noreturn]] void failAtElement(const fs::path& file, const std::string& elementPath, const std::string& message) {
  throw InputError(file, "element " + elementPath, message);
}

std::string_view trimmed(const char* text) {
  std::string_view view(text);
  const auto first = view.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos) return {};
  const auto last = view.find_last_not_of(" \t\r\n");
  return view.substr(first, last - first + 1);
}

std::string_view typeOf(pugi::xml_node node) { return node.attribute("type").value(); }

/// Text from the file for a message: quoted, at most 40 characters, non-printable ones as '?'.
std::string quoted(std::string_view text) {
  constexpr std::size_t kMaxShown = 40;
  std::string shown = "\"";
  for (const char c : text.substr(0, kMaxShown)) shown += std::isprint(static_cast<unsigned char>(c)) ? c : '?';
  if (text.size() > kMaxShown) shown += "...";
  return shown + "\"";
}

std::int64_t parseInteger(std::string_view text, const fs::path& file, const std::string& where, const char* what) {
  std::int64_t value = 0;
  if (!parseNumber(text, value)) {
    failAtElement(file, where, std::string(what) + " " + quoted(text) + " is not an integer");
  }
  return value;
}

double parseFloat(std::string_view text, const fs::path& file, const std::string& where, const char* what) {
  double value = 0.0;
  if (!parseNumber(text, value)) {
    failAtElement(file, where, std::string(what) + " " + quoted(text) + " is not a number");
  }
  return value;
}

std::int64_t integerAttribute(pugi::xml_node node, const char* name, std::int64_t fallback, const fs::path& file,
                              const std::string& path) {
  const pugi::xml_attribute attribute = node.attribute(name);
  return attribute ? parseInteger(trimmed(attribute.value()), file, path, name) : fallback;
}

double floatAttribute(pugi::xml_node node, const char* name, double fallback, const fs::path& file,
                      const std::string& path) {
  const pugi::xml_attribute attribute = node.attribute(name);
  return attribute ? parseFloat(trimmed(attribute.value()), file, path, name) : fallback;
}

/// A count or offset attribute: present and non-negative.
std::uint64_t requiredCountAttribute(pugi::xml_node node, const char* name, const fs::path& file,
                                     const std::string& path) {
  if (!node.attribute(name)) failAtElement(file, path, std::string("missing attribute ") + name);
  const std::int64_t value = integerAttribute(node, name, 0, file, path);
  if (value < 0) failAtElement(file, path, std::string(name) + " " + std::to_string(value) + " is negative");
  return static_cast<std::uint64_t>(value);
}

pugi::xml_node requireChild(pugi::xml_node parent, const char* name, const fs::path& file,
                            const std::string& parentPath, const std::string& expected) {
  const pugi::xml_node child = parent.child(name);
  if (!child) failAtElement(file, parentPath + "/" + name, "missing, expected " + expected);
  return child;
}

/// The value of an Integer, ScaledInteger or Float element (an empty element means 0).
double numberValue(pugi::xml_node node, const fs::path& file, const std::string& path) {
  const std::string_view type = typeOf(node);
  const std::string_view text = trimmed(node.child_value());
  if (type == "Float") return text.empty() ? 0.0 : parseFloat(text, file, path, "value");
  if (type != "Integer" && type != "ScaledInteger") {
    failAtElement(file, path, "type " + quoted(type) + ", expected a number (Float, ScaledInteger or Integer)");
  }
  const std::int64_t raw = text.empty() ? 0 : parseInteger(text, file, path, "value");
  if (type == "Integer") return static_cast<double>(raw);
  return static_cast<double>(raw) * floatAttribute(node, "scale", 1.0, file, path) +
         floatAttribute(node, "offset", 0.0, file, path);
}

// ---------------------------------------------------------------------------------------------
// Scans

enum class FieldKind { Float32, Float64, Integer, ScaledInteger };

/// One terminal field of a CompressedVector prototype; it is stored as one bytestream.
struct Field {
  std::string name;  // nested structures join their names with '/'
  std::string path;  // element path, for error messages
  FieldKind kind = FieldKind::Float64;
  std::int64_t minimum = 0;  // Integer and ScaledInteger: the stored value is raw - minimum
  std::int64_t maximum = 0;
  double scale = 1.0;
  double offset = 0.0;
  std::optional<double> floatMinimum;  // Float: declared bounds, when given
  std::optional<double> floatMaximum;
  unsigned bits = 0;  // bit width of one value; 0 for a constant field

  /// The value a stored bit pattern stands for.
  double decode(std::uint64_t stored) const {
    switch (kind) {
      case FieldKind::Float32: {
        const auto pattern = static_cast<std::uint32_t>(stored);
        float value;
        std::memcpy(&value, &pattern, sizeof value);
        return value;
      }
      case FieldKind::Float64: {
        double value;
        std::memcpy(&value, &stored, sizeof value);
        return value;
      }
      case FieldKind::Integer:
      case FieldKind::ScaledInteger: {
        // Unsigned addition wraps where signed addition would overflow; the sum lies in [min, max].
        const auto raw = static_cast<std::int64_t>(static_cast<std::uint64_t>(minimum) + stored);
        return kind == FieldKind::Integer ? static_cast<double>(raw) : static_cast<double>(raw) * scale + offset;
      }
    }
    return 0.0;
  }
};

/// Bits needed to store every value of [minimum, maximum]: ceil(log2(maximum - minimum + 1)).
unsigned bitWidth(std::int64_t minimum, std::int64_t maximum) {
  std::uint64_t span = static_cast<std::uint64_t>(maximum) - static_cast<std::uint64_t>(minimum);
  unsigned bits = 0;
  while (span != 0) {
    ++bits;
    span >>= 1;
  }
  return bits;
}

Field parseField(pugi::xml_node node, const std::string& name, const std::string& path, const fs::path& file) {
  Field field;
  field.name = name;
  field.path = path;
  const std::string_view type = typeOf(node);
  if (type == "Float") {
    const std::string_view precision = trimmed(node.attribute("precision").value());
    if (precision.empty() || precision == "double") {
      field.kind = FieldKind::Float64;
      field.bits = 64;
    } else if (precision == "single") {
      field.kind = FieldKind::Float32;
      field.bits = 32;
    } else {
      failAtElement(file, path, "precision " + quoted(precision) + ", expected single or double");
    }
    if (node.attribute("minimum")) field.floatMinimum = floatAttribute(node, "minimum", 0.0, file, path);
    if (node.attribute("maximum")) field.floatMaximum = floatAttribute(node, "maximum", 0.0, file, path);
  } else if (type == "Integer" || type == "ScaledInteger") {
    field.kind = type == "Integer" ? FieldKind::Integer : FieldKind::ScaledInteger;
    field.minimum = integerAttribute(node, "minimum", std::numeric_limits<std::int64_t>::min(), file, path);
    field.maximum = integerAttribute(node, "maximum", std::numeric_limits<std::int64_t>::max(), file, path);
    if (field.minimum > field.maximum) {
      failAtElement(
          file, path,
          "minimum " + std::to_string(field.minimum) + " is greater than maximum " + std::to_string(field.maximum));
    }
    field.bits = bitWidth(field.minimum, field.maximum);
    field.scale = floatAttribute(node, "scale", 1.0, file, path);
    field.offset = floatAttribute(node, "offset", 0.0, file, path);
  } else {
    failAtElement(file, path, "unsupported field type " + quoted(type) + ", expected Float, ScaledInteger or Integer");
  }
  return field;
}

/// The prototype's terminal fields in depth-first order, which is the order of the bytestreams.
void collectFields(pugi::xml_node structure, const std::string& namePrefix, const std::string& path,
                   const fs::path& file, std::vector<Field>& fields) {
  for (const pugi::xml_node child : structure.children()) {
    if (child.type() != pugi::node_element) continue;
    const std::string name = namePrefix + child.name();
    const std::string childPath = path + "/" + child.name();
    if (typeOf(child) == "Structure") {
      collectFields(child, name + "/", childPath, file, fields);
    } else {
      fields.push_back(parseField(child, name, childPath, file));
    }
  }
}

/// Index of a field with a given role in a scan's prototype, or kAbsent.
using FieldIndex = std::size_t;
constexpr FieldIndex kAbsent = std::numeric_limits<FieldIndex>::max();

/// Maps a colour field's declared range onto 0..255.
struct ColorScale {
  FieldIndex field = kAbsent;
  double low = 0.0;
  double factor = 1.0;

  std::uint8_t operator()(double value) const {
    return static_cast<std::uint8_t>(std::clamp(std::round((value - low) * factor), 0.0, 255.0));
  }
};

struct Scan {
  std::string path;  // /data3D/N
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  std::vector<Field> fields;
  std::uint64_t recordCount = 0;
  std::uint64_t sectionBegin = 0;  // logical offsets of the binary section and its first packet
  std::uint64_t sectionEnd = 0;
  std::uint64_t dataBegin = 0;

  bool spherical = false;  // coordinates are range, azimuth, elevation
  std::array<FieldIndex, 3> coordinates{kAbsent, kAbsent, kAbsent};
  FieldIndex invalidState = kAbsent;
  FieldIndex intensity = kAbsent;
  std::array<ColorScale, 3> colors;
  std::array<FieldIndex, 3> normals{kAbsent, kAbsent, kAbsent};

  bool hasColors() const { return colors[0].field != kAbsent; }
  bool hasNormals() const { return normals[0] != kAbsent; }
};

FieldIndex fieldIndex(const std::vector<Field>& fields, std::string_view name) {
  for (FieldIndex i = 0; i < fields.size(); ++i) {
    if (fields[i].name == name) return i;
  }
  return kAbsent;
}

/// The declared range of a colour field in the units of its values.
std::pair<double, double> colorRange(const Field& field, pugi::xml_node scanNode, const char* channel,
                                     const fs::path& file, const std::string& scanPath) {
  switch (field.kind) {
    case FieldKind::Integer:
      return {static_cast<double>(field.minimum), static_cast<double>(field.maximum)};
    case FieldKind::ScaledInteger: {
      const double a = static_cast<double>(field.minimum) * field.scale + field.offset;
      const double b = static_cast<double>(field.maximum) * field.scale + field.offset;
      return {std::min(a, b), std::max(a, b)};
    }
    case FieldKind::Float32:
    case FieldKind::Float64:
      break;
  }
  if (field.floatMinimum && field.floatMaximum) return {*field.floatMinimum, *field.floatMaximum};
  // Float colours without bounds: the scan's colorLimits give the range.
  const std::string limitsPath = scanPath + "/colorLimits";
  const pugi::xml_node limits = scanNode.child("colorLimits");
  const std::string minimumName = std::string(channel) + "Minimum";
  const std::string maximumName = std::string(channel) + "Maximum";
  const pugi::xml_node minimum = limits.child(minimumName.c_str());
  const pugi::xml_node maximum = limits.child(maximumName.c_str());
  if (!minimum || !maximum) {
    failAtElement(file, field.path,
                  "Float colour without minimum and maximum, expected them or " + limitsPath + "/" + minimumName +
                      " and " + maximumName + " to scale colours by");
  }
  return {numberValue(minimum, file, limitsPath + "/" + minimumName),
          numberValue(maximum, file, limitsPath + "/" + maximumName)};
}

void readPose(pugi::xml_node scanNode, const fs::path& file, Scan& scan) {
  const pugi::xml_node pose = scanNode.child("pose");
  if (!pose) return;  // the scan is in file coordinates already
  const std::string posePath = scan.path + "/pose";
  auto component = [&](pugi::xml_node parent, const std::string& parentPath, const char* name) {
    return numberValue(requireChild(parent, name, file, parentPath, "a number"), file, parentPath + "/" + name);
  };
  if (const pugi::xml_node rotation = pose.child("rotation")) {
    const std::string path = posePath + "/rotation";
    const Eigen::Quaterniond q(component(rotation, path, "w"), component(rotation, path, "x"),
                               component(rotation, path, "y"), component(rotation, path, "z"));
    if (!(q.norm() > 0.0) || !std::isfinite(q.norm())) {
      failAtElement(file, path, "rotation quaternion has no direction, expected a unit quaternion");
    }
    scan.rotation = q.normalized().toRotationMatrix();
  }
  if (const pugi::xml_node translation = pose.child("translation")) {
    const std::string path = posePath + "/translation";
    scan.translation = {component(translation, path, "x"), component(translation, path, "y"),
                        component(translation, path, "z")};
  }
}

/// Finds the coordinate, state, intensity, normal and colour fields of a scan's prototype.
void assignRoles(pugi::xml_node scanNode, const std::string& prototypePath, const std::string& normalsPrefix,
                 const fs::path& file, Scan& scan) {
  const std::array<FieldIndex, 3> cartesian{fieldIndex(scan.fields, "cartesianX"),
                                            fieldIndex(scan.fields, "cartesianY"),
                                            fieldIndex(scan.fields, "cartesianZ")};
  const std::array<FieldIndex, 3> spherical{fieldIndex(scan.fields, "sphericalRange"),
                                            fieldIndex(scan.fields, "sphericalAzimuth"),
                                            fieldIndex(scan.fields, "sphericalElevation")};
  auto complete = [](const std::array<FieldIndex, 3>& roles) {
    return std::all_of(roles.begin(), roles.end(), [](FieldIndex i) { return i != kAbsent; });
  };
  if (complete(cartesian)) {
    scan.coordinates = cartesian;
    scan.invalidState = fieldIndex(scan.fields, "cartesianInvalidState");
  } else if (complete(spherical)) {
    scan.spherical = true;
    scan.coordinates = spherical;
    scan.invalidState = fieldIndex(scan.fields, "sphericalInvalidState");
  } else {
    failAtElement(file, prototypePath,
                  "no coordinates, expected cartesianX/Y/Z or sphericalRange/Azimuth/Elevation fields");
  }
  scan.intensity = fieldIndex(scan.fields, "intensity");
  if (!normalsPrefix.empty()) {
    const std::array<FieldIndex, 3> normals{fieldIndex(scan.fields, normalsPrefix + ":normalX"),
                                            fieldIndex(scan.fields, normalsPrefix + ":normalY"),
                                            fieldIndex(scan.fields, normalsPrefix + ":normalZ")};
    if (complete(normals)) scan.normals = normals;
  }

  static constexpr std::array<const char*, 3> kChannels{"colorRed", "colorGreen", "colorBlue"};
  std::array<FieldIndex, 3> colorFields{};
  for (std::size_t c = 0; c < 3; ++c) colorFields[c] = fieldIndex(scan.fields, kChannels[c]);
  if (!complete(colorFields)) return;
  for (std::size_t c = 0; c < 3; ++c) {
    const Field& field = scan.fields[colorFields[c]];
    const auto [low, high] = colorRange(field, scanNode, kChannels[c], file, scan.path);
    ColorScale& scale = scan.colors[c];
    scale.field = colorFields[c];
    // A degenerate range leaves values as they are (clamped to 0..255).
    if (std::isfinite(low) && std::isfinite(high) && high > low) {
      scale.low = low;
      scale.factor = 255.0 / (high - low);
    }
  }
}

void checkCodecs(pugi::xml_node points, const fs::path& file, const std::string& pointsPath) {
  std::size_t index = 0;
  for (const pugi::xml_node codec : points.child("codecs").children("vectorChild")) {
    if (!codec.child("bitPackCodec")) {
      failAtElement(file, pointsPath + "/codecs/" + std::to_string(index), "unsupported codec, expected bitPackCodec");
    }
    ++index;
  }
}

/// Reads the CompressedVector section header and checks that the declared records can fit in it.
void openSection(PagedFile& paged, std::uint64_t sectionPhysical, const std::string& pointsPath, Scan& scan) {
  const fs::path& file = paged.path();
  if (!paged.holdsData(sectionPhysical)) {
    failAtElement(file, pointsPath,
                  "fileOffset " + std::to_string(sectionPhysical) +
                      " points into a page checksum or past the end, expected a binary section");
  }
  scan.sectionBegin = paged.toLogical(sectionPhysical);
  unsigned char header[kSectionHeaderBytes];
  paged.readLogical(scan.sectionBegin, header, sizeof header, "CompressedVector section header");
  if (header[0] != kCompressedVectorSectionId) {
    paged.failAt(sectionPhysical, "section id " + std::to_string(header[0]) + ", expected " +
                                      std::to_string(kCompressedVectorSectionId) + " (CompressedVector section) for " +
                                      pointsPath);
  }
  const auto sectionLength = loadLE<std::uint64_t>(header + 8);
  const auto dataPhysical = loadLE<std::uint64_t>(header + 16);
  const std::uint64_t available = paged.logicalLength() - scan.sectionBegin;
  if (sectionLength < kSectionHeaderBytes || sectionLength > available) {
    paged.failAt(paged.toPhysical(scan.sectionBegin + 8), "sectionLogicalLength " + std::to_string(sectionLength) +
                                                              ", expected " + std::to_string(kSectionHeaderBytes) +
                                                              " to " + std::to_string(available) + " bytes");
  }
  scan.sectionEnd = scan.sectionBegin + sectionLength;

  // Even a scan of constant fields is held to one bit a record, so that the declared count, which
  // callers reserve memory for, stays within what the file could describe.
  std::uint64_t bitsPerRecord = 0;
  for (const Field& field : scan.fields) bitsPerRecord += field.bits;
  const std::uint64_t sectionBits = sectionLength * 8;
  if (scan.recordCount > sectionBits / std::max<std::uint64_t>(bitsPerRecord, 1)) {
    failAtElement(file, pointsPath,
                  "recordCount " + std::to_string(scan.recordCount) + " at " + std::to_string(bitsPerRecord) +
                      " bits a record is more than the " + std::to_string(sectionLength) +
                      "-byte binary section can hold");
  }
  if (scan.recordCount == 0) return;
  const bool insideSection = paged.holdsData(dataPhysical) &&
                             paged.toLogical(dataPhysical) >= scan.sectionBegin + kSectionHeaderBytes &&
                             paged.toLogical(dataPhysical) < scan.sectionEnd;
  if (!insideSection) {
    paged.failAt(paged.toPhysical(scan.sectionBegin + 16), "dataPhysicalOffset " + std::to_string(dataPhysical) +
                                                               " lies outside its section, expected the first packet");
  }
  scan.dataBegin = paged.toLogical(dataPhysical);
}

/// The namespace prefix the file binds to the surface-normals extension, or "" when it has none.
std::string normalsPrefix(pugi::xml_node root) {
  constexpr std::string_view kDeclaration = "xmlns:";
  for (const pugi::xml_attribute attribute : root.attributes()) {
    const std::string_view name = attribute.name();
    if (name.substr(0, kDeclaration.size()) == kDeclaration && attribute.value() == kNormalsNamespace) {
      return std::string(name.substr(kDeclaration.size()));
    }
  }
  return {};
}

Scan parseScan(pugi::xml_node node, const std::string& path, const std::string& normalsPrefix, PagedFile& paged) {
  const fs::path& file = paged.path();
  Scan scan;
  scan.path = path;
  readPose(node, file, scan);

  const pugi::xml_node points = requireChild(node, "points", file, path, "the CompressedVector of points");
  const std::string pointsPath = path + "/points";
  if (typeOf(points) != "CompressedVector") {
    failAtElement(file, pointsPath, "type " + quoted(typeOf(points)) + ", expected CompressedVector");
  }
  const pugi::xml_node prototype = requireChild(points, "prototype", file, pointsPath, "the Structure of a record");
  const std::string prototypePath = pointsPath + "/prototype";
  collectFields(prototype, "", prototypePath, file, scan.fields);
  assignRoles(node, prototypePath, normalsPrefix, file, scan);
  checkCodecs(points, file, pointsPath);

  scan.recordCount = requiredCountAttribute(points, "recordCount", file, pointsPath);
  openSection(paged, requiredCountAttribute(points, "fileOffset", file, pointsPath), pointsPath, scan);
  return scan;
}

// ---------------------------------------------------------------------------------------------
// Bytestreams

/// The pending bytes of one field's bytestream: appended packet by packet, consumed value by value
/// (least significant bit first).
class BitStream {
 public:
  std::uint64_t availableValues(unsigned bits) const { return (bytes_.size() * 8 - bitPosition_) / bits; }

  /// Room for `size` more bytes at the end; consumed bytes are dropped first.
  unsigned char* extend(std::size_t size) {
    const std::size_t consumed = static_cast<std::size_t>(bitPosition_ / 8);
    bytes_.erase(bytes_.begin(), bytes_.begin() + static_cast<std::ptrdiff_t>(consumed));
    bitPosition_ -= consumed * 8;
    const std::size_t end = bytes_.size();
    bytes_.resize(end + size);
    return bytes_.data() + end;
  }

  /// Takes the next value of `bits` bits (1..64); the caller checked availableValues().
  std::uint64_t take(unsigned bits) {
    const std::size_t byte = static_cast<std::size_t>(bitPosition_ / 8);
    const unsigned shift = static_cast<unsigned>(bitPosition_ % 8);
    std::uint64_t value = 0;
    if (byte + 8 <= bytes_.size() && shift + bits <= 64) {
      value = loadLE<std::uint64_t>(bytes_.data() + byte) >> shift;
    } else {
      unsigned gathered = 0;
      for (std::size_t b = byte; gathered < bits; ++b) {
        value |= static_cast<std::uint64_t>(bytes_[b] >> (b == byte ? shift : 0)) << gathered;
        gathered += b == byte ? 8 - shift : 8;
      }
    }
    if (bits < 64) value &= (std::uint64_t{1} << bits) - 1;
    bitPosition_ += bits;
    return value;
  }

 private:
  std::vector<unsigned char> bytes_;
  std::uint64_t bitPosition_ = 0;
};

// ---------------------------------------------------------------------------------------------
// Reader

class E57Reader final : public PointReader {
 public:
  explicit E57Reader(const fs::path& path) : paged_(path) {
    pugi::xml_document document;
    parseXml(document);
    const pugi::xml_node root = document.child("e57Root");
    if (!root) failAtElement(path, "/e57Root", "missing, expected the E57 root element");
    const pugi::xml_node data3D = requireChild(root, "data3D", path, "", "the Vector of scans");
    const std::string normalsNamespacePrefix = normalsPrefix(root);
    for (const pugi::xml_node child : data3D.children("vectorChild")) {
      scans_.push_back(parseScan(child, "/data3D/" + std::to_string(scans_.size()), normalsNamespacePrefix, paged_));
    }
    describe();
    if (!scans_.empty()) startScan(0);
  }

  const CloudInfo& info() const override { return info_; }

  std::size_t read(PointChunk& chunk, std::size_t maxPoints) override {
    chunk.clear();
    while (chunk.size() < maxPoints && scanIndex_ < scans_.size()) {
      const Scan& scan = scans_[scanIndex_];
      const std::uint64_t left = scan.recordCount - recordsDecoded_;
      if (left == 0) {
        bytesDone_ += scan.sectionEnd - nextPacket_;  // trailing index or empty packets
        startScan(scanIndex_ + 1);
        continue;
      }
      const std::uint64_t ready = std::min(left, decodableRecords(scan));
      if (ready == 0) {
        readPacket(scan);
        continue;
      }
      decodeRecords(scan, static_cast<std::size_t>(std::min<std::uint64_t>(ready, maxPoints - chunk.size())), chunk);
    }
    return chunk.size();
  }

  double progress() const override {
    if (totalSectionBytes_ == 0) return scanIndex_ >= scans_.size() ? 1.0 : 0.0;
    return std::min(1.0, static_cast<double>(bytesDone_) / static_cast<double>(totalSectionBytes_));
  }

 private:
  void parseXml(pugi::xml_document& document) {
    // The XML section is read whole: pugixml parses a complete buffer, and the section is small
    // next to the binary data (a few kilobytes per scan).
    std::string xml(static_cast<std::size_t>(paged_.xmlLogicalLength()), '\0');
    paged_.readLogical(paged_.xmlLogicalOffset(), xml.data(), xml.size(), "XML section");
    const pugi::xml_parse_result result =
        document.load_buffer(xml.data(), xml.size(), pugi::parse_default, pugi::encoding_utf8);
    if (!result) {
      const auto at = paged_.toPhysical(paged_.xmlLogicalOffset() +
                                        static_cast<std::uint64_t>(std::max<std::ptrdiff_t>(result.offset, 0)));
      paged_.failAt(at, std::string("XML is not well-formed: ") + result.description());
    }
  }

  void describe() {
    info_.format = "E57 " + std::to_string(paged_.majorVersion()) + "." + std::to_string(paged_.minorVersion());
    std::uint64_t total = 0;
    for (const Scan& scan : scans_) {
      for (const Field& field : scan.fields) {
        if (std::find(info_.fields.begin(), info_.fields.end(), field.name) == info_.fields.end()) {
          info_.fields.push_back(field.name);
        }
      }
      if (scan.hasNormals()) info_.attributes |= kNormals;
      if (scan.hasColors()) info_.attributes |= kColors;
      if (scan.intensity != kAbsent) info_.attributes |= kIntensity;
      total += scan.recordCount;  // each count is bounded by its section, so the sum cannot wrap
      totalSectionBytes_ += scan.sectionEnd - scan.sectionBegin;
    }
    info_.declaredPoints = total;
  }

  void startScan(std::size_t index) {
    scanIndex_ = index;
    if (index >= scans_.size()) return;
    const Scan& scan = scans_[index];
    bytesDone_ += scan.dataBegin > scan.sectionBegin ? scan.dataBegin - scan.sectionBegin : kSectionHeaderBytes;
    nextPacket_ = std::max(scan.dataBegin, scan.sectionBegin + kSectionHeaderBytes);
    recordsDecoded_ = 0;
    streams_.assign(scan.fields.size(), BitStream());
    values_.resize(scan.fields.size());
  }

  std::uint64_t decodableRecords(const Scan& scan) const {
    std::uint64_t ready = std::numeric_limits<std::uint64_t>::max();
    for (std::size_t f = 0; f < scan.fields.size(); ++f) {
      if (scan.fields[f].bits > 0) ready = std::min(ready, streams_[f].availableValues(scan.fields[f].bits));
    }
    return ready;
  }

  /// Reads the packet at nextPacket_, appending a data packet's buffers to the bytestreams.
  /// Always advances nextPacket_ or throws.
  void readPacket(const Scan& scan) {
    const std::uint64_t packet = nextPacket_;
    const std::uint64_t packetPhysical = paged_.toPhysical(packet);
    if (packet + kPacketHeaderBytes > scan.sectionEnd) {
      paged_.failAt(packetPhysical, "data ends after " + std::to_string(recordsDecoded_) + " of " +
                                        std::to_string(scan.recordCount) + " records of " + scan.path +
                                        "/points, expected more data packets");
    }
    unsigned char header[kDataPacketHeaderBytes] = {};
    paged_.readLogical(packet, header, kPacketHeaderBytes, "packet header");
    const std::uint8_t type = header[0];
    const std::uint64_t length = std::uint64_t{loadLE<std::uint16_t>(header + 2)} + 1;
    if (type != kIndexPacket && type != kDataPacket && type != kEmptyPacket) {
      paged_.failAt(packetPhysical,
                    "bad packet type " + std::to_string(type) + ", expected 0 (index), 1 (data) or 2 (empty)");
    }
    if (length > scan.sectionEnd - packet) {
      paged_.failAt(packetPhysical, "bad packet length " + std::to_string(length) +
                                        ": the packet runs past the end of its section (" +
                                        std::to_string(scan.sectionEnd - packet) + " bytes left)");
    }
    if (length < kPacketHeaderBytes) {
      paged_.failAt(packetPhysical, "bad packet length " + std::to_string(length) + ", expected at least its " +
                                        std::to_string(kPacketHeaderBytes) + "-byte header");
    }
    nextPacket_ += length;
    bytesDone_ += length;
    if (type != kDataPacket) return;

    paged_.readLogical(packet + kPacketHeaderBytes, header + kPacketHeaderBytes, 2, "data packet header");
    const std::size_t streamCount = loadLE<std::uint16_t>(header + kPacketHeaderBytes);
    if (streamCount != scan.fields.size()) {
      paged_.failAt(packetPhysical, "bytestreamCount " + std::to_string(streamCount) + ", expected " +
                                        std::to_string(scan.fields.size()) + " (one per prototype field)");
    }
    const std::uint64_t lengthsBytes = 2 * std::uint64_t{streamCount};
    if (kDataPacketHeaderBytes + lengthsBytes > length) {
      paged_.failAt(packetPhysical, "bad packet length " + std::to_string(length) + ", shorter than its header of " +
                                        std::to_string(kDataPacketHeaderBytes + lengthsBytes) + " bytes");
    }
    bufferLengths_.resize(streamCount);
    std::uint64_t payload = kDataPacketHeaderBytes + lengthsBytes;
    for (std::size_t s = 0; s < streamCount; ++s) {
      bufferLengths_[s] =
          paged_.readLogicalLE<std::uint16_t>(packet + kDataPacketHeaderBytes + 2 * s, "bytestream length");
      payload += bufferLengths_[s];
    }
    if (payload > length) {
      paged_.failAt(packetPhysical, "bytestream lengths add up to " + std::to_string(payload) +
                                        " bytes with the header, more than the packet length " +
                                        std::to_string(length));
    }
    std::uint64_t buffer = packet + kDataPacketHeaderBytes + lengthsBytes;
    for (std::size_t s = 0; s < streamCount; ++s) {
      // A constant field's values need no bytes; anything a writer put there carries nothing.
      if (scan.fields[s].bits > 0 && bufferLengths_[s] > 0) {
        paged_.readLogical(buffer, streams_[s].extend(bufferLengths_[s]), bufferLengths_[s], "bytestream buffer");
      }
      buffer += bufferLengths_[s];
    }
  }

  void decodeRecords(const Scan& scan, std::size_t count, PointChunk& chunk) {
    const bool wantNormals = info_.attributes & kNormals;
    const bool wantColors = info_.attributes & kColors;
    const bool wantIntensity = info_.attributes & kIntensity;
    const std::size_t fieldCount = scan.fields.size();
    for (std::size_t r = 0; r < count; ++r) {
      for (std::size_t f = 0; f < fieldCount; ++f) {
        const Field& field = scan.fields[f];
        values_[f] = field.decode(field.bits > 0 ? streams_[f].take(field.bits) : 0);
      }
      if (scan.invalidState != kAbsent && values_[scan.invalidState] != kInvalidStateValid) {
        continue;  // 1 = direction only, 2 = no return: neither gives a position
      }
      const double a = values_[scan.coordinates[0]];
      const double b = values_[scan.coordinates[1]];
      const double c = values_[scan.coordinates[2]];
      const Eigen::Vector3d local = scan.spherical ? Eigen::Vector3d(a * std::cos(c) * std::cos(b),
                                                                     a * std::cos(c) * std::sin(b), a * std::sin(c))
                                                   : Eigen::Vector3d(a, b, c);
      chunk.positions.push_back(scan.rotation * local + scan.translation);
      // Scans without normals, colour or intensity get zero normals, black and 0 where another
      // scan of the file has them.
      if (wantNormals) {
        Eigen::Vector3f normal = Eigen::Vector3f::Zero();
        if (scan.hasNormals()) {
          const Eigen::Vector3d n(values_[scan.normals[0]], values_[scan.normals[1]], values_[scan.normals[2]]);
          normal = (scan.rotation * n).cast<float>();
        }
        chunk.normals.push_back(normal);
      }
      if (wantColors) {
        Color color = Color::Zero();
        if (scan.hasColors()) {
          for (std::size_t k = 0; k < 3; ++k) color[k] = scan.colors[k](values_[scan.colors[k].field]);
        }
        chunk.colors.push_back(color);
      }
      if (wantIntensity) {
        chunk.intensities.push_back(scan.intensity != kAbsent ? static_cast<float>(values_[scan.intensity]) : 0.0f);
      }
    }
    recordsDecoded_ += count;
  }

  PagedFile paged_;
  CloudInfo info_;
  std::vector<Scan> scans_;
  std::uint64_t totalSectionBytes_ = 0;

  // Position in the stream.
  std::size_t scanIndex_ = 0;
  std::uint64_t nextPacket_ = 0;  // logical offset of the next packet of the current scan
  std::uint64_t recordsDecoded_ = 0;
  std::uint64_t bytesDone_ = 0;
  std::vector<BitStream> streams_;
  std::vector<double> values_;
  std::vector<std::uint16_t> bufferLengths_;
};

}  // namespace

std::unique_ptr<PointReader> openE57Reader(const std::filesystem::path& path) {
  return std::make_unique<E57Reader>(path);
}

}  // namespace piperun::io
