#include "e57_test_writer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>

#include "io/e57_checksum.h"

namespace piperun::test {

namespace {

constexpr std::size_t kFileHeaderBytes = 48;
constexpr std::size_t kSectionHeaderBytes = 32;
constexpr std::size_t kDataPacketHeaderBytes = 6;
constexpr std::uint64_t kChecksumBytes = 4;

void putLE(std::string& out, std::uint64_t value, std::size_t size) { out += littleEndianBytes(value, size); }

void overwriteLE(std::string& out, std::size_t at, std::uint64_t value, std::size_t size) {
  out.replace(at, size, littleEndianBytes(value, size));
}

void padTo(std::string& out, std::size_t multiple) {
  while (out.size() % multiple != 0) out.push_back('\0');
}

/// Appends values least significant bit first, one bit at a time (simple on purpose: the reader's
/// word-wise decoding is checked against it).
class BitWriter {
 public:
  void put(std::uint64_t value, unsigned bits) {
    for (unsigned i = 0; i < bits; ++i) {
      if (bitCount_ % 8 == 0) bytes_.push_back('\0');
      if ((value >> i) & 1u) bytes_.back() = static_cast<char>(bytes_.back() | (1 << (bitCount_ % 8)));
      ++bitCount_;
    }
  }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
  std::uint64_t bitCount_ = 0;
};

unsigned bitWidth(std::int64_t minimum, std::int64_t maximum) {
  std::uint64_t span = static_cast<std::uint64_t>(maximum) - static_cast<std::uint64_t>(minimum);
  unsigned bits = 0;
  for (; span != 0; span >>= 1) ++bits;
  return bits;
}

/// The bytestream of one field.
std::string encodeField(const E57TestField& field) {
  BitWriter writer;
  for (const double value : field.values) {
    switch (field.type) {
      case E57TestField::Type::Float32: {
        const float single = static_cast<float>(value);
        std::uint32_t pattern;
        std::memcpy(&pattern, &single, sizeof pattern);
        writer.put(pattern, 32);
        break;
      }
      case E57TestField::Type::Float64: {
        std::uint64_t pattern;
        std::memcpy(&pattern, &value, sizeof pattern);
        writer.put(pattern, 64);
        break;
      }
      case E57TestField::Type::ScaledInteger:
      case E57TestField::Type::Integer: {
        const double raw = field.type == E57TestField::Type::Integer ? value : (value - field.offset) / field.scale;
        const auto integer = static_cast<std::int64_t>(std::llround(raw));
        if (integer < field.minimum || integer > field.maximum) {
          throw std::invalid_argument("E57 test writer: value of " + field.name + " outside its declared range");
        }
        writer.put(static_cast<std::uint64_t>(integer) - static_cast<std::uint64_t>(field.minimum),
                   bitWidth(field.minimum, field.maximum));
        break;
      }
    }
  }
  return writer.bytes();
}

class Layout {
 public:
  explicit Layout(std::uint64_t pageSize) : pageSize_(pageSize), payload_(pageSize - kChecksumBytes) {}
  std::uint64_t physical(std::uint64_t logical) const { return logical / payload_ * pageSize_ + logical % payload_; }
  std::uint64_t payload() const { return payload_; }

 private:
  std::uint64_t pageSize_;
  std::uint64_t payload_;
};

std::uint64_t recordCount(const E57TestScan& scan) {
  const std::uint64_t count = scan.fields.empty() ? 0 : scan.fields.front().values.size();
  for (const E57TestField& field : scan.fields) {
    if (field.values.size() != count) throw std::invalid_argument("E57 test writer: fields of unequal length");
  }
  return count;
}

/// Appends one scan's CompressedVector binary section to `logical`; returns its layout.
E57TestLayout::Section writeSection(std::string& logical, const E57TestScan& scan, const Layout& layout,
                                    const E57TestOptions& options) {
  padTo(logical, 8);
  E57TestLayout::Section section;
  const std::size_t begin = logical.size();
  section.header = layout.physical(begin);
  logical.append(kSectionHeaderBytes, '\0');

  std::vector<std::string> streams;
  std::uint64_t totalBytes = 0;
  for (const E57TestField& field : scan.fields) {
    streams.push_back(encodeField(field));
    totalBytes += streams.back().size();
  }
  const std::size_t headerBytes = kDataPacketHeaderBytes + 2 * streams.size();
  // Shares proportional to each stream's size keep the streams roughly in step; room is left for
  // rounding each share up to 1 byte and for the padding to 4 bytes.
  if (options.maxPacketBytes % 4 != 0 || options.maxPacketBytes > 65536 ||
      options.maxPacketBytes <= headerBytes + 3 + streams.size()) {
    throw std::invalid_argument("E57 test writer: maxPacketBytes too small or not a multiple of 4");
  }
  const std::uint64_t budget = options.maxPacketBytes - headerBytes - 3 - streams.size();
  std::vector<std::size_t> shares(streams.size()), taken(streams.size(), 0);
  for (std::size_t s = 0; s < streams.size(); ++s) {
    if (!streams[s].empty()) shares[s] = std::max<std::size_t>(1, streams[s].size() * budget / totalBytes);
  }

  std::uint64_t indexPacket = 0;
  auto moreData = [&] {
    for (std::size_t s = 0; s < streams.size(); ++s) {
      if (taken[s] < streams[s].size()) return true;
    }
    return false;
  };
  while (moreData()) {
    const std::size_t packet = logical.size();
    section.dataPackets.push_back(layout.physical(packet));
    std::string body;
    std::string lengths;
    for (std::size_t s = 0; s < streams.size(); ++s) {
      const std::size_t take = std::min(shares[s], streams[s].size() - taken[s]);
      putLE(lengths, take, 2);
      body += streams[s].substr(taken[s], take);
      taken[s] += take;
    }
    std::string bytes;
    bytes.push_back('\x01');  // data packet
    bytes.push_back('\0');    // flags
    putLE(bytes, 0, 2);       // length, set below
    putLE(bytes, streams.size(), 2);
    bytes += lengths + body;
    padTo(bytes, 4);
    overwriteLE(bytes, 2, bytes.size() - 1, 2);
    logical += bytes;

    if (options.emptyAndIndexPackets && section.dataPackets.size() == 1) {
      std::string empty("\x02\0", 2);
      putLE(empty, 7, 2);
      empty.append(4, '\0');
      logical += empty;
    }
  }
  if (options.emptyAndIndexPackets && !section.dataPackets.empty()) {
    indexPacket = layout.physical(logical.size());
    std::string index("\0\0", 2);
    putLE(index, 31, 2);     // 16-byte header + one 16-byte entry
    putLE(index, 1, 2);      // entryCount
    index.append(10, '\0');  // indexLevel 0, reserved
    putLE(index, 0, 8);      // chunkRecordNumber
    putLE(index, section.dataPackets.front(), 8);
    logical += index;
  }

  overwriteLE(logical, begin, 1, 1);  // sectionId: CompressedVector
  overwriteLE(logical, begin + 8, logical.size() - begin, 8);
  overwriteLE(logical, begin + 16, section.dataPackets.empty() ? 0 : section.dataPackets.front(), 8);
  overwriteLE(logical, begin + 24, indexPacket, 8);
  return section;
}

std::string number(double value) {
  std::ostringstream out;
  out.precision(17);
  out << value;
  return out.str();
}

void writeFieldXml(std::ostringstream& xml, const E57TestField& field) {
  xml << "          <" << field.name;
  switch (field.type) {
    case E57TestField::Type::Float32:
    case E57TestField::Type::Float64:
      xml << " type=\"Float\"";
      if (field.type == E57TestField::Type::Float32) xml << " precision=\"single\"";
      if (field.floatMinimum) xml << " minimum=\"" << number(*field.floatMinimum) << "\"";
      if (field.floatMaximum) xml << " maximum=\"" << number(*field.floatMaximum) << "\"";
      break;
    case E57TestField::Type::ScaledInteger:
      xml << " type=\"ScaledInteger\" minimum=\"" << field.minimum << "\" maximum=\"" << field.maximum << "\" scale=\""
          << number(field.scale) << "\" offset=\"" << number(field.offset) << "\"";
      break;
    case E57TestField::Type::Integer:
      xml << " type=\"Integer\" minimum=\"" << field.minimum << "\" maximum=\"" << field.maximum << "\"";
      break;
  }
  xml << "/>\n";
}

std::string makeXml(const std::vector<E57TestScan>& scans, const E57TestLayout& layout) {
  std::ostringstream xml;
  xml << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      << "<e57Root type=\"Structure\" xmlns=\"http://www.astm.org/COMMIT/E57/2010-e57-v1.0\"\n"
      << "         xmlns:nor=\"http://www.libe57.org/E57_NOR_surface_normals.txt\">\n"
      << "  <formatName type=\"String\"><![CDATA[ASTM E57 3D Imaging Data File]]></formatName>\n"
      << "  <guid type=\"String\"><![CDATA[{piperun-test-file}]]></guid>\n"
      << "  <versionMajor type=\"Integer\">1</versionMajor>\n"
      << "  <versionMinor type=\"Integer\"/>\n"
      << "  <coordinateMetadata type=\"String\"/>\n"
      << "  <data3D type=\"Vector\" allowHeterogeneousChildren=\"1\">\n";
  for (std::size_t i = 0; i < scans.size(); ++i) {
    const E57TestScan& scan = scans[i];
    xml << "    <vectorChild type=\"Structure\">\n"
        << "      <guid type=\"String\"><![CDATA[{piperun-test-scan-" << i << "}]]></guid>\n"
        << "      <name type=\"String\"><![CDATA[" << scan.name << "]]></name>\n";
    if (scan.rotation || scan.translation) {
      const Eigen::Quaterniond q = scan.rotation.value_or(Eigen::Quaterniond::Identity());
      const Eigen::Vector3d t = scan.translation.value_or(Eigen::Vector3d::Zero());
      xml << "      <pose type=\"Structure\">\n"
          << "        <rotation type=\"Structure\">\n"
          << "          <w type=\"Float\">" << number(q.w()) << "</w>\n"
          << "          <x type=\"Float\">" << number(q.x()) << "</x>\n"
          << "          <y type=\"Float\">" << number(q.y()) << "</y>\n"
          << "          <z type=\"Float\">" << number(q.z()) << "</z>\n"
          << "        </rotation>\n"
          << "        <translation type=\"Structure\">\n"
          << "          <x type=\"Float\">" << number(t.x()) << "</x>\n"
          << "          <y type=\"Float\">" << number(t.y()) << "</y>\n"
          << "          <z type=\"Float\">" << number(t.z()) << "</z>\n"
          << "        </translation>\n"
          << "      </pose>\n";
    }
    xml << "      <points type=\"CompressedVector\" fileOffset=\"" << layout.sections[i].header << "\" recordCount=\""
        << scan.declaredRecordCount.value_or(recordCount(scan)) << "\">\n"
        << "        <prototype type=\"Structure\">\n";
    for (const E57TestField& field : scan.fields) writeFieldXml(xml, field);
    xml << "        </prototype>\n"
        << "        <codecs type=\"Vector\" allowHeterogeneousChildren=\"1\"/>\n"
        << "      </points>\n"
        << "    </vectorChild>\n";
  }
  xml << "  </data3D>\n"
      << "  <images2D type=\"Vector\" allowHeterogeneousChildren=\"1\"/>\n"
      << "</e57Root>\n";
  return xml.str();
}

void writeChecksum(std::string& file, std::uint64_t page, std::uint64_t pageSize) {
  const std::size_t begin = static_cast<std::size_t>(page * pageSize);
  const std::size_t payload = static_cast<std::size_t>(pageSize - kChecksumBytes);
  const std::uint32_t crc = io::crc32c(reinterpret_cast<const unsigned char*>(file.data() + begin), payload);
  for (std::size_t i = 0; i < kChecksumBytes; ++i) {
    file[begin + payload + i] = static_cast<char>((crc >> (8 * (kChecksumBytes - 1 - i))) & 0xFFu);  // big-endian
  }
}

}  // namespace

std::string littleEndianBytes(std::uint64_t value, std::size_t size) {
  std::string bytes;
  for (std::size_t i = 0; i < size; ++i) bytes.push_back(static_cast<char>((value >> (8 * i)) & 0xFFu));
  return bytes;
}

E57TestLayout writeE57(const std::filesystem::path& path, const std::vector<E57TestScan>& scans,
                       const E57TestOptions& options) {
  const Layout layout(options.pageSize);
  E57TestLayout result;
  std::string logical(kFileHeaderBytes, '\0');
  for (const E57TestScan& scan : scans) result.sections.push_back(writeSection(logical, scan, layout, options));

  std::string xml = makeXml(scans, result);
  if (options.editXml) xml = options.editXml(xml);
  padTo(logical, 8);
  const std::uint64_t xmlLogical = logical.size();
  result.xmlOffset = layout.physical(xmlLogical);
  logical += xml;

  const std::uint64_t pages = (logical.size() + layout.payload() - 1) / layout.payload();
  const std::uint64_t physicalLength = pages * options.pageSize;
  std::string header = "ASTM-E57";
  putLE(header, 1, 4);  // major version
  putLE(header, 0, 4);  // minor version
  putLE(header, physicalLength, 8);
  putLE(header, result.xmlOffset, 8);
  putLE(header, xml.size(), 8);
  putLE(header, options.pageSize, 8);
  logical.replace(0, kFileHeaderBytes, header);

  std::string file(static_cast<std::size_t>(physicalLength), '\0');
  for (std::uint64_t page = 0; page < pages; ++page) {
    const std::size_t from = static_cast<std::size_t>(page * layout.payload());
    const std::size_t count = std::min<std::size_t>(static_cast<std::size_t>(layout.payload()), logical.size() - from);
    std::memcpy(file.data() + page * options.pageSize, logical.data() + from, count);
    writeChecksum(file, page, options.pageSize);
  }
  std::ofstream out(path, std::ios::binary);
  out.write(file.data(), static_cast<std::streamsize>(file.size()));
  if (!out) throw std::runtime_error("E57 test writer: cannot write " + path.string());
  return result;
}

void patchE57(const std::filesystem::path& path, std::uint64_t physicalOffset, const std::string& bytes,
              std::uint64_t pageSize) {
  std::string file;
  {
    std::ifstream in(path, std::ios::binary);
    file.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  std::set<std::uint64_t> touched;
  std::uint64_t at = physicalOffset;
  for (const char byte : bytes) {
    if (at % pageSize >= pageSize - kChecksumBytes) at += kChecksumBytes;  // skip the checksum
    if (at >= file.size()) throw std::out_of_range("E57 test writer: patch past the end of the file");
    file[static_cast<std::size_t>(at)] = byte;
    touched.insert(at / pageSize);
    ++at;
  }
  for (const std::uint64_t page : touched) writeChecksum(file, page, pageSize);
  std::ofstream out(path, std::ios::binary);
  out.write(file.data(), static_cast<std::streamsize>(file.size()));
}

}  // namespace piperun::test
