// PCD reader: hand-made ascii, binary and binary_compressed files, the real scans, malformed input.

#include "io/readers.h"
#include "piperun/error.h"
#include "piperun/io/point_reader.h"
#include "test_util.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <unordered_map>

namespace piperun {
namespace {

using test::TempDir;
using test::writeFile;
using testing::HasSubstr;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

/// Little-endian binary data for hand-made files.
class Bytes {
 public:
  template <class T>
  Bytes& put(T value) {
    char raw[sizeof(T)];
    std::memcpy(raw, &value, sizeof(T));
    text_.append(raw, sizeof(T));
    return *this;
  }
  Bytes& append(const std::string& bytes) {
    text_ += bytes;
    return *this;
  }
  const std::string& str() const { return text_; }

 private:
  std::string text_;
};

float floatFromBits(std::uint32_t bits) {
  float value = 0.0f;
  std::memcpy(&value, &bits, sizeof value);
  return value;
}

std::string header(const std::string& fields, const std::string& sizes, const std::string& types,
                   const std::string& counts, std::uint64_t width, std::uint64_t height, const std::string& data,
                   const std::string& viewpoint = "0 0 0 1 0 0 0") {
  return "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS " + fields + "\nSIZE " + sizes +
         "\nTYPE " + types + "\nCOUNT " + counts + "\nWIDTH " + std::to_string(width) + "\nHEIGHT " +
         std::to_string(height) + "\nVIEWPOINT " + viewpoint + "\nPOINTS " + std::to_string(width * height) +
         "\nDATA " + data + "\n";
}

struct LzfStats {
  int literalRuns = 0;
  int backReferences = 0;
};

/// A small LZF compressor (liblzf's stream format): greedy matches found through the last
/// position of each 3-byte sequence, literal runs of up to 32 bytes in between.
std::string compressLzf(const std::string& input, LzfStats& stats) {
  constexpr std::size_t kMaxDistance = 8192;
  constexpr std::size_t kMaxLength = 264;
  std::string output;
  std::string literal;
  const auto flushLiteral = [&] {
    for (std::size_t i = 0; i < literal.size(); i += 32) {
      const std::size_t n = std::min<std::size_t>(32, literal.size() - i);
      output.push_back(static_cast<char>(n - 1));
      output.append(literal, i, n);
      ++stats.literalRuns;
    }
    literal.clear();
  };
  std::unordered_map<std::uint32_t, std::size_t> lastSeen;
  std::size_t i = 0;
  while (i < input.size()) {
    std::size_t length = 0;
    std::size_t distance = 0;
    if (i + 3 <= input.size()) {
      const auto byte = [&](std::size_t k) { return static_cast<std::uint32_t>(static_cast<unsigned char>(input[k])); };
      const std::uint32_t key = byte(i) | byte(i + 1) << 8 | byte(i + 2) << 16;
      const auto found = lastSeen.find(key);
      if (found != lastSeen.end() && i - found->second <= kMaxDistance) {
        distance = i - found->second;
        while (i + length < input.size() && length < kMaxLength && input[found->second + length] == input[i + length]) {
          ++length;
        }
      }
      lastSeen[key] = i;
    }
    if (length < 3) {
      literal.push_back(input[i++]);
      continue;
    }
    flushLiteral();
    const std::size_t lengthCode = length - 2;
    const std::size_t offset = distance - 1;
    if (lengthCode < 7) {
      output.push_back(static_cast<char>(lengthCode << 5 | offset >> 8));
    } else {
      output.push_back(static_cast<char>(7 << 5 | offset >> 8));
      output.push_back(static_cast<char>(lengthCode - 7));
    }
    output.push_back(static_cast<char>(offset & 0xff));
    ++stats.backReferences;
    i += length;
  }
  flushLiteral();
  return output;
}

/// All points of a file through the format reader, in chunks of `maxPoints`.
PointChunk readAll(const std::filesystem::path& path, std::size_t maxPoints = 1u << 20) {
  auto reader = io::openPcdReader(path);
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

void expectSamePoints(const PointChunk& a, const PointChunk& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    // Compare bit patterns so that NaN points count as equal.
    EXPECT_EQ(std::memcmp(a.positions[i].data(), b.positions[i].data(), sizeof(Eigen::Vector3d)), 0) << "point " << i;
  }
  EXPECT_EQ(a.normals, b.normals);
  EXPECT_EQ(a.colors, b.colors);
  EXPECT_EQ(a.intensities, b.intensities);
  EXPECT_EQ(a.labels, b.labels);
}

/// Expects InputError whose message contains each of `parts`.
template <class Function>
void expectInputError(Function&& function, std::initializer_list<std::string> parts) {
  try {
    function();
  } catch (const InputError& error) {
    for (const auto& part : parts) EXPECT_THAT(error.what(), HasSubstr(part));
    return;
  }
  ADD_FAILURE() << "no InputError";
}

// ---------------------------------------------------------------------------------------------

TEST(PcdReader, AsciiXyzDeliversNonFinitePointsForTheCallerToDrop) {
  TempDir dir;
  const auto path = dir / "xyz.pcd";
  writeFile(path, header("x y z", "4 4 4", "F F F", "1 1 1", 3, 1, "ascii") + "0.5 1 -2\n\n3 4 5\nnan nan nan\n");
  auto reader = io::openPcdReader(path);
  EXPECT_EQ(reader->info().format, "PCD v0.7 ascii");
  EXPECT_EQ(reader->info().attributes, unsigned(kNoAttributes));
  EXPECT_EQ(reader->info().declaredPoints, std::optional<std::uint64_t>(3));
  const PointChunk points = readAll(path);
  ASSERT_EQ(points.size(), 3u);
  EXPECT_EQ(points.positions[0], Eigen::Vector3d(0.5, 1, -2));
  EXPECT_EQ(points.positions[1], Eigen::Vector3d(3, 4, 5));
  EXPECT_TRUE(std::isnan(points.positions[2].x()));

  ReadReport report;
  const PointCloud cloud = readPointCloud(path, {}, &report);
  EXPECT_EQ(cloud.size(), 2u);
  EXPECT_EQ(report.nonFiniteDropped, 1u);
}

TEST(PcdReader, AsciiWithNormalsIntensityLabelAndRgbInBothNotations) {
  TempDir dir;
  const auto path = dir / "ascii.pcd";
  const float oldStyle = 4.2108e+06f;  // older writers printed the float holding the colour bits
  std::uint32_t oldBits = 0;
  std::memcpy(&oldBits, &oldStyle, sizeof oldBits);
  writeFile(path, header("x y z rgb normal_x normal_y normal_z curvature intensity label", "4 4 4 4 4 4 4 4 4 4",
                         "F F F F F F F F F U", "1 1 1 1 1 1 1 1 1 1", 2, 1, "ascii") +
                      "1 2 3 16744512 0 0 1 0.01 0.5 7\n"
                      "-1 -2 -3 4.2108e+06 1 0 0 0.02 12.25 4294967295\n");
  auto reader = io::openPcdReader(path);
  EXPECT_EQ(reader->info().attributes, unsigned(kNormals | kColors | kIntensity | kLabels));
  const PointChunk points = readAll(path);
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points.positions[1], Eigen::Vector3d(-1, -2, -3));
  EXPECT_EQ(points.colors[0], Color(0xFF, 0x80, 0x40));  // 16744512 = 0xFF8040
  EXPECT_EQ(points.colors[1], Color(std::uint8_t(oldBits >> 16), std::uint8_t(oldBits >> 8), std::uint8_t(oldBits)));
  EXPECT_EQ(points.normals[0], Eigen::Vector3f(0, 0, 1));
  EXPECT_EQ(points.normals[1], Eigen::Vector3f(1, 0, 0));
  EXPECT_EQ(points.intensities, (std::vector<float>{0.5f, 12.25f}));
  EXPECT_EQ(points.labels, (std::vector<std::int32_t>{7, std::numeric_limits<std::int32_t>::max()}));
}

TEST(PcdReader, OldVersionWithoutWidthAndHeight) {
  TempDir dir;
  const auto path = dir / "old.pcd";
  writeFile(path, "VERSION .5\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 2\nDATA ascii\n1 2 3\n4 5 6\n");
  auto reader = io::openPcdReader(path);
  EXPECT_EQ(reader->info().format, "PCD v.5 ascii");
  const PointChunk points = readAll(path);
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points.positions[1], Eigen::Vector3d(4, 5, 6));
}

TEST(PcdReader, BinaryWithNormalsAndRgbPackedAsFloat) {
  TempDir dir;
  const auto path = dir / "normals.pcd";
  Bytes data;
  data.put(1.0f).put(2.0f).put(3.0f).put(floatFromBits(0x00FF8040)).put(0.0f).put(1.0f).put(0.0f).put(0.5f);
  data.put(-4.0f).put(0.25f).put(9.0f).put(floatFromBits(0xFF0A0B0C)).put(0.6f).put(0.0f).put(0.8f).put(0.1f);
  writeFile(path, header("x y z rgb normal_x normal_y normal_z curvature", "4 4 4 4 4 4 4 4", "F F F F F F F F",
                         "1 1 1 1 1 1 1 1", 2, 1, "binary") +
                      data.str());
  const PointChunk points = readAll(path);
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points.positions[0], Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(points.positions[1], Eigen::Vector3d(-4, 0.25, 9));
  EXPECT_EQ(points.colors[0], Color(0xFF, 0x80, 0x40));
  EXPECT_EQ(points.colors[1], Color(0x0A, 0x0B, 0x0C));
  EXPECT_EQ(points.normals[0], Eigen::Vector3f(0, 1, 0));
  EXPECT_EQ(points.normals[1], Eigen::Vector3f(0.6f, 0, 0.8f));
}

TEST(PcdReader, BinaryRgbaAsUnsignedWithADescriptorFieldToSkip) {
  TempDir dir;
  const auto path = dir / "fpfh.pcd";
  Bytes data;
  for (int i = 0; i < 5; ++i) {
    data.put(0.5 * i).put(-1.0 * i).put(2.0);  // F 8 coordinates
    data.put(std::uint32_t(0xFF000000u | std::uint32_t(i) << 16 | 0x2000u | std::uint32_t(3 * i)));
    for (int k = 0; k < 33; ++k) data.put(100.0f + float(k));  // fpfh, COUNT 33
    data.put(std::int16_t(-7));                                   // unknown field
    data.put(0.125f * float(i));                                  // intensity
    data.put(std::uint32_t(40 + i));                              // label
  }
  writeFile(path, header("x y z rgba fpfh _ intensity label", "8 8 8 4 4 2 4 4", "F F F U F I F U",
                         "1 1 1 1 33 1 1 1", 5, 1, "binary") +
                      data.str());
  auto reader = io::openPcdReader(path);
  EXPECT_EQ(reader->info().fields,
            (std::vector<std::string>{"x", "y", "z", "rgba", "fpfh", "_", "intensity", "label"}));
  EXPECT_EQ(reader->info().attributes, unsigned(kColors | kIntensity | kLabels));
  const PointChunk points = readAll(path);
  ASSERT_EQ(points.size(), 5u);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(points.positions[i], Eigen::Vector3d(0.5 * i, -1.0 * i, 2.0));
    EXPECT_EQ(points.colors[i], Color(i, 0x20, 3 * i));
    EXPECT_EQ(points.intensities[i], 0.125f * float(i));
    EXPECT_EQ(points.labels[i], 40 + i);
  }
}

TEST(PcdReader, ViewpointIsTheSensorPoseAndPointsStayAsStored) {
  TempDir dir;
  const auto posed = dir / "posed.pcd";
  writeFile(posed, header("x y z normal_x normal_y normal_z", "4 4 4 4 4 4", "F F F F F F", "1 1 1 1 1 1", 1, 1,
                          "ascii", "1 2 3 0.70710678 0 0 0.70710678") +
                       "1 0 5 1 0 0\n");
  const PointChunk points = readAll(posed);
  ASSERT_EQ(points.size(), 1u);
  EXPECT_EQ(points.positions[0], Eigen::Vector3d(1, 0, 5));
  EXPECT_EQ(points.normals[0], Eigen::Vector3f(1, 0, 0));

  const auto bad = dir / "bad-viewpoint.pcd";
  writeFile(bad, header("x y z", "4 4 4", "F F F", "1 1 1", 1, 1, "ascii", "0 0 0 0 0 0 0") + "1 2 3\n");
  try {
    readAll(bad);
    FAIL() << "zero quaternion accepted";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("VIEWPOINT"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("line"), std::string::npos) << error.what();
  }
}

TEST(PcdReader, OrganizedBinaryCloudKeepsItsNaNGridCells) {
  TempDir dir;
  const auto path = dir / "organized.pcd";
  Bytes data;
  for (int i = 0; i < 6; ++i) {
    const bool hole = i == 1 || i == 4;
    data.put(hole ? kNaN : float(i)).put(hole ? kNaN : 1.0f).put(hole ? kNaN : 2.0f);
  }
  writeFile(path, header("x y z", "4 4 4", "F F F", "1 1 1", 3, 2, "binary") + data.str());
  const PointChunk points = readAll(path);
  ASSERT_EQ(points.size(), 6u);
  EXPECT_TRUE(std::isnan(points.positions[1].x()));
  EXPECT_EQ(points.positions[5], Eigen::Vector3d(5, 1, 2));

  ReadReport report;
  const PointCloud cloud = readPointCloud(path, {}, &report);
  EXPECT_EQ(cloud.size(), 4u);
  EXPECT_EQ(report.nonFiniteDropped, 2u);
}

/// 60 points of a small grid in binary_compressed form; the columns repeat, so the compressor
/// finds back-references between its literal runs.
struct CompressedCloud {
  std::string file;
  std::string uncompressed;
  LzfStats stats;
};

CompressedCloud makeCompressedCloud(std::size_t points) {
  Bytes x, y, z, rgb, intensity, label;
  for (std::size_t i = 0; i < points; ++i) {
    x.put(float(i % 10) * 0.1f);
    y.put(float(i / 10) * 0.2f);
    z.put(i == 13 ? kNaN : 1.5f);
    rgb.put(std::uint32_t(0x00102030));
    intensity.put(float(i));
    label.put(std::uint16_t(i % 3));
  }
  CompressedCloud cloud;
  cloud.uncompressed = x.str() + y.str() + z.str() + rgb.str() + intensity.str() + label.str();
  const std::string compressed = compressLzf(cloud.uncompressed, cloud.stats);
  Bytes data;
  data.put(std::uint32_t(compressed.size())).put(std::uint32_t(cloud.uncompressed.size())).append(compressed);
  cloud.file = header("x y z rgb intensity label", "4 4 4 4 4 2", "F F F U F U", "1 1 1 1 1 1", points, 1,
                      "binary_compressed") +
               data.str();
  return cloud;
}

TEST(PcdReader, BinaryCompressedWithLiteralRunsAndBackReferences) {
  TempDir dir;
  const auto path = dir / "compressed.pcd";
  const CompressedCloud cloud = makeCompressedCloud(60);
  EXPECT_GT(cloud.stats.literalRuns, 0);
  EXPECT_GT(cloud.stats.backReferences, 0);
  writeFile(path, cloud.file);

  auto reader = io::openPcdReader(path);
  EXPECT_EQ(reader->info().format, "PCD v0.7 binary_compressed");
  EXPECT_EQ(reader->info().attributes, unsigned(kColors | kIntensity | kLabels));
  const PointChunk points = readAll(path);
  ASSERT_EQ(points.size(), 60u);
  for (std::size_t i = 0; i < 60; ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(points.positions[i].x(), double(float(i % 10) * 0.1f));
    EXPECT_EQ(points.positions[i].y(), double(float(i / 10) * 0.2f));
    if (i == 13) {
      EXPECT_TRUE(std::isnan(points.positions[i].z()));
    } else {
      EXPECT_EQ(points.positions[i].z(), 1.5);
    }
    EXPECT_EQ(points.colors[i], Color(0x10, 0x20, 0x30));
    EXPECT_EQ(points.intensities[i], float(i));
    EXPECT_EQ(points.labels[i], std::int32_t(i % 3));
  }
}

TEST(PcdReader, ChunksOfSevenGiveTheSamePointsAsOneChunk) {
  TempDir dir;
  const auto compressedPath = dir / "compressed.pcd";
  writeFile(compressedPath, makeCompressedCloud(50).file);

  const auto binaryPath = dir / "binary.pcd";
  Bytes data;
  for (int i = 0; i < 50; ++i) data.put(float(i)).put(std::uint8_t(i)).put(-float(i)).put(0.5f);
  writeFile(binaryPath, header("x label z y", "4 1 4 4", "F U F F", "1 1 1 1", 50, 1, "binary") + data.str());

  std::string ascii = header("x y z", "4 4 4", "F F F", "1 1 1", 50, 1, "ascii");
  for (int i = 0; i < 50; ++i) ascii += std::to_string(i) + " 1 " + std::to_string(-i) + "\n";
  const auto asciiPath = dir / "ascii.pcd";
  writeFile(asciiPath, ascii);

  for (const auto& path : {compressedPath, binaryPath, asciiPath}) {
    SCOPED_TRACE(path.filename().string());
    auto reader = io::openPcdReader(path);
    PointChunk chunk;
    std::vector<std::size_t> sizes;
    while (reader->read(chunk, 7) > 0) sizes.push_back(chunk.size());
    EXPECT_EQ(sizes, (std::vector<std::size_t>{7, 7, 7, 7, 7, 7, 7, 1}));
    const PointChunk whole = readAll(path);
    EXPECT_EQ(whole.size(), 50u);
    expectSamePoints(readAll(path, 7), whole);
  }
  EXPECT_EQ(readAll(binaryPath).positions[49], Eigen::Vector3d(49, 0.5, -49));
}

// ---------------------------------------------------------------------------------------------

TEST(PcdRealData, PumpStationBinaryMatchesPcl) {
  const auto path = test::realDataDir() / "pumpA_pump_station.pcd";
  ASSERT_TRUE(std::filesystem::exists(path)) << path;
  ReadReport report;
  const PointCloud cloud = readPointCloud(path, {}, &report);
  EXPECT_EQ(report.info.format, "PCD v0.7 binary");
  EXPECT_EQ(report.info.declaredPoints, std::optional<std::uint64_t>(155201));
  EXPECT_EQ(report.nonFiniteDropped, 0u);
  ASSERT_EQ(cloud.size(), 155201u);
  EXPECT_EQ(cloud.attributes(), unsigned(kColors | kIntensity));

  // Reference values printed by PCL 1.13 (pcl::io::PCDReader + fromPCLPointCloud2).
  EXPECT_EQ(cloud.worldPosition(0), Eigen::Vector3f(1.70228601f, -3.19358802f, -1.84184301f).cast<double>());
  EXPECT_EQ(cloud.colors[0], Color(51, 65, 49));
  EXPECT_EQ(cloud.intensities[0], 0.456556916f);
  EXPECT_EQ(cloud.worldPosition(1), Eigen::Vector3f(1.70689404f, -3.20231605f, -1.84135401f).cast<double>());
  EXPECT_EQ(cloud.colors[1], Color(54, 70, 55));
  EXPECT_EQ(cloud.worldPosition(155200), Eigen::Vector3f(-1.26762402f, -0.796401978f, -1.38172901f).cast<double>());
  EXPECT_EQ(cloud.colors[155200], Color(26, 29, 19));
  EXPECT_EQ(cloud.intensities[155200], 0.493118078f);

  // SOURCE.md: 4.63 x 4.51 x 3.74 m.
  const BoundingBox box = cloud.boundingBox();
  EXPECT_NEAR(box.min.x(), -2.904, 1e-3);
  EXPECT_NEAR(box.max.y(), -0.793, 1e-3);
  EXPECT_NEAR(box.max.z(), 1.843, 1e-3);
}

TEST(PcdRealData, MugBinaryCompressedOrganizedCloud) {
  const auto path = test::realDataDir() / "table_scene_mug_stereo_textured.pcd";
  ASSERT_TRUE(std::filesystem::exists(path)) << path;
  auto reader = io::openPcdReader(path);
  EXPECT_EQ(reader->info().format, "PCD v0.7 binary_compressed");
  EXPECT_EQ(reader->info().declaredPoints, std::optional<std::uint64_t>(307200));
  const PointChunk grid = readAll(path, 100000);
  ASSERT_EQ(grid.size(), 307200u);
  EXPECT_TRUE(std::isnan(grid.positions[0].x()));
  EXPECT_EQ(grid.colors[0], Color(192, 0, 0));

  ReadReport report;
  const PointCloud cloud = readPointCloud(path, {}, &report);
  EXPECT_EQ(cloud.size(), 209280u);
  EXPECT_EQ(report.nonFiniteDropped, 307200u - 209280u);
  EXPECT_EQ(cloud.attributes(), unsigned(kColors));

  // PCL 1.13 gives the first finite point (grid cell 6538) as (-0.381909996, -0.448199987,
  // 2.02579999) and the last (cell 300789) as (0.225370005, 0.17904, 0.70292002), in the camera
  // frame; the file's VIEWPOINT (a half turn about x) is the sensor pose and is not applied.
  EXPECT_EQ(cloud.worldPosition(0), Eigen::Vector3f(-0.381909996f, -0.448199987f, 2.02579999f).cast<double>());
  EXPECT_EQ(cloud.colors[0], Color(67, 67, 62));
  EXPECT_EQ(cloud.worldPosition(209279), Eigen::Vector3f(0.225370005f, 0.17904f, 0.70292002f).cast<double>());
  EXPECT_EQ(cloud.colors[209279], Color(233, 235, 19));

  // SOURCE.md (camera frame): X -0.456..0.715, Y -0.511..0.179, Z 0.690..2.593.
  const BoundingBox box = cloud.boundingBox();
  EXPECT_NEAR(box.min.x(), -0.456, 1e-3);
  EXPECT_NEAR(box.max.x(), 0.715, 1e-3);
  EXPECT_NEAR(box.min.y(), -0.511, 1e-3);
  EXPECT_NEAR(box.max.y(), 0.179, 1e-3);
  EXPECT_NEAR(box.min.z(), 0.690, 1e-3);
  EXPECT_NEAR(box.max.z(), 2.593, 1e-3);
}

// ---------------------------------------------------------------------------------------------

std::filesystem::path writeTemp(const TempDir& dir, const std::string& bytes) {
  const auto path = dir / "bad.pcd";
  writeFile(path, bytes);
  return path;
}

TEST(PcdMalformed, MissingDataLine) {
  TempDir dir;
  std::string noData = header("x y z", "4 4 4", "F F F", "1 1 1", 1, 1, "ascii");
  noData.erase(noData.find("DATA"));
  const auto dataFollows = writeTemp(dir, noData + "1 2 3\n");
  expectInputError([&] { io::openPcdReader(dataFollows); }, {"bad.pcd: line 11:", "found '1 2 3'", "or DATA"});
  const auto endsEarly = writeTemp(dir, noData);
  expectInputError([&] { io::openPcdReader(endsEarly); },
                   {"line 11:", "unexpected end of file in the header, expected a DATA line"});
}

TEST(PcdMalformed, FieldsSizeTypeAndCountMismatch) {
  TempDir dir;
  const auto sizes = writeTemp(dir, header("x y z", "4 4", "F F F", "1 1 1", 1, 1, "ascii") + "1 2 3\n");
  expectInputError([&] { io::openPcdReader(sizes); }, {"line 4:", "SIZE has 2 entries, expected 3"});
  const auto types = writeTemp(dir, header("x y z", "4 4 4", "F F F F", "1 1 1", 1, 1, "ascii") + "1 2 3\n");
  expectInputError([&] { io::openPcdReader(types); }, {"line 5:", "TYPE has 4 entries, expected 3"});
  const auto counts = writeTemp(dir, header("x y z", "4 4 4", "F F F", "1 1", 1, 1, "ascii") + "1 2 3\n");
  expectInputError([&] { io::openPcdReader(counts); }, {"line 6:", "COUNT has 2 entries, expected 3"});
  const auto badType = writeTemp(dir, header("x y z", "4 4 4", "F F D", "1 1 1", 1, 1, "ascii") + "1 2 3\n");
  expectInputError([&] { io::openPcdReader(badType); }, {"line 5:", "TYPE 'D' of field z, expected F, U or I"});
  const auto noZ = writeTemp(dir, header("x y intensity", "4 4 4", "F F F", "1 1 1", 1, 1, "ascii") + "1 2 3\n");
  expectInputError([&] { io::openPcdReader(noZ); }, {"line 3:", "no field 'z', expected x, y and z"});
}

TEST(PcdMalformed, PointsDifferFromWidthTimesHeight) {
  TempDir dir;
  std::string text = header("x y z", "4 4 4", "F F F", "1 1 1", 3, 2, "ascii");
  text.replace(text.find("POINTS 6"), 8, "POINTS 5");
  const auto path = writeTemp(dir, text + "1 2 3\n1 2 3\n1 2 3\n1 2 3\n1 2 3\n");
  expectInputError([&] { io::openPcdReader(path); }, {"line 10:", "POINTS 5 differs from WIDTH x HEIGHT = 3 x 2"});
}

TEST(PcdMalformed, TruncatedBinaryData) {
  TempDir dir;
  const std::string text = header("x y z", "4 4 4", "F F F", "1 1 1", 3, 1, "binary");
  const auto path = writeTemp(dir, text + Bytes().put(1.0f).put(2.0f).put(3.0f).put(4.0f).str());
  expectInputError([&] { io::openPcdReader(path); },
                   {"byte " + std::to_string(text.size()) + ":", "POINTS 3 records of 12 bytes",
                    "16 bytes after the header", "truncated"});
}

TEST(PcdMalformed, AbsurdPointCountThrowsQuicklyWithoutAllocating) {
  TempDir dir;
  for (const char* data : {"binary", "binary_compressed", "ascii"}) {
    SCOPED_TRACE(data);
    const auto path =
        writeTemp(dir, header("x y z", "4 4 4", "F F F", "1 1 1", 1000000000000000, 1, data) + std::string(64, '1'));
    const auto start = std::chrono::steady_clock::now();
    expectInputError([&] { io::openPcdReader(path); }, {"byte"});
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(1));
  }
}

TEST(PcdMalformed, CorruptLzfBackReference) {
  TempDir dir;
  const std::string text = header("x y z", "4 4 4", "F F F", "1 1 1", 1, 1, "binary_compressed");
  // A literal run of 4 bytes, then a back-reference 100 bytes back (only 4 exist).
  const std::string stream = std::string("\x03" "abcd", 5) + static_cast<char>(1 << 5) + static_cast<char>(99);
  const std::string sizes = Bytes().put(std::uint32_t(stream.size())).put(std::uint32_t(12)).str();
  const auto path = writeTemp(dir, text + sizes + stream);
  expectInputError([&] { io::openPcdReader(path); },
                   {"byte " + std::to_string(text.size() + 8 + 5) + ":",
                    "corrupt LZF data: back-reference 100 bytes back from output byte 4, expected at most 4"});

  // A literal run longer than the stream holds.
  const std::string cut = std::string("\x1f" "abc", 4);
  const auto cutPath = writeTemp(dir, text + Bytes().put(std::uint32_t(cut.size())).put(std::uint32_t(12)).str() + cut);
  expectInputError([&] { io::openPcdReader(cutPath); }, {"literal run of 32 bytes passes the end"});

  // A valid stream of the wrong length.
  const std::string shortStream = std::string("\x03" "abcd", 5);
  const auto shortPath =
      writeTemp(dir, text + Bytes().put(std::uint32_t(shortStream.size())).put(std::uint32_t(12)).str() + shortStream);
  expectInputError([&] { io::openPcdReader(shortPath); }, {"stream ends after 4 bytes, expected 12"});
}

TEST(PcdMalformed, CompressedSizesInconsistentWithTheFile) {
  TempDir dir;
  const std::string text = header("x y z", "4 4 4", "F F F", "1 1 1", 2, 1, "binary_compressed");
  const auto tooLarge = writeTemp(dir, text + Bytes().put(std::uint32_t(1000000)).put(std::uint32_t(24)).str() + "xyz");
  expectInputError([&] { io::openPcdReader(tooLarge); },
                   {"byte " + std::to_string(text.size()) + ":",
                    "compressed size 1000000 is larger than the 3 bytes left in the file"});
  const auto wrongSize = writeTemp(dir, text + Bytes().put(std::uint32_t(3)).put(std::uint32_t(48)).str() + "xyz");
  expectInputError([&] { io::openPcdReader(wrongSize); },
                   {"uncompressed size 48, expected POINTS x record size = 2 x 12"});
  const auto noSizes = writeTemp(dir, text + "xy");
  expectInputError([&] { io::openPcdReader(noSizes); }, {"unexpected end of file", "compressed size"});
}

TEST(PcdMalformed, BadAsciiValues) {
  TempDir dir;
  const auto word = writeTemp(dir, header("x y z", "4 4 4", "F F F", "1 1 1", 2, 1, "ascii") + "1 2 3\n4 five 6\n");
  auto reader = io::openPcdReader(word);
  PointChunk chunk;
  expectInputError([&] { reader->read(chunk, 10); }, {"line 13:", "value 'five' of field y is not a number"});

  const auto few = writeTemp(dir, header("x y z", "4 4 4", "F F F", "1 1 1", 2, 1, "ascii") + "1 2 3\n40 50\n");
  auto fewReader = io::openPcdReader(few);
  expectInputError([&] { fewReader->read(chunk, 10); }, {"line 13:", "found 2 values, expected 3"});

  const auto lines = writeTemp(dir, header("x y z", "4 4 4", "F F F", "1 1 1", 2, 1, "ascii") + "1 2 3\n\n\n\n\n\n");
  auto linesReader = io::openPcdReader(lines);
  expectInputError([&] { linesReader->read(chunk, 10); },
                   {"unexpected end of file after 1 points, expected POINTS 2"});
}

}  // namespace
}  // namespace piperun
