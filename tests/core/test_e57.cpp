// E57 reader: the real pump-room scan against its PCD conversion, round trips through the test
// writer (poses, field types, spherical coordinates, invalid states, packets), malformed files.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

#include "e57_test_writer.h"
#include "piperun/error.h"
#include "piperun/io/point_reader.h"
#include "test_util.h"

namespace piperun {
namespace {

using test::E57TestField;
using test::E57TestScan;
using ::testing::AllOf;
using ::testing::HasSubstr;
using Type = E57TestField::Type;

constexpr double kPi = 3.14159265358979323846;

/// Every point of a file, read through the public reader in chunks of `maxPoints`.
PointChunk readAll(const std::filesystem::path& path, std::size_t maxPoints = 1u << 20) {
  auto reader = openPointReader(path);
  PointChunk all;
  PointChunk chunk;
  while (reader->read(chunk, maxPoints) > 0) {
    chunk.checkConsistent();
    all.positions.insert(all.positions.end(), chunk.positions.begin(), chunk.positions.end());
    all.normals.insert(all.normals.end(), chunk.normals.begin(), chunk.normals.end());
    all.colors.insert(all.colors.end(), chunk.colors.begin(), chunk.colors.end());
    all.intensities.insert(all.intensities.end(), chunk.intensities.begin(), chunk.intensities.end());
  }
  return all;
}

/// The one-line message of the InputError that reading a file raises ("no error" if none).
std::string readError(const std::filesystem::path& path) {
  try {
    readAll(path);
  } catch (const InputError& error) {
    return error.what();
  }
  return "no error";
}

E57TestField field(const std::string& name, Type type, std::vector<double> values) {
  E57TestField result;
  result.name = name;
  result.type = type;
  result.values = std::move(values);
  return result;
}

E57TestField integerField(const std::string& name, std::int64_t minimum, std::int64_t maximum,
                          std::vector<double> values) {
  E57TestField result = field(name, Type::Integer, std::move(values));
  result.minimum = minimum;
  result.maximum = maximum;
  return result;
}

E57TestField scaledField(const std::string& name, std::int64_t minimum, std::int64_t maximum, double scale,
                         double offset, std::vector<double> values) {
  E57TestField result = field(name, Type::ScaledInteger, std::move(values));
  result.minimum = minimum;
  result.maximum = maximum;
  result.scale = scale;
  result.offset = offset;
  return result;
}

/// The value a reader should see for a written one: what the field's storage keeps of it.
double stored(const E57TestField& f, std::size_t i) {
  const double v = f.values[i];
  switch (f.type) {
    case Type::Float32:
      return static_cast<float>(v);
    case Type::Float64:
      return v;
    case Type::ScaledInteger:
      return static_cast<double>(std::llround((v - f.offset) / f.scale)) * f.scale + f.offset;
    case Type::Integer:
      return v;
  }
  return v;
}

std::vector<double> uniform(std::mt19937& random, std::size_t count, double low, double high) {
  std::uniform_real_distribution<double> distribution(low, high);
  std::vector<double> values(count);
  for (double& v : values) v = distribution(random);
  return values;
}

std::vector<double> integers(std::mt19937& random, std::size_t count, int low, int high) {
  std::uniform_int_distribution<int> distribution(low, high);
  std::vector<double> values(count);
  for (double& v : values) v = distribution(random);
  return values;
}

/// A scan with cartesian float coordinates, 8-bit colours and float intensity.
E57TestScan cartesianScan(std::mt19937& random, std::size_t count, Type coordinateType = Type::Float64) {
  E57TestScan scan;
  scan.fields = {field("cartesianX", coordinateType, uniform(random, count, -20.0, 20.0)),
                 field("cartesianY", coordinateType, uniform(random, count, -20.0, 20.0)),
                 field("cartesianZ", coordinateType, uniform(random, count, -3.0, 8.0)),
                 integerField("colorRed", 0, 255, integers(random, count, 0, 255)),
                 integerField("colorGreen", 0, 255, integers(random, count, 0, 255)),
                 integerField("colorBlue", 0, 255, integers(random, count, 0, 255)),
                 field("intensity", Type::Float32, uniform(random, count, 0.0, 1.0))};
  return scan;
}

const E57TestField& fieldNamed(const E57TestScan& scan, const std::string& name) {
  for (const E57TestField& f : scan.fields) {
    if (f.name == name) return f;
  }
  throw std::logic_error("no field " + name);
}

Eigen::Vector3d storedCartesian(const E57TestScan& scan, std::size_t i) {
  return {stored(fieldNamed(scan, "cartesianX"), i), stored(fieldNamed(scan, "cartesianY"), i),
          stored(fieldNamed(scan, "cartesianZ"), i)};
}

Eigen::Vector3d toWorld(const E57TestScan& scan, const Eigen::Vector3d& local) {
  const Eigen::Quaterniond q = scan.rotation.value_or(Eigen::Quaterniond::Identity());
  return q.normalized() * local + scan.translation.value_or(Eigen::Vector3d::Zero());
}

void expectNear(const Eigen::Vector3d& actual, const Eigen::Vector3d& expected, double tolerance, std::size_t index) {
  EXPECT_LE((actual - expected).cwiseAbs().maxCoeff(), tolerance)
      << "point " << index << ": " << actual.transpose() << " vs " << expected.transpose();
}

/// Expects points[first...] to be the scan's records (all valid), posed, with 8-bit colours.
void expectScan(const PointChunk& points, std::size_t first, const E57TestScan& scan, double tolerance) {
  const std::size_t count = scan.fields.front().values.size();
  ASSERT_GE(points.size(), first + count);
  for (std::size_t i = 0; i < count; ++i) {
    expectNear(points.positions[first + i], toWorld(scan, storedCartesian(scan, i)), tolerance, first + i);
    EXPECT_EQ(points.intensities[first + i], static_cast<float>(stored(fieldNamed(scan, "intensity"), i)));
  }
}

// ---------------------------------------------------------------------------------------------
// The real scan

struct PcdPoints {
  std::vector<Eigen::Vector3f> positions;
  std::vector<std::uint32_t> rgba;
  std::vector<float> intensities;
};

/// Decodes the pump-room PCD (v0.7, DATA binary, x y z rgba intensity, 4 bytes each).
PcdPoints readPumpPcd(const std::filesystem::path& path) {
  const std::string bytes = test::readFile(path);
  const std::string marker = "DATA binary\n";
  const std::size_t data = bytes.find(marker);
  if (data == std::string::npos) throw std::runtime_error("no DATA binary line in " + path.string());
  constexpr std::size_t kRecordBytes = 20;
  const std::size_t begin = data + marker.size();
  const std::size_t count = (bytes.size() - begin) / kRecordBytes;
  PcdPoints points;
  for (std::size_t i = 0; i < count; ++i) {
    const char* record = bytes.data() + begin + i * kRecordBytes;
    float xyz[3];
    std::uint32_t rgba;
    float intensity;
    std::memcpy(xyz, record, sizeof xyz);
    std::memcpy(&rgba, record + 12, sizeof rgba);
    std::memcpy(&intensity, record + 16, sizeof intensity);
    points.positions.emplace_back(xyz[0], xyz[1], xyz[2]);
    points.rgba.push_back(rgba);
    points.intensities.push_back(intensity);
  }
  return points;
}

const std::filesystem::path kPumpE57 = test::realDataDir() / "pumpAVisualReferenceImage.e57";

TEST(E57RealData, MatchesItsPcdConversion) {
  const PcdPoints expected = readPumpPcd(test::realDataDir() / "pumpA_pump_station.pcd");
  ASSERT_EQ(expected.positions.size(), 155201u);
  const PointChunk points = readAll(kPumpE57);
  ASSERT_EQ(points.size(), expected.positions.size());
  ASSERT_EQ(points.colors.size(), points.size());
  ASSERT_EQ(points.intensities.size(), points.size());
  std::size_t positionMismatches = 0, colorMismatches = 0, intensityMismatches = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d difference = points.positions[i] - expected.positions[i].cast<double>();
    if (difference.cwiseAbs().maxCoeff() > 1e-6) ++positionMismatches;
    const Color& c = points.colors[i];
    const std::uint32_t rgba = 0xFF000000u | std::uint32_t{c[0]} << 16 | std::uint32_t{c[1]} << 8 | c[2];
    if (rgba != expected.rgba[i]) ++colorMismatches;
    if (std::abs(points.intensities[i] - expected.intensities[i]) > 1e-6f) ++intensityMismatches;
  }
  EXPECT_EQ(positionMismatches, 0u);
  EXPECT_EQ(colorMismatches, 0u);
  EXPECT_EQ(intensityMismatches, 0u);
}

TEST(E57RealData, InfoDescribesThePrototype) {
  const auto reader = openPointReader(kPumpE57);
  const CloudInfo& info = reader->info();
  EXPECT_EQ(info.format, "E57 1.0");
  EXPECT_EQ(info.declaredPoints, 155201u);
  EXPECT_EQ(info.attributes, kColors | kIntensity);
  EXPECT_EQ(info.fields,
            (std::vector<std::string>{"cartesianX", "cartesianY", "cartesianZ", "intensity", "colorRed", "colorGreen",
                                      "colorBlue", "rowIndex", "columnIndex", "cartesianInvalidState"}));
  EXPECT_LT(reader->progress(), 1e-3);  // only the section header is read yet
}

TEST(E57RealData, ReadPointCloudKeepsEveryPointInsideTheDeclaredBounds) {
  ReadReport report;
  const PointCloud cloud = readPointCloud(kPumpE57, {}, &report);
  EXPECT_EQ(cloud.size(), 155201u);
  EXPECT_EQ(report.nonFiniteDropped, 0u);
  EXPECT_TRUE(cloud.hasColors());
  EXPECT_TRUE(cloud.hasIntensity());
  // cartesianBounds of the file's XML.
  const BoundingBox box = cloud.boundingBox();
  EXPECT_NEAR(box.min.x(), -2.903764, 1e-5);
  EXPECT_NEAR(box.max.x(), 1.721604, 1e-5);
  EXPECT_NEAR(box.min.y(), -5.301103, 1e-5);
  EXPECT_NEAR(box.max.y(), -0.792647, 1e-5);
  EXPECT_NEAR(box.min.z(), -1.899705, 1e-5);
  EXPECT_NEAR(box.max.z(), 1.843003, 1e-5);
}

// ---------------------------------------------------------------------------------------------
// Round trips

TEST(E57RoundTrip, TwoPosedScansWithFloatScaledAndIntegerFields) {
  test::TempDir dir;
  std::mt19937 random(57);
  E57TestScan first = cartesianScan(random, 500, Type::Float64);
  first.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  first.translation = Eigen::Vector3d(10.0, -5.0, 2.0);

  constexpr std::size_t kSecond = 700;
  E57TestScan second;
  second.fields = {field("cartesianX", Type::Float32, uniform(random, kSecond, -30.0, 30.0)),
                   scaledField("cartesianY", -100000, 100000, 0.001, 100.0, uniform(random, kSecond, 5.0, 190.0)),
                   integerField("cartesianZ", -50, 50, integers(random, kSecond, -50, 50)),
                   integerField("colorRed", 0, 65535, integers(random, kSecond, 0, 65535)),
                   integerField("colorGreen", 0, 65535, integers(random, kSecond, 0, 65535)),
                   integerField("colorBlue", 0, 65535, integers(random, kSecond, 0, 65535)),
                   scaledField("intensity", 0, 4095, 1.0 / 4095.0, 0.0, integers(random, kSecond, 0, 4095)),
                   integerField("rowIndex", 0, 999, integers(random, kSecond, 0, 999)),
                   field("timeStamp", Type::Float64, uniform(random, kSecond, 0.0, 1e4))};
  for (double& v : second.fields[6].values) v /= 4095.0;
  second.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(-2.0, Eigen::Vector3d::UnitZ()));
  second.translation = Eigen::Vector3d(-300.5, 42.25, 0.125);

  const auto path = dir / "two.e57";
  test::writeE57(path, {first, second});
  const auto reader = openPointReader(path);
  EXPECT_EQ(reader->info().declaredPoints, 1200u);
  EXPECT_EQ(reader->info().attributes, kColors | kIntensity);
  EXPECT_EQ(reader->info().fields,
            (std::vector<std::string>{"cartesianX", "cartesianY", "cartesianZ", "colorRed", "colorGreen", "colorBlue",
                                      "intensity", "rowIndex", "timeStamp"}));

  const PointChunk points = readAll(path);
  ASSERT_EQ(points.size(), 1200u);
  expectScan(points, 0, first, 1e-9);
  expectScan(points, 500, second, 1e-9);
  for (std::size_t i = 0; i < 500; ++i) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(points.colors[i][c], first.fields[3 + static_cast<std::size_t>(c)].values[i]) << "point " << i;
    }
  }
  for (std::size_t i = 0; i < kSecond; ++i) {
    for (int c = 0; c < 3; ++c) {
      const double sixteenBit = second.fields[3 + static_cast<std::size_t>(c)].values[i];
      EXPECT_EQ(points.colors[500 + i][c], std::lround(sixteenBit / 65535.0 * 255.0)) << "point " << i;
    }
  }
}

TEST(E57RoundTrip, SinglePrecisionCoordinatesKeepTheirFloatValues) {
  test::TempDir dir;
  std::mt19937 random(3);
  E57TestScan scan = cartesianScan(random, 300, Type::Float32);
  scan.translation = Eigen::Vector3d(1.0, 2.0, 3.0);
  const auto path = dir / "single.e57";
  test::writeE57(path, {scan});
  const PointChunk points = readAll(path);
  ASSERT_EQ(points.size(), 300u);
  expectScan(points, 0, scan, 1e-12);
}

TEST(E57RoundTrip, SphericalCoordinatesBecomeCartesianAndInvalidOnesAreSkipped) {
  test::TempDir dir;
  std::mt19937 random(11);
  constexpr std::size_t kCount = 400;
  E57TestScan scan;
  scan.fields = {scaledField("sphericalRange", 0, 1 << 20, 1e-5, 0.0, uniform(random, kCount, 0.5, 10.0)),
                 field("sphericalAzimuth", Type::Float64, uniform(random, kCount, -kPi, kPi)),
                 field("sphericalElevation", Type::Float32, uniform(random, kCount, -kPi / 2, kPi / 2)),
                 integerField("sphericalInvalidState", 0, 2, {})};
  for (std::size_t i = 0; i < kCount; ++i)
    scan.fields[3].values.push_back(static_cast<double>(i % 5 == 0 ? 2 : i % 7 == 0 ? 1 : 0));
  scan.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitX()));
  scan.translation = Eigen::Vector3d(0.0, 0.0, 1.5);
  const auto path = dir / "spherical.e57";
  test::writeE57(path, {scan});

  const PointChunk points = readAll(path);
  std::size_t next = 0;
  for (std::size_t i = 0; i < kCount; ++i) {
    if (scan.fields[3].values[i] != 0.0) continue;
    const double r = stored(scan.fields[0], i), az = stored(scan.fields[1], i), el = stored(scan.fields[2], i);
    const Eigen::Vector3d local(r * std::cos(el) * std::cos(az), r * std::cos(el) * std::sin(az), r * std::sin(el));
    ASSERT_LT(next, points.size());
    expectNear(points.positions[next], toWorld(scan, local), 1e-9, next);
    ++next;
  }
  EXPECT_EQ(points.size(), next);
  EXPECT_LT(points.size(), kCount);
  EXPECT_TRUE(points.colors.empty());
  EXPECT_TRUE(points.intensities.empty());
}

TEST(E57RoundTrip, CartesianInvalidStatesOneAndTwoAreSkipped) {
  test::TempDir dir;
  std::mt19937 random(5);
  E57TestScan scan = cartesianScan(random, 9);
  scan.fields.push_back(integerField("cartesianInvalidState", 0, 2, {0, 1, 2, 0, 0, 2, 1, 1, 0}));
  const auto path = dir / "states.e57";
  test::writeE57(path, {scan});
  const PointChunk points = readAll(path);
  const std::vector<std::size_t> valid{0, 3, 4, 8};
  ASSERT_EQ(points.size(), valid.size());
  for (std::size_t k = 0; k < valid.size(); ++k) {
    expectNear(points.positions[k], storedCartesian(scan, valid[k]), 0.0, k);
    EXPECT_EQ(points.colors[k][0], scan.fields[3].values[valid[k]]);
  }
}

TEST(E57RoundTrip, ManyDataPacketsAcrossPagesWithIndexAndEmptyPackets) {
  test::TempDir dir;
  std::mt19937 random(23);
  constexpr std::size_t kCount = 20000;
  E57TestScan scan = cartesianScan(random, kCount);
  scan.fields.push_back(integerField("rowIndex", 0, 1023, integers(random, kCount, 0, 1023)));
  scan.fields.push_back(field("timeStamp", Type::Float64, uniform(random, kCount, 0.0, 100.0)));
  test::E57TestOptions options;
  options.emptyAndIndexPackets = true;
  const auto path = dir / "packets.e57";
  const test::E57TestLayout layout = test::writeE57(path, {scan}, options);
  EXPECT_GT(layout.sections[0].dataPackets.size(), 10u);  // about 800 KB of data in 64 KiB packets

  const PointChunk points = readAll(path);
  ASSERT_EQ(points.size(), kCount);
  expectScan(points, 0, scan, 0.0);
}

TEST(E57RoundTrip, OddBitWidthsStraddleSmallPackets) {
  test::TempDir dir;
  std::mt19937 random(29);
  constexpr std::size_t kCount = 3000;
  E57TestScan scan;
  scan.fields = {scaledField("cartesianX", -8388608, 8388607, 1e-6, 0.0, uniform(random, kCount, -8.0, 8.0)),
                 scaledField("cartesianY", -8388608, 8388607, 1e-6, 0.0, uniform(random, kCount, -8.0, 8.0)),
                 scaledField("cartesianZ", -1000, 1000, 0.003, -1.0, uniform(random, kCount, -3.0, 1.0)),
                 scaledField("intensity", 0, 32767, 1.0 / 32767.0, 0.0, uniform(random, kCount, 0.0, 1.0)),
                 integerField("colorRed", 0, 255, integers(random, kCount, 0, 255)),
                 integerField("colorGreen", 0, 255, integers(random, kCount, 0, 255)),
                 integerField("colorBlue", 0, 255, integers(random, kCount, 0, 255)),
                 integerField("columnIndex", 0, 6, integers(random, kCount, 0, 6))};
  test::E57TestOptions options;
  options.maxPacketBytes = 200;
  const auto path = dir / "small-packets.e57";
  const test::E57TestLayout layout = test::writeE57(path, {scan}, options);
  EXPECT_GT(layout.sections[0].dataPackets.size(), 100u);
  const PointChunk points = readAll(path);
  ASSERT_EQ(points.size(), kCount);
  expectScan(points, 0, scan, 1e-12);
}

TEST(E57RoundTrip, EmptyScanBetweenTwoScans) {
  test::TempDir dir;
  std::mt19937 random(31);
  const E57TestScan first = cartesianScan(random, 10);
  const E57TestScan empty = cartesianScan(random, 0);
  E57TestScan last = cartesianScan(random, 5);
  last.translation = Eigen::Vector3d(0.0, 100.0, 0.0);
  const auto path = dir / "empty-scan.e57";
  test::writeE57(path, {first, empty, last});
  EXPECT_EQ(openPointReader(path)->info().declaredPoints, 15u);
  const PointChunk points = readAll(path);
  ASSERT_EQ(points.size(), 15u);
  expectScan(points, 0, first, 0.0);
  expectScan(points, 10, last, 0.0);

  const auto onlyEmpty = dir / "only-empty.e57";
  test::writeE57(onlyEmpty, {empty});
  const auto reader = openPointReader(onlyEmpty);
  PointChunk chunk;
  EXPECT_EQ(reader->read(chunk, 100), 0u);
  EXPECT_EQ(reader->progress(), 1.0);
}

TEST(E57RoundTrip, ConstantFieldsNeedNoBytes) {
  test::TempDir dir;
  std::mt19937 random(37);
  constexpr std::size_t kCount = 50;
  E57TestScan scan;
  scan.fields = {field("cartesianX", Type::Float64, uniform(random, kCount, -1.0, 1.0)),
                 field("cartesianY", Type::Float64, uniform(random, kCount, -1.0, 1.0)),
                 scaledField("cartesianZ", 250, 250, 0.01, 0.0, std::vector<double>(kCount, 2.5)),
                 integerField("returnIndex", 3, 3, std::vector<double>(kCount, 3.0))};
  const auto path = dir / "constant.e57";
  test::writeE57(path, {scan});
  const PointChunk points = readAll(path);
  ASSERT_EQ(points.size(), kCount);
  for (std::size_t i = 0; i < kCount; ++i) expectNear(points.positions[i], storedCartesian(scan, i), 1e-12, i);
}

TEST(E57RoundTrip, FloatColoursScaleByTheirDeclaredRange) {
  test::TempDir dir;
  E57TestScan scan;
  scan.fields = {
      field("cartesianX", Type::Float64, {0.0, 1.0, 2.0}),  field("cartesianY", Type::Float64, {0.0, 0.0, 0.0}),
      field("cartesianZ", Type::Float64, {0.0, 0.0, 0.0}),  field("colorRed", Type::Float32, {0.0, 0.5, 1.0}),
      field("colorGreen", Type::Float32, {1.0, 0.25, 0.0}), field("colorBlue", Type::Float32, {0.2, 0.4, 0.6})};
  for (std::size_t c = 3; c < 6; ++c) {
    scan.fields[c].floatMinimum = 0.0;
    scan.fields[c].floatMaximum = 1.0;
  }
  const auto path = dir / "float-colours.e57";
  test::writeE57(path, {scan});
  const PointChunk points = readAll(path);
  ASSERT_EQ(points.colors.size(), 3u);
  EXPECT_EQ(points.colors[0], Color(0, 255, 51));
  EXPECT_EQ(points.colors[1], Color(128, 64, 102));
  EXPECT_EQ(points.colors[2], Color(255, 0, 153));
}

TEST(E57RoundTrip, ScanWithoutColoursGetsBlackBesideOneWithColours) {
  test::TempDir dir;
  std::mt19937 random(41);
  const E57TestScan coloured = cartesianScan(random, 4);
  E57TestScan plain = cartesianScan(random, 3);
  plain.fields.resize(3);  // coordinates only
  const auto path = dir / "mixed.e57";
  test::writeE57(path, {coloured, plain});
  const PointChunk points = readAll(path);
  ASSERT_EQ(points.size(), 7u);
  ASSERT_EQ(points.colors.size(), 7u);
  ASSERT_EQ(points.intensities.size(), 7u);
  EXPECT_EQ(points.colors[1][2], coloured.fields[5].values[1]);
  for (std::size_t i = 4; i < 7; ++i) {
    EXPECT_EQ(points.colors[i], Color(0, 0, 0));
    EXPECT_EQ(points.intensities[i], 0.0f);
    expectNear(points.positions[i], storedCartesian(plain, i - 4), 0.0, i);
  }
}

TEST(E57RoundTrip, SurfaceNormalsExtensionIsRotatedByThePose) {
  test::TempDir dir;
  std::mt19937 random(43);
  E57TestScan scan = cartesianScan(random, 3);
  scan.fields.push_back(field("nor:normalX", Type::Float32, {1.0, 0.0, 0.0}));
  scan.fields.push_back(field("nor:normalY", Type::Float32, {0.0, 1.0, 0.0}));
  scan.fields.push_back(field("nor:normalZ", Type::Float32, {0.0, 0.0, 1.0}));
  scan.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitZ()));
  const auto path = dir / "normals.e57";
  test::writeE57(path, {scan});
  EXPECT_EQ(openPointReader(path)->info().attributes, kNormals | kColors | kIntensity);
  const PointChunk points = readAll(path);
  ASSERT_EQ(points.normals.size(), 3u);
  EXPECT_TRUE(points.normals[0].isApprox(Eigen::Vector3f(0, 1, 0), 1e-6f)) << points.normals[0].transpose();
  EXPECT_TRUE(points.normals[1].isApprox(Eigen::Vector3f(-1, 0, 0), 1e-6f)) << points.normals[1].transpose();
  EXPECT_TRUE(points.normals[2].isApprox(Eigen::Vector3f(0, 0, 1), 1e-6f)) << points.normals[2].transpose();
}

// ---------------------------------------------------------------------------------------------
// Chunks and progress

void expectSameChunks(const PointChunk& small, const PointChunk& big) {
  ASSERT_EQ(small.size(), big.size());
  EXPECT_TRUE(small.positions == big.positions);
  EXPECT_TRUE(small.normals == big.normals);
  EXPECT_TRUE(small.colors == big.colors);
  EXPECT_TRUE(small.intensities == big.intensities);
}

TEST(E57Chunks, SmallChunksGiveTheSamePointsAsOneBigChunk) {
  expectSameChunks(readAll(kPumpE57, 1000), readAll(kPumpE57));

  test::TempDir dir;
  std::mt19937 random(43);
  E57TestScan first = cartesianScan(random, 2500);
  first.fields.push_back(integerField("cartesianInvalidState", 0, 2, integers(random, 2500, 0, 2)));
  E57TestScan second = cartesianScan(random, 1800, Type::Float32);
  second.rotation = Eigen::Quaterniond(0.5, 0.5, 0.5, 0.5);
  const auto path = dir / "chunks.e57";
  test::E57TestOptions options;
  options.maxPacketBytes = 4096;
  test::writeE57(path, {first, second}, options);
  expectSameChunks(readAll(path, 7), readAll(path));
}

TEST(E57Chunks, ChunksAreFullUntilTheLastAndProgressClimbsToOne) {
  const auto reader = openPointReader(kPumpE57);
  PointChunk chunk;
  std::size_t total = 0;
  double previous = reader->progress();
  while (const std::size_t count = reader->read(chunk, 1000)) {
    total += count;
    if (total < 155201u) {
      EXPECT_EQ(count, 1000u);
    }
    EXPECT_GE(reader->progress(), previous);
    previous = reader->progress();
  }
  EXPECT_EQ(total, 155201u);
  EXPECT_DOUBLE_EQ(reader->progress(), 1.0);
}

// ---------------------------------------------------------------------------------------------
// Malformed files

/// A valid one-scan file of `count` points (several pages), and its layout.
test::E57TestLayout writeSmallFile(const std::filesystem::path& path, std::size_t count = 200,
                                   const test::E57TestOptions& options = {}) {
  std::mt19937 random(47);
  return test::writeE57(path, {cartesianScan(random, count)}, options);
}

std::string replaceAll(std::string text, const std::string& from, const std::string& to) {
  for (std::size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size())) {
    text.replace(at, from.size(), to);
  }
  return text;
}

test::E57TestOptions editingXml(std::function<std::string(const std::string&)> edit) {
  test::E57TestOptions options;
  options.editXml = std::move(edit);
  return options;
}

TEST(E57Malformed, NotAnE57Signature) {
  test::TempDir dir;
  test::writeFile(dir / "fake.e57", "ply\nformat ascii 1.0\nend_header\n" + std::string(100, ' '));
  EXPECT_THAT(readError(dir / "fake.e57"),
              AllOf(HasSubstr("byte 0"), HasSubstr("ASTM-E57"), HasSubstr("not an E57 file")));
}

TEST(E57Malformed, TruncatedHeader) {
  test::TempDir dir;
  test::writeFile(dir / "short.e57", "ASTM-E57" + std::string(12, '\0'));
  EXPECT_THAT(readError(dir / "short.e57"), AllOf(HasSubstr("byte 20"), HasSubstr("truncated"), HasSubstr("48-byte")));
}

TEST(E57Malformed, FileShorterThanItsPhysicalLength) {
  test::TempDir dir;
  const auto path = dir / "cut.e57";
  writeSmallFile(path);
  const std::string bytes = test::readFile(path);
  test::writeFile(path, bytes.substr(0, bytes.size() - 1024));
  EXPECT_THAT(readError(path),
              AllOf(HasSubstr("byte 16"), HasSubstr("filePhysicalLength " + std::to_string(bytes.size())),
                    HasSubstr("disagrees with the file size")));
}

TEST(E57Malformed, BadPageSize) {
  test::TempDir dir;
  const auto path = dir / "page.e57";
  writeSmallFile(path);
  test::patchE57(path, 40, test::littleEndianBytes(1000, 8));
  EXPECT_THAT(readError(path), AllOf(HasSubstr("byte 40"), HasSubstr("bad page size 1000")));
}

TEST(E57Malformed, ChecksumMismatchNamesThePage) {
  test::TempDir dir;
  const auto path = dir / "crc.e57";
  writeSmallFile(path, 2000);
  std::string bytes = test::readFile(path);
  ASSERT_GT(bytes.size(), 5u * 1024);
  bytes[3 * 1024 + 100] ^= 0x10;  // a data page; its checksum is left as it was
  test::writeFile(path, bytes);
  EXPECT_THAT(readError(path), AllOf(HasSubstr("byte 3072"), HasSubstr("checksum mismatch")));
}

TEST(E57Malformed, XmlNotWellFormed) {
  test::TempDir dir;
  const auto path = dir / "xml.e57";
  writeSmallFile(path, 200,
                 editingXml([](const std::string& xml) { return replaceAll(xml, "</data3D>", "</data3d>"); }));
  const std::string message = readError(path);
  EXPECT_THAT(message, AllOf(HasSubstr("XML is not well-formed"), HasSubstr("byte ")));
  EXPECT_THAT(message, ::testing::Not(HasSubstr("byte 0:")));  // located inside the XML section
}

TEST(E57Malformed, XmlWithoutData3D) {
  test::TempDir dir;
  const auto path = dir / "no-data3d.e57";
  writeSmallFile(path, 20, editingXml([](const std::string& xml) { return replaceAll(xml, "data3D", "data4D"); }));
  EXPECT_THAT(readError(path), AllOf(HasSubstr("element /data3D:"), HasSubstr("missing")));
}

TEST(E57Malformed, XmlWithoutPoints) {
  test::TempDir dir;
  const auto path = dir / "no-points.e57";
  writeSmallFile(path, 20, editingXml([](const std::string& xml) {
                   return replaceAll(replaceAll(xml, "<points ", "<dots "), "</points>", "</dots>");
                 }));
  EXPECT_THAT(readError(path), AllOf(HasSubstr("element /data3D/0/points:"), HasSubstr("missing")));
}

TEST(E57Malformed, XmlWithoutPrototype) {
  test::TempDir dir;
  const auto path = dir / "no-prototype.e57";
  writeSmallFile(path, 20,
                 editingXml([](const std::string& xml) { return replaceAll(xml, "prototype", "archetype"); }));
  EXPECT_THAT(readError(path), AllOf(HasSubstr("element /data3D/0/points/prototype:"), HasSubstr("missing")));
}

TEST(E57Malformed, UnsupportedFieldType) {
  test::TempDir dir;
  const auto path = dir / "string-field.e57";
  writeSmallFile(path, 20, editingXml([](const std::string& xml) {
                   return replaceAll(xml, "</prototype>", "  <label type=\"String\"/>\n        </prototype>");
                 }));
  EXPECT_THAT(readError(path), AllOf(HasSubstr("element /data3D/0/points/prototype/label:"),
                                     HasSubstr("unsupported field type \"String\"")));
}

TEST(E57Malformed, AbsurdRecordCount) {
  test::TempDir dir;
  std::mt19937 random(53);
  E57TestScan scan = cartesianScan(random, 100);
  scan.declaredRecordCount = 1'000'000'000'000'000ull;
  const auto path = dir / "absurd.e57";
  test::writeE57(path, {scan});
  EXPECT_THAT(readError(path), AllOf(HasSubstr("element /data3D/0/points:"), HasSubstr("recordCount 1000000000000000"),
                                     HasSubstr("more than")));
}

TEST(E57Malformed, BadPacketType) {
  test::TempDir dir;
  const auto path = dir / "packet-type.e57";
  const auto layout = writeSmallFile(path);
  const std::uint64_t packet = layout.sections[0].dataPackets[0];
  test::patchE57(path, packet, "\x07");
  EXPECT_THAT(readError(path), AllOf(HasSubstr("byte " + std::to_string(packet)), HasSubstr("bad packet type 7")));
}

TEST(E57Malformed, PacketRunningPastItsSection) {
  test::TempDir dir;
  const auto path = dir / "packet-length.e57";
  const auto layout = writeSmallFile(path);
  const std::uint64_t packet = layout.sections[0].dataPackets.back();
  test::patchE57(path, packet + 2, test::littleEndianBytes(0xFFFF, 2));
  EXPECT_THAT(readError(path), AllOf(HasSubstr("byte " + std::to_string(packet)), HasSubstr("bad packet length 65536"),
                                     HasSubstr("past the end of its section")));
}

TEST(E57Malformed, BytestreamLengthsExceedingThePacket) {
  test::TempDir dir;
  const auto path = dir / "stream-length.e57";
  const auto layout = writeSmallFile(path);
  const std::uint64_t packet = layout.sections[0].dataPackets[0];
  test::patchE57(path, packet + 6, test::littleEndianBytes(60000, 2));
  EXPECT_THAT(readError(path), AllOf(HasSubstr("byte " + std::to_string(packet)), HasSubstr("bytestream lengths"),
                                     HasSubstr("more than the packet length")));
}

TEST(E57Malformed, BytestreamCountDifferentFromThePrototype) {
  test::TempDir dir;
  const auto path = dir / "stream-count.e57";
  const auto layout = writeSmallFile(path);
  const std::uint64_t packet = layout.sections[0].dataPackets[0];
  test::patchE57(path, packet + 4, test::littleEndianBytes(3, 2));
  EXPECT_THAT(readError(path),
              AllOf(HasSubstr("byte " + std::to_string(packet)), HasSubstr("bytestreamCount 3, expected 7")));
}

TEST(E57Malformed, DataEndingBeforeRecordCount) {
  test::TempDir dir;
  std::mt19937 random(59);
  E57TestScan scan = cartesianScan(random, 1000);
  scan.declaredRecordCount = 1001;
  const auto path = dir / "short-data.e57";
  test::writeE57(path, {scan});
  EXPECT_THAT(readError(path), AllOf(HasSubstr("data ends after 1000 of 1001 records of /data3D/0/points")));
}

}  // namespace
}  // namespace piperun
