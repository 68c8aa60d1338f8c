// PLY reader and writer: round trips, hand-written files in every encoding, malformed input.

#include "io/readers.h"
#include "piperun/error.h"
#include "piperun/io/point_reader.h"
#include "piperun/io/point_writer.h"
#include "test_util.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstring>

namespace piperun {
namespace {

using test::TempDir;
using test::writeFile;
using testing::HasSubstr;

/// Deterministic points carrying the requested attributes.
PointChunk makeChunk(std::size_t n, unsigned attributes, double offset = 0.0) {
  PointChunk chunk;
  for (std::size_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(i);
    chunk.positions.emplace_back(offset + 0.25 * t - 3.0, -offset + 1e-3 * t, 0.5 * offset + 2.0 - 0.125 * t);
    if (attributes & kNormals) chunk.normals.push_back(Eigen::Vector3f(1.0f, float(t), 2.0f).normalized());
    if (attributes & kColors) chunk.colors.emplace_back(std::uint8_t(i), std::uint8_t(255 - i), std::uint8_t(3 * i));
    if (attributes & kIntensity) chunk.intensities.push_back(0.5f * float(t) + 0.1f);
    if (attributes & kLabels) chunk.labels.push_back(static_cast<std::int32_t>(i) - 5);
  }
  return chunk;
}

/// All points of a file through the format reader, in chunks of `maxPoints`.
PointChunk readAll(const std::filesystem::path& path, std::size_t maxPoints = 1000) {
  auto reader = io::openPlyReader(path);
  PointChunk all;
  PointChunk chunk;
  while (reader->read(chunk, maxPoints) > 0) {
    EXPECT_LE(chunk.size(), maxPoints);
    chunk.checkConsistent();
    all.positions.insert(all.positions.end(), chunk.positions.begin(), chunk.positions.end());
    all.normals.insert(all.normals.end(), chunk.normals.begin(), chunk.normals.end());
    all.colors.insert(all.colors.end(), chunk.colors.begin(), chunk.colors.end());
    all.intensities.insert(all.intensities.end(), chunk.intensities.begin(), chunk.intensities.end());
    all.labels.insert(all.labels.end(), chunk.labels.begin(), chunk.labels.end());
  }
  EXPECT_DOUBLE_EQ(reader->progress(), 1.0);
  return all;
}

/// Expects InputError whose message contains each of `parts`; returns the message.
template <class Function>
std::string expectInputError(Function&& function, std::initializer_list<const char*> parts) {
  try {
    function();
  } catch (const InputError& error) {
    for (const char* part : parts) EXPECT_THAT(error.what(), HasSubstr(part));
    return error.what();
  }
  ADD_FAILURE() << "no InputError";
  return {};
}

/// Binary records for hand-made files, in either byte order.
class Bytes {
 public:
  explicit Bytes(bool bigEndian = false) : bigEndian_(bigEndian) {}
  template <class T>
  Bytes& put(T value) {
    char raw[sizeof(T)];
    std::memcpy(raw, &value, sizeof(T));
    if (bigEndian_) std::reverse(raw, raw + sizeof(T));
    text_.append(raw, sizeof(T));
    return *this;
  }
  const std::string& str() const { return text_; }

 private:
  bool bigEndian_;
  std::string text_;
};

// ---------------------------------------------------------------------------------------------

TEST(PlyRoundTrip, EveryAttributeCombinationReadsBackTheSameValues) {
  TempDir dir;
  for (const unsigned attributes : {unsigned(kNoAttributes), unsigned(kNormals), unsigned(kColors),
                                    unsigned(kIntensity), unsigned(kLabels),
                                    unsigned(kNormals | kColors | kIntensity | kLabels)}) {
    SCOPED_TRACE("attributes " + std::to_string(attributes));
    const auto path = dir / ("cloud" + std::to_string(attributes) + ".ply");
    const PointChunk written = makeChunk(50, attributes);
    auto writer = openPlyWriter(path, attributes);
    writer->write(written);
    writer->close();

    ReadReport report;
    const PointCloud cloud = readPointCloud(path, {}, &report);
    ASSERT_EQ(cloud.size(), written.size());
    EXPECT_EQ(cloud.attributes(), attributes);
    EXPECT_EQ(report.info.format, "PLY binary_little_endian 1.0");
    EXPECT_EQ(report.info.declaredPoints, std::optional<std::uint64_t>(50));
    EXPECT_EQ(report.info.attributes, attributes);
    for (std::size_t i = 0; i < written.size(); ++i) {
      EXPECT_EQ(cloud.worldPosition(i), written.positions[i].cast<float>().cast<double>());
    }
    EXPECT_EQ(cloud.normals, written.normals);
    EXPECT_EQ(cloud.colors, written.colors);
    EXPECT_EQ(cloud.intensities, written.intensities);
    EXPECT_EQ(cloud.labels, written.labels);
  }
}

TEST(PlyRoundTrip, DoublePositionsKeepFullPrecisionFarFromTheOrigin) {
  TempDir dir;
  const auto path = dir / "far.ply";
  const PointChunk written = makeChunk(20, kIntensity, 4.5e6 + 0.123456789);
  auto writer = openPlyWriter(path, kIntensity, /*doublePositions=*/true);
  writer->write(written);
  writer->close();

  EXPECT_THAT(test::readFile(path), HasSubstr("property double x\nproperty double y\nproperty double z\n"));
  const PointChunk exact = readAll(path);
  ASSERT_EQ(exact.size(), written.size());
  for (std::size_t i = 0; i < written.size(); ++i) EXPECT_EQ(exact.positions[i], written.positions[i]);

  const PointCloud cloud = readPointCloud(path);
  ASSERT_EQ(cloud.size(), written.size());
  for (std::size_t i = 0; i < written.size(); ++i) {
    EXPECT_LT((cloud.worldPosition(i) - written.positions[i]).norm(), 1e-6);
  }
}

TEST(PlyRoundTrip, ManyChunksStreamIntoOneFileWithThePatchedCount) {
  TempDir dir;
  const auto path = dir / "chunks.ply";
  auto writer = openPlyWriter(path, kColors);
  const PointChunk chunk = makeChunk(100, kColors);
  for (int k = 0; k < 3; ++k) writer->write(chunk);
  writer->write(PointChunk{});
  writer->close();
  writer->close();  // closing twice is harmless

  const std::string bytes = test::readFile(path);
  const std::string countLine = "element vertex 00000000000000000300\n";
  ASSERT_NE(bytes.find(countLine), std::string::npos);
  const std::size_t dataStart = bytes.find("end_header\n") + std::strlen("end_header\n");
  EXPECT_EQ(bytes.size() - dataStart, 300u * (3 * 4 + 3));  // float x y z, uchar r g b

  const PointChunk all = readAll(path, 128);
  ASSERT_EQ(all.size(), 300u);
  EXPECT_EQ(all.colors[250], chunk.colors[50]);
  EXPECT_EQ(all.positions[199], chunk.positions[99].cast<float>().cast<double>());
}

TEST(PlyRoundTrip, DestructorFinishesAnUnclosedFile) {
  TempDir dir;
  const auto path = dir / "unclosed.ply";
  openPlyWriter(path, kNoAttributes)->write(makeChunk(7, kNoAttributes));
  EXPECT_EQ(readAll(path).size(), 7u);
}

TEST(PlyWriter, ChunkWithOtherAttributesThanDeclaredIsRejected) {
  TempDir dir;
  auto writer = openPlyWriter(dir / "a.ply", kColors | kLabels);
  EXPECT_THROW(writer->write(makeChunk(3, kColors)), std::invalid_argument);
  EXPECT_THROW(writer->write(makeChunk(3, kColors | kLabels | kNormals)), std::invalid_argument);
  writer->write(makeChunk(3, kColors | kLabels));
  writer->close();
  EXPECT_EQ(readAll(dir / "a.ply").size(), 3u);
}

TEST(PlyWriter, UncreatableFileNamesThePath) {
  TempDir dir;
  const auto path = dir / "missing-folder" / "out.ply";
  try {
    openPlyWriter(path, kNoAttributes);
    FAIL() << "no error";
  } catch (const OutputError& error) {
    EXPECT_THAT(error.what(), HasSubstr(path.string()));
    EXPECT_THAT(error.what(), HasSubstr("cannot create"));
  }
}

TEST(PlyWriter, FullDiskNamesThePath) {
  if (!std::filesystem::exists("/dev/full")) GTEST_SKIP() << "no /dev/full on this system";
  auto writer = openPlyWriter("/dev/full", kNormals);
  try {
    writer->write(makeChunk(100000, kNormals));  // more than the stdio buffer
    writer->close();
    FAIL() << "no error";
  } catch (const OutputError& error) {
    EXPECT_THAT(error.what(), HasSubstr("/dev/full"));
    EXPECT_THAT(error.what(), HasSubstr(std::strerror(ENOSPC)));
  }
}

// ---------------------------------------------------------------------------------------------

TEST(PlyReader, AsciiWithCommentsObjInfoAndAliases) {
  TempDir dir;
  const auto path = dir / "ascii.ply";
  writeFile(path,
            "ply\n"
            "format ascii 1.0\n"
            "comment made by hand\n"
            "obj_info scanner none\n"
            "element vertex 3\n"
            "property float x\n"
            "property float y\n"
            "property float z\n"
            "property uchar r\n"
            "property uchar g\n"
            "property uchar b\n"
            "property float scalar_intensity\n"
            "property int class\n"
            "property float quality\n"
            "comment a comment between properties\n"
            "end_header\n"
            "1.5 -2 3e-1 255 0 10 0.75 4 9\n"
            "\n"
            "  4 5 6 1 2 3 100 -1 9  \n"
            "7\t8\t9\t0\t0\t0\t1e3\t12\t9");
  auto reader = io::openPlyReader(path);
  EXPECT_EQ(reader->info().format, "PLY ascii 1.0");
  EXPECT_EQ(reader->info().attributes, unsigned(kColors | kIntensity | kLabels));
  EXPECT_EQ(reader->info().fields,
            (std::vector<std::string>{"x", "y", "z", "r", "g", "b", "scalar_intensity", "class", "quality"}));
  const PointChunk points = readAll(path);
  ASSERT_EQ(points.size(), 3u);
  EXPECT_EQ(points.positions[0], Eigen::Vector3d(1.5, -2.0, 0.3));
  EXPECT_EQ(points.positions[2], Eigen::Vector3d(7, 8, 9));
  EXPECT_EQ(points.colors[0], Color(255, 0, 10));
  EXPECT_EQ(points.colors[1], Color(1, 2, 3));
  EXPECT_EQ(points.intensities, (std::vector<float>{0.75f, 100.0f, 1000.0f}));
  EXPECT_EQ(points.labels, (std::vector<std::int32_t>{4, -1, 12}));
}

TEST(PlyReader, AsciiWithCrlfLineEnds) {
  TempDir dir;
  const auto path = dir / "crlf.ply";
  writeFile(path,
            "ply\r\nformat ascii 1.0\r\ncomment windows\r\nelement vertex 2\r\nproperty double x\r\n"
            "property double y\r\nproperty double z\r\nproperty float nx\r\nproperty float ny\r\n"
            "property float nz\r\nend_header\r\n0.1 0.2 0.3 0 0 1\r\n-1 -2 -3 1 0 0\r\n");
  const PointChunk points = readAll(path);
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points.positions[0], Eigen::Vector3d(0.1, 0.2, 0.3));
  EXPECT_EQ(points.positions[1], Eigen::Vector3d(-1, -2, -3));
  EXPECT_EQ(points.normals[0], Eigen::Vector3f(0, 0, 1));
  EXPECT_EQ(points.normals[1], Eigen::Vector3f(1, 0, 0));
}

TEST(PlyReader, BinaryBigEndianWithDoubleCoordinates) {
  TempDir dir;
  const auto path = dir / "big.ply";
  Bytes data(/*bigEndian=*/true);
  data.put(123456.789).put(-0.001).put(1e-9).put(std::int16_t(-300)).put(std::uint32_t(70000));
  data.put(-5.5).put(6.25).put(7.0).put(std::int16_t(2)).put(std::uint32_t(1));
  writeFile(path,
            "ply\nformat binary_big_endian 1.0\nelement vertex 2\nproperty float64 x\nproperty float64 y\n"
            "property float64 z\nproperty int16 extra\nproperty uint32 label\nend_header\n" +
                data.str());
  auto reader = io::openPlyReader(path);
  EXPECT_EQ(reader->info().format, "PLY binary_big_endian 1.0");
  const PointChunk points = readAll(path);
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points.positions[0], Eigen::Vector3d(123456.789, -0.001, 1e-9));
  EXPECT_EQ(points.positions[1], Eigen::Vector3d(-5.5, 6.25, 7.0));
  EXPECT_EQ(points.labels, (std::vector<std::int32_t>{70000, 1}));
}

/// A mesh with a face element before and after the vertices, in the given encoding.
std::string meshWithFacesAroundVertices(const std::string& encoding) {
  std::string header = "ply\nformat " + encoding +
                       " 1.0\n"
                       "element face 2\nproperty list uchar int vertex_indices\nproperty uchar flags\n"
                       "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                       "property list uint8 float texture\n"
                       "element material 1\nproperty float shininess\n"
                       "element edge 1\nproperty list uchar int vertex_indices\nend_header\n";
  if (encoding == "ascii") {
    return header +
           "3 0 1 2 7\n4 0 1 2 0 8\n"
           "1 2 3 2 0.5 0.5\n4 5 6 0\n7 8 9 1 0.25\n"
           "0.5\n2 0 1\n";
  }
  Bytes data(encoding == "binary_big_endian");
  data.put(std::uint8_t(3)).put(0).put(1).put(2).put(std::uint8_t(7));
  data.put(std::uint8_t(4)).put(0).put(1).put(2).put(0).put(std::uint8_t(8));
  data.put(1.0f).put(2.0f).put(3.0f).put(std::uint8_t(2)).put(0.5f).put(0.5f);
  data.put(4.0f).put(5.0f).put(6.0f).put(std::uint8_t(0));
  data.put(7.0f).put(8.0f).put(9.0f).put(std::uint8_t(1)).put(0.25f);
  data.put(0.5f);
  data.put(std::uint8_t(2)).put(0).put(1);
  return header + data.str();
}

TEST(PlyReader, SkipsFacesBeforeAndAfterVerticesAndListPropertiesInEveryEncoding) {
  TempDir dir;
  for (const std::string encoding : {"ascii", "binary_little_endian", "binary_big_endian"}) {
    SCOPED_TRACE(encoding);
    const auto path = dir / (encoding + ".ply");
    writeFile(path, meshWithFacesAroundVertices(encoding));
    auto reader = io::openPlyReader(path);
    EXPECT_EQ(reader->info().declaredPoints, std::optional<std::uint64_t>(3));
    const PointChunk points = readAll(path, 2);
    ASSERT_EQ(points.size(), 3u);
    EXPECT_EQ(points.positions[0], Eigen::Vector3d(1, 2, 3));
    EXPECT_EQ(points.positions[1], Eigen::Vector3d(4, 5, 6));
    EXPECT_EQ(points.positions[2], Eigen::Vector3d(7, 8, 9));
  }
}

TEST(PlyReader, SixteenBitColorsAreScaledToEightBitAndFloatColorsFromUnitRange) {
  TempDir dir;
  const auto ushortPath = dir / "ushort.ply";
  Bytes data;
  data.put(0.0f).put(0.0f).put(0.0f).put(std::uint16_t(65535)).put(std::uint16_t(0)).put(std::uint16_t(32896));
  data.put(1.0f).put(1.0f).put(1.0f).put(std::uint16_t(257)).put(std::uint16_t(514)).put(std::uint16_t(1000));
  writeFile(ushortPath,
            "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
            "property float z\nproperty ushort red\nproperty ushort green\nproperty ushort blue\nend_header\n" +
                data.str());
  const PointChunk colors16 = readAll(ushortPath);
  ASSERT_EQ(colors16.size(), 2u);
  EXPECT_EQ(colors16.colors[0], Color(255, 0, 128));
  EXPECT_EQ(colors16.colors[1], Color(1, 2, 4));

  const auto floatPath = dir / "float.ply";
  writeFile(floatPath,
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
            "property float diffuse_red\nproperty float diffuse_green\nproperty float diffuse_blue\nend_header\n"
            "0 0 0 1.0 0.5 0\n");
  EXPECT_EQ(readAll(floatPath).colors[0], Color(255, 128, 0));
}

TEST(PlyReader, IncompleteNormalsOrColorsAreNotDelivered) {
  TempDir dir;
  const auto path = dir / "partial.ply";
  writeFile(path,
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
            "property float nx\nproperty float ny\nproperty uchar red\nend_header\n1 2 3 0 1 255\n");
  auto reader = io::openPlyReader(path);
  EXPECT_EQ(reader->info().attributes, unsigned(kNoAttributes));
  EXPECT_EQ(readAll(path).positions[0], Eigen::Vector3d(1, 2, 3));
}

TEST(PlyReader, ChunksOfSevenGiveTheSamePointsAsOneChunk) {
  TempDir dir;
  const unsigned all = kNormals | kColors | kIntensity | kLabels;
  const auto binaryPath = dir / "chunked.ply";
  auto writer = openPlyWriter(binaryPath, all);
  writer->write(makeChunk(52, all));
  writer->close();

  std::string ascii = "ply\nformat ascii 1.0\nelement vertex 52\nproperty float x\nproperty float y\n"
                      "property float z\nproperty int label\nend_header\n";
  for (int i = 0; i < 52; ++i) ascii += std::to_string(i) + " 0.5 -1 " + std::to_string(2 * i) + "\n";
  const auto asciiPath = dir / "chunked-ascii.ply";
  writeFile(asciiPath, ascii);

  for (const auto& path : {binaryPath, asciiPath}) {
    SCOPED_TRACE(path.filename().string());
    auto reader = io::openPlyReader(path);
    PointChunk chunk;
    std::vector<std::size_t> sizes;
    while (reader->read(chunk, 7) > 0) sizes.push_back(chunk.size());
    EXPECT_EQ(sizes, (std::vector<std::size_t>{7, 7, 7, 7, 7, 7, 7, 3}));

    const PointChunk sevens = readAll(path, 7);
    const PointChunk whole = readAll(path, 1000);
    EXPECT_EQ(sevens.positions, whole.positions);
    EXPECT_EQ(sevens.normals, whole.normals);
    EXPECT_EQ(sevens.colors, whole.colors);
    EXPECT_EQ(sevens.intensities, whole.intensities);
    EXPECT_EQ(sevens.labels, whole.labels);
    EXPECT_EQ(whole.size(), 52u);
  }
}

TEST(PlyReader, ProgressGrowsToOne) {
  TempDir dir;
  const auto path = dir / "progress.ply";
  auto writer = openPlyWriter(path, kNoAttributes);
  writer->write(makeChunk(1000, kNoAttributes));
  writer->close();
  auto reader = io::openPlyReader(path);
  PointChunk chunk;
  reader->read(chunk, 500);
  EXPECT_GT(reader->progress(), 0.4);
  EXPECT_LT(reader->progress(), 0.6);
  reader->read(chunk, 500);
  EXPECT_DOUBLE_EQ(reader->progress(), 1.0);
  EXPECT_EQ(reader->read(chunk, 500), 0u);
}

// ---------------------------------------------------------------------------------------------

std::filesystem::path writeTemp(const TempDir& dir, const std::string& bytes) {
  const auto path = dir / "bad.ply";
  writeFile(path, bytes);
  return path;
}

const char* const kXyzHeader = "element vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n";

TEST(PlyMalformed, BadMagic) {
  TempDir dir;
  const auto path = writeTemp(dir, "PLY\nformat ascii 1.0\n");
  expectInputError([&] { io::openPlyReader(path); }, {"bad.ply: byte 0:", "expected the PLY magic 'ply'"});
  const auto trailing = writeTemp(dir, "plyx\nformat ascii 1.0\n");
  expectInputError([&] { io::openPlyReader(trailing); }, {"line 1:", "found 'plyx', expected 'ply'"});
}

TEST(PlyMalformed, MissingFormatLine) {
  TempDir dir;
  const auto path = writeTemp(dir, std::string("ply\ncomment no format\n") + kXyzHeader + "1 2 3\n4 5 6\n");
  expectInputError([&] { io::openPlyReader(path); }, {"line 3:", "found 'element' before the format line"});
}

TEST(PlyMalformed, UnknownFormatOrVersion) {
  TempDir dir;
  const auto path = writeTemp(dir, std::string("ply\nformat binary_middle_endian 1.0\n") + kXyzHeader);
  expectInputError([&] { io::openPlyReader(path); },
                   {"line 2:", "unknown format 'binary_middle_endian', expected ascii, binary_little_endian"});
  const auto version = writeTemp(dir, std::string("ply\nformat ascii 2.0\n") + kXyzHeader);
  expectInputError([&] { io::openPlyReader(version); }, {"line 2:", "version '2.0', expected 1.0"});
}

TEST(PlyMalformed, UnknownPropertyType) {
  TempDir dir;
  const auto path = writeTemp(dir,
                              "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty half y\n"
                              "property float z\nend_header\n1 2 3\n");
  expectInputError([&] { io::openPlyReader(path); }, {"line 5:", "unknown property type 'half'", "expected char"});
}

TEST(PlyMalformed, MissingCoordinateOrVertexElement) {
  TempDir dir;
  const auto path = writeTemp(dir,
                              "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                              "property float intensity\nend_header\n1 2 3\n");
  expectInputError([&] { io::openPlyReader(path); }, {"line 3:", "no property 'z', expected x, y and z"});
  const auto noVertex = writeTemp(dir,
                                  "ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int vertex_indices\n"
                                  "end_header\n3 0 1 2\n");
  expectInputError([&] { io::openPlyReader(noVertex); }, {"no 'vertex' element"});
}

TEST(PlyMalformed, HeaderWithoutEnd) {
  TempDir dir;
  const auto path = writeTemp(dir, "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n");
  expectInputError([&] { io::openPlyReader(path); }, {"line 5:", "expected 'end_header'"});
}

TEST(PlyMalformed, AbsurdVertexCountThrowsQuicklyWithoutAllocating) {
  TempDir dir;
  for (const std::string encoding : {"binary_little_endian", "ascii"}) {
    SCOPED_TRACE(encoding);
    const auto path = writeTemp(dir, "ply\nformat " + encoding +
                                         " 1.0\nelement vertex 1000000000000000\nproperty float x\n"
                                         "property float y\nproperty float z\nend_header\n" +
                                         std::string(24, '1'));
    const auto start = std::chrono::steady_clock::now();
    expectInputError([&] { io::openPlyReader(path); },
                     {"line 3:", "element vertex declares 1000000000000000 records", "only 24 bytes follow"});
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(1));
  }
}

TEST(PlyMalformed, TruncatedBinaryData) {
  TempDir dir;
  const std::string fourFloats = Bytes().put(1.0f).put(2.0f).put(3.0f).put(4.0f).str();
  const auto path = writeTemp(dir, std::string("ply\nformat binary_little_endian 1.0\n") + kXyzHeader + fourFloats);
  expectInputError([&] { io::openPlyReader(path); },
                   {"line 3:", "2 records of at least 12 bytes", "only 16 bytes follow the header", "truncated"});

  // With list properties the size is only known while reading: the error names the byte.
  Bytes records;
  records.put(1.0f).put(2.0f).put(3.0f).put(std::uint8_t(3)).put(0).put(1).put(2);
  records.put(4.0f).put(5.0f).put(6.0f).put(std::uint8_t(200));  // 200 ints the file does not hold
  const auto listPath = writeTemp(dir,
                                  "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\n"
                                  "property float y\nproperty float z\nproperty list uchar int extra\nend_header\n" +
                                      records.str());
  const std::string headerBytes = test::readFile(listPath).substr(0, test::readFile(listPath).find("end_header") + 11);
  auto reader = io::openPlyReader(listPath);
  PointChunk chunk;
  expectInputError([&] { reader->read(chunk, 10); },
                   {"unexpected end of file in vertex 1, expected 2 vertex records",
                    ("byte " + std::to_string(headerBytes.size() + 38)).c_str()});
}

TEST(PlyMalformed, NonNumericAsciiValue) {
  TempDir dir;
  const auto path = writeTemp(dir, std::string("ply\nformat ascii 1.0\n") + kXyzHeader + "1 2 3\n4 abc 6\n");
  auto reader = io::openPlyReader(path);
  PointChunk chunk;
  expectInputError([&] { reader->read(chunk, 10); }, {"line 9:", "value 'abc' of property y is not a number"});
}

TEST(PlyMalformed, TooFewOrTooManyAsciiValues) {
  TempDir dir;
  const auto path = writeTemp(dir, std::string("ply\nformat ascii 1.0\n") + kXyzHeader + "1 2 3\n40 50\n");
  auto reader = io::openPlyReader(path);
  PointChunk chunk;
  expectInputError([&] { reader->read(chunk, 10); }, {"line 9:", "found 2 values", "property z"});

  const auto extra = writeTemp(dir, std::string("ply\nformat ascii 1.0\n") + kXyzHeader + "1 2 3 4\n4 5 6\n");
  auto extraReader = io::openPlyReader(extra);
  expectInputError([&] { extraReader->read(chunk, 10); }, {"line 8:", "found 4 values, expected 3"});
}

TEST(PlyMalformed, TooFewAsciiLines) {
  TempDir dir;
  const auto path = writeTemp(dir, std::string("ply\nformat ascii 1.0\n") + kXyzHeader + "1 2 3\n\n\n\n\n\n\n\n\n");
  auto reader = io::openPlyReader(path);
  PointChunk chunk;
  expectInputError([&] { reader->read(chunk, 10); }, {"unexpected end of file in vertex 1, expected 2 vertex lines"});
}

}  // namespace
}  // namespace piperun
