// LAS reader: files built byte by byte from the ASPRS LAS 1.2/1.3/1.4 layouts, read back.

#include "io/readers.h"
#include "piperun/error.h"
#include "piperun/io/point_reader.h"
#include "test_util.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <cstring>
#include <limits>

namespace piperun {
namespace {

using test::TempDir;
using test::writeFile;
using ::testing::HasSubstr;

// ---------------------------------------------------------------------------------------------
// A minimal LAS writer for the tests.

struct LasPoint {
  std::array<std::int32_t, 3> raw;  // stored integer coordinates
  std::uint16_t intensity = 0;
  std::uint8_t classification = 0;
  std::array<std::uint16_t, 3> rgb{};
};

struct LasSpec {
  unsigned minor = 2;
  unsigned format = 0;
  unsigned vlrCount = 2;
  std::uint16_t extraBytes = 3;  // per record, after the format's standard fields
  std::array<double, 3> scale{0.001, 0.01, 0.0001};
  std::array<double, 3> offset{500000.0, 4000000.0, 100.0};
  std::vector<LasPoint> points;
  /// Projection VLRs (user ID "LASF_Projection"): record ID and payload, after the other VLRs.
  std::vector<std::pair<std::uint16_t, std::string>> projection;
  std::uint16_t globalEncoding = 0;
};

constexpr std::array<std::uint16_t, 11> kStandardRecordSize = {20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67};
constexpr std::array<int, 11> kColorAt = {-1, -1, 20, 28, -1, 28, -1, 30, 30, -1, 30};
constexpr std::size_t kVlrHeaderBytes = 54;
constexpr std::size_t kVlrPayloadBytes = 10;

std::uint16_t headerSize(unsigned minor) { return minor >= 4 ? 375 : minor == 3 ? 235 : 227; }
std::size_t recordLength(const LasSpec& spec) { return kStandardRecordSize[spec.format] + spec.extraBytes; }

template <class T>
void put(std::string& bytes, std::size_t at, T value) {
  std::memcpy(&bytes[at], &value, sizeof value);
}

template <class T>
T get(const std::string& bytes, std::size_t at) {
  T value;
  std::memcpy(&value, &bytes[at], sizeof value);
  return value;
}

std::string buildLas(const LasSpec& spec) {
  const std::uint16_t headerBytes = headerSize(spec.minor);
  std::string bytes(headerBytes, '\0');
  std::memcpy(&bytes[0], "LASF", 4);
  bytes[24] = 1;
  bytes[25] = static_cast<char>(spec.minor);
  std::memcpy(&bytes[58], "piperun tests", 13);
  put<std::uint16_t>(bytes, 94, headerBytes);
  put<std::uint16_t>(bytes, 6, spec.globalEncoding);
  std::size_t projectionBytes = 0;
  for (const auto& [record, payload] : spec.projection) projectionBytes += kVlrHeaderBytes + payload.size();
  const auto pointDataOffset = static_cast<std::uint32_t>(
      headerBytes + spec.vlrCount * (kVlrHeaderBytes + kVlrPayloadBytes) + projectionBytes);
  put<std::uint32_t>(bytes, 96, pointDataOffset);
  put<std::uint32_t>(bytes, 100, static_cast<std::uint32_t>(spec.vlrCount + spec.projection.size()));
  bytes[104] = static_cast<char>(spec.format);
  put<std::uint16_t>(bytes, 105, static_cast<std::uint16_t>(recordLength(spec)));
  const auto count = static_cast<std::uint32_t>(spec.points.size());
  // LAS 1.4 keeps the legacy count at 0 for formats 6-10, which it cannot describe.
  put<std::uint32_t>(bytes, 107, spec.minor >= 4 && spec.format >= 6 ? 0 : count);
  for (int axis = 0; axis < 3; ++axis) {
    put<double>(bytes, 131 + 8 * axis, spec.scale[axis]);
    put<double>(bytes, 155 + 8 * axis, spec.offset[axis]);
    double low = std::numeric_limits<double>::max();
    double high = std::numeric_limits<double>::lowest();
    for (const auto& point : spec.points) {
      const double world = point.raw[axis] * spec.scale[axis] + spec.offset[axis];
      low = std::min(low, world);
      high = std::max(high, world);
    }
    put<double>(bytes, 179 + 16 * axis, high);
    put<double>(bytes, 187 + 16 * axis, low);
  }
  if (spec.minor >= 4) put<std::uint64_t>(bytes, 247, count);

  for (unsigned i = 0; i < spec.vlrCount; ++i) {
    std::string vlr(kVlrHeaderBytes, '\0');
    std::memcpy(&vlr[2], "piperun", 7);
    put<std::uint16_t>(vlr, 18, static_cast<std::uint16_t>(i));
    put<std::uint16_t>(vlr, 20, kVlrPayloadBytes);
    bytes += vlr + std::string(kVlrPayloadBytes, '\xEE');
  }
  for (const auto& [record, payload] : spec.projection) {
    std::string vlr(kVlrHeaderBytes, '\0');
    std::memcpy(&vlr[2], "LASF_Projection", 15);
    put<std::uint16_t>(vlr, 18, record);
    put<std::uint16_t>(vlr, 20, static_cast<std::uint16_t>(payload.size()));
    bytes += vlr + payload;
  }

  for (const auto& point : spec.points) {
    // Fields the reader skips (returns, flags, scan angle, GPS time, NIR, wave packets, extra
    // bytes) hold a recognisable filler.
    std::string record(recordLength(spec), '\x5A');
    for (int axis = 0; axis < 3; ++axis) put<std::int32_t>(record, 4 * axis, point.raw[axis]);
    put<std::uint16_t>(record, 12, point.intensity);
    if (spec.format <= 5) {
      record[15] = static_cast<char>(point.classification | 0xE0);  // synthetic, key-point, withheld flags
    } else {
      record[16] = static_cast<char>(point.classification);
    }
    if (kColorAt[spec.format] >= 0) {
      for (int channel = 0; channel < 3; ++channel) {
        put<std::uint16_t>(record, kColorAt[spec.format] + 2 * channel, point.rgb[channel]);
      }
    }
    bytes += record;
  }
  return bytes;
}

bool hasColor(unsigned format) { return kColorAt[format] >= 0; }

/// Three points spanning the int32 range, with the world coordinates they stand for under the
/// default scale (0.001, 0.01, 0.0001) and offset (500000, 4000000, 100).
std::vector<LasPoint> samplePoints(unsigned format) {
  const std::uint8_t highClass = format <= 5 ? 31 : 200;
  return {
      {{123456, -7890, 42}, 65535, 2, {65535, 32768, 255}},
      {{0, 0, 0}, 0, highClass, {256, 511, 0}},
      {{std::numeric_limits<std::int32_t>::max(), std::numeric_limits<std::int32_t>::min(), -1}, 1234, 0, {0, 0, 0}},
  };
}

const std::array<Eigen::Vector3d, 3> kSampleWorld = {
    Eigen::Vector3d(500123.456, 3999921.1, 100.0042),
    Eigen::Vector3d(500000.0, 4000000.0, 100.0),
    Eigen::Vector3d(2647483.647, -17474836.48, 99.9999),
};

template <class T>
void appendAll(std::vector<T>& to, const std::vector<T>& from) {
  to.insert(to.end(), from.begin(), from.end());
}

PointChunk readAll(PointReader& reader, std::size_t chunkPoints = 1u << 20) {
  PointChunk all;
  PointChunk chunk;
  while (reader.read(chunk, chunkPoints) > 0) {
    EXPECT_LE(chunk.size(), chunkPoints);
    chunk.checkConsistent();
    appendAll(all.positions, chunk.positions);
    appendAll(all.colors, chunk.colors);
    appendAll(all.intensities, chunk.intensities);
    appendAll(all.labels, chunk.labels);
  }
  return all;
}

PointChunk readAll(const std::filesystem::path& path, std::size_t chunkPoints = 1u << 20) {
  return readAll(*openPointReader(path), chunkPoints);
}

std::string openError(const std::filesystem::path& path) {
  try {
    readAll(path);
  } catch (const InputError& error) {
    return error.what();
  }
  ADD_FAILURE() << "reading " << path << " did not throw InputError";
  return {};
}

/// The message reading these bytes as "scan.las" throws.
std::string lasError(const std::string& bytes) {
  TempDir dir;
  writeFile(dir / "scan.las", bytes);
  return openError(dir / "scan.las");
}

LasSpec sampleSpec(unsigned minor, unsigned format) {
  LasSpec spec;
  spec.minor = minor;
  spec.format = format;
  spec.points = samplePoints(format);
  return spec;
}

// ---------------------------------------------------------------------------------------------
// Every point data record format, in the versions that define it.

struct VersionAndFormat {
  unsigned minor;
  unsigned format;
};

// Names the parameter in test listings ("LAS 1.4 format 6") instead of its raw bytes.
void PrintTo(const VersionAndFormat& value, std::ostream* out) {
  *out << "LAS 1." << value.minor << " format " << value.format;
}

class LasRoundTrip : public ::testing::TestWithParam<VersionAndFormat> {};

TEST_P(LasRoundTrip, ReadsScaledPositionsIntensityClassificationAndColor) {
  const auto [minor, format] = GetParam();
  const LasSpec spec = sampleSpec(minor, format);
  TempDir dir;
  writeFile(dir / "scan.las", buildLas(spec));

  auto reader = openPointReader(dir / "scan.las");
  const CloudInfo& info = reader->info();
  EXPECT_EQ(info.format, "LAS 1." + std::to_string(minor) + " format " + std::to_string(format));
  ASSERT_TRUE(info.declaredPoints.has_value());
  EXPECT_EQ(*info.declaredPoints, 3u);
  EXPECT_EQ(info.attributes, kIntensity | kLabels | (hasColor(format) ? kColors : kNoAttributes));

  const auto points = readAll(*reader);
  ASSERT_EQ(points.size(), 3u);
  EXPECT_EQ(points.attributes(), info.attributes);
  for (std::size_t i = 0; i < 3; ++i) {
    for (int axis = 0; axis < 3; ++axis) {
      // A millionth of the quantisation step: any error in scale or offset shows.
      EXPECT_NEAR(points.positions[i][axis], kSampleWorld[i][axis], 1e-6 * spec.scale[axis])
          << "point " << i << " axis " << axis;
    }
    EXPECT_EQ(points.intensities[i], static_cast<float>(spec.points[i].intensity));
    EXPECT_EQ(points.labels[i], spec.points[i].classification);
  }
  if (hasColor(format)) {
    EXPECT_EQ(points.colors[0], Color(255, 128, 0));
    EXPECT_EQ(points.colors[1], Color(1, 1, 0));
    EXPECT_EQ(points.colors[2], Color(0, 0, 0));
  }
}

INSTANTIATE_TEST_SUITE_P(LasFormats, LasRoundTrip,
                         ::testing::Values(VersionAndFormat{2, 0}, VersionAndFormat{2, 1}, VersionAndFormat{2, 2},
                                           VersionAndFormat{2, 3}, VersionAndFormat{3, 4}, VersionAndFormat{3, 5},
                                           VersionAndFormat{4, 0}, VersionAndFormat{4, 3}, VersionAndFormat{4, 6},
                                           VersionAndFormat{4, 7}, VersionAndFormat{4, 8}, VersionAndFormat{4, 9},
                                           VersionAndFormat{4, 10}),
                         [](const ::testing::TestParamInfo<VersionAndFormat>& param) {
                           return "Las1" + std::to_string(param.param.minor) + "Format" +
                                  std::to_string(param.param.format);
                         });

TEST(LasReader, Version14UsesThe64BitPointCount) {
  LasSpec spec = sampleSpec(4, 1);
  std::string bytes = buildLas(spec);
  put<std::uint32_t>(bytes, 107, 1);  // a stale legacy count
  TempDir dir;
  writeFile(dir / "scan.las", bytes);
  EXPECT_EQ(readAll(dir / "scan.las").size(), 3u);
}

TEST(LasReader, NoVlrsNoExtraBytes) {
  LasSpec spec = sampleSpec(2, 3);
  spec.vlrCount = 0;
  spec.extraBytes = 0;
  TempDir dir;
  writeFile(dir / "scan.las", buildLas(spec));
  const auto points = readAll(dir / "scan.las");
  ASSERT_EQ(points.size(), 3u);
  EXPECT_NEAR(points.positions[0].x(), kSampleWorld[0].x(), 1e-9);
  EXPECT_EQ(points.colors[0], Color(255, 128, 0));
}

TEST(LasReader, EightBitColoursAreRecognised) {
  // Many writers store 0-255 in the 16-bit colour fields; read as >> 8 they would all be black.
  LasSpec spec = sampleSpec(2, 2);
  spec.points[0].rgb = {200, 100, 7};
  spec.points[1].rgb = {255, 0, 1};
  spec.points[2].rgb = {0, 0, 0};
  TempDir dir;
  writeFile(dir / "scan.las", buildLas(spec));
  const auto points = readAll(dir / "scan.las");
  ASSERT_EQ(points.size(), 3u);
  EXPECT_EQ(points.colors[0], Color(200, 100, 7));
  EXPECT_EQ(points.colors[1], Color(255, 0, 1));
  EXPECT_EQ(points.positions.size(), 3u);  // the probe ahead did not consume any record
}

TEST(LasReader, ZeroPoints) {
  LasSpec spec = sampleSpec(4, 6);
  spec.points.clear();
  TempDir dir;
  writeFile(dir / "scan.las", buildLas(spec));
  auto reader = openPointReader(dir / "scan.las");
  PointChunk chunk;
  EXPECT_EQ(reader->read(chunk, 100), 0u);
  EXPECT_EQ(reader->info().declaredPoints, std::optional<std::uint64_t>(0));
}

TEST(LasReader, ChunkedReadingEqualsOneChunkAndProgressReachesOne) {
  LasSpec spec;
  spec.minor = 3;
  spec.format = 5;
  spec.extraBytes = 17;
  for (int i = 0; i < 1000; ++i) {
    spec.points.push_back({{i * 7, -i * 3, i}, static_cast<std::uint16_t>(i), static_cast<std::uint8_t>(i % 32),
                           {static_cast<std::uint16_t>(i * 65), 0, 65535}});
  }
  TempDir dir;
  writeFile(dir / "scan.las", buildLas(spec));
  const auto whole = readAll(dir / "scan.las");
  auto reader = openPointReader(dir / "scan.las");
  EXPECT_LT(reader->progress(), 0.01);
  const auto chunked = readAll(*reader, 7);
  EXPECT_DOUBLE_EQ(reader->progress(), 1.0);
  ASSERT_EQ(whole.size(), 1000u);
  EXPECT_EQ(chunked.positions, whole.positions);
  EXPECT_EQ(chunked.colors, whole.colors);
  EXPECT_EQ(chunked.intensities, whole.intensities);
  EXPECT_EQ(chunked.labels, whole.labels);
  EXPECT_NEAR(whole.positions[999].x(), 500000.0 + 999 * 7 * 0.001, 1e-9);
  EXPECT_EQ(whole.labels[999], 999 % 32);
}

TEST(LasReader, ReadPointCloudKeepsGeoreferencedPrecision) {
  TempDir dir;
  writeFile(dir / "scan.las", buildLas(sampleSpec(2, 2)));
  ReadReport report;
  const auto cloud = readPointCloud(dir / "scan.las", {}, &report);
  ASSERT_EQ(cloud.size(), 3u);
  EXPECT_EQ(report.info.format, "LAS 1.2 format 2");
  EXPECT_NEAR((cloud.worldPosition(0) - kSampleWorld[0]).norm(), 0.0, 1e-3);
  EXPECT_EQ(cloud.colors[0], Color(255, 128, 0));
  EXPECT_EQ(cloud.labels[1], 31);
  EXPECT_FLOAT_EQ(cloud.intensities[0], 65535.0f);
}

/// A GeoTIFF key directory VLR (record 34735): a model-type key, then ProjLinearUnitsGeoKey.
std::pair<std::uint16_t, std::string> geoKeys(std::uint16_t linearUnits) {
  const std::array<std::uint16_t, 12> shorts = {1, 1, 0, 2, 1024, 0, 1, 1, 3076, 0, 1, linearUnits};
  std::string payload(sizeof shorts, '\0');
  std::memcpy(payload.data(), shorts.data(), sizeof shorts);
  return {34735, payload};
}

/// An OGC WKT VLR (record 2112) of a projected CRS in `unit` ("name",metres), NUL-terminated.
std::pair<std::uint16_t, std::string> wkt(const std::string& unit) {
  return {2112,
          "PROJCS[\"NAD83 / Texas Central\",GEOGCS[\"NAD83\",DATUM[\"North_American_Datum_1983\"],"
          "PRIMEM[\"Greenwich\",0],UNIT[\"degree\",0.0174532925199433]],PROJECTION[\"Lambert_Conformal_Conic_2SP\"],"
          "PARAMETER[\"standard_parallel_1\",31.88],UNIT[" + unit + "],AXIS[\"Easting\",EAST],AUTHORITY[\"EPSG\",\"2277\"]]" +
              std::string(1, '\0')};
}

TEST(LasUnits, TheProjectionsLinearUnitIsReadAndTheCoordinatesScaledToMetres) {
  TempDir dir;
  LasSpec spec = sampleSpec(2, 0);
  spec.projection = {geoKeys(9003)};
  writeFile(dir / "feet.las", buildLas(spec));
  ReadReport report;
  const PointCloud cloud = readPointCloud(dir / "feet.las", {}, &report);
  EXPECT_EQ(report.info.declaredUnits, "us-ft");
  EXPECT_EQ(report.info.declaredUnitsSource, "GeoTIFF key ProjLinearUnitsGeoKey = 9003");
  EXPECT_EQ(report.units, "us-ft");
  ASSERT_EQ(cloud.size(), 3u);
  EXPECT_NEAR((cloud.worldPosition(0) - kSampleWorld[0] * 1200.0 / 3937.0).norm(), 0.0, 1e-3);
  // --units overrides what the file says.
  ReadOptions asMetres;
  asMetres.units = "m";
  EXPECT_NEAR((readPointCloud(dir / "feet.las", asMetres).worldPosition(0) - kSampleWorld[0]).norm(), 0.0, 1e-3);

  spec.projection = {geoKeys(9002)};
  writeFile(dir / "feet.las", buildLas(spec));
  EXPECT_EQ(openPointReader(dir / "feet.las")->info().declaredUnits, "ft");
  // A unit no scan unit stands for (9036, kilometres) declares nothing: metres.
  spec.projection = {geoKeys(9036)};
  writeFile(dir / "km.las", buildLas(spec));
  EXPECT_EQ(openPointReader(dir / "km.las")->info().declaredUnits, "");
}

TEST(LasUnits, TheWktsProjectedUnitIsReadNotItsAngularOne) {
  TempDir dir;
  LasSpec spec = sampleSpec(4, 6);
  spec.projection = {wkt("\"US survey foot\",0.3048006096012192")};
  writeFile(dir / "wkt.las", buildLas(spec));
  auto reader = openPointReader(dir / "wkt.las");
  EXPECT_EQ(reader->info().declaredUnits, "us-ft");
  EXPECT_EQ(reader->info().declaredUnitsSource, "WKT UNIT[\"US survey foot\"]");
  spec.projection = {wkt("\"metre\",1")};
  writeFile(dir / "wkt.las", buildLas(spec));
  EXPECT_EQ(openPointReader(dir / "wkt.las")->info().declaredUnits, "m");

  // Both records, saying different things: the header's WKT bit says which one is the CRS.
  spec.projection = {geoKeys(9002), wkt("\"metre\",1")};
  writeFile(dir / "both.las", buildLas(spec));
  EXPECT_EQ(openPointReader(dir / "both.las")->info().declaredUnits, "ft");
  spec.globalEncoding = 1u << 4;
  writeFile(dir / "both.las", buildLas(spec));
  EXPECT_EQ(openPointReader(dir / "both.las")->info().declaredUnits, "m");
}

TEST(LasUnits, AProjectionRecordRunningIntoThePointsIsLeftOut) {
  TempDir dir;
  LasSpec spec = sampleSpec(2, 1);
  spec.projection = {geoKeys(9003)};
  std::string bytes = buildLas(spec);
  // The projection VLR (the last before the points) claims 100 bytes more than it has.
  const std::size_t lengthAt = 227 + spec.vlrCount * (kVlrHeaderBytes + kVlrPayloadBytes) + 20;
  put<std::uint16_t>(bytes, lengthAt, static_cast<std::uint16_t>(get<std::uint16_t>(bytes, lengthAt) + 100));
  writeFile(dir / "long.las", bytes);
  ReadReport report;
  const PointCloud cloud = readPointCloud(dir / "long.las", {}, &report);
  EXPECT_EQ(report.units, "m");
  ASSERT_EQ(cloud.size(), 3u);
  EXPECT_NEAR((cloud.worldPosition(1) - kSampleWorld[1]).norm(), 0.0, 1e-3);
}

// ---------------------------------------------------------------------------------------------
// Malformed files

TEST(LasMalformed, BadSignature) {
  std::string bytes = buildLas(sampleSpec(2, 0));
  bytes[3] = 'X';
  const auto message = lasError(bytes);
  EXPECT_THAT(message, HasSubstr("byte 0"));
  EXPECT_THAT(message, HasSubstr("'LASX' is not 'LASF'"));
}

TEST(LasMalformed, TruncatedHeader) {
  EXPECT_THAT(lasError(buildLas(sampleSpec(2, 0)).substr(0, 100)), HasSubstr("unexpected end of file"));
  const auto message = lasError(buildLas(sampleSpec(4, 6)).substr(0, 300));
  EXPECT_THAT(message, HasSubstr("byte 227"));
  EXPECT_THAT(message, HasSubstr("unexpected end of file"));
}

TEST(LasMalformed, UnsupportedVersion) {
  std::string bytes = buildLas(sampleSpec(2, 0));
  bytes[24] = 2;
  EXPECT_THAT(lasError(bytes), HasSubstr("LAS version 2.2, expected 1.0 to 1.4"));
}

TEST(LasMalformed, HeaderSizeTooSmallForTheVersion) {
  std::string bytes = buildLas(sampleSpec(4, 6));
  put<std::uint16_t>(bytes, 94, 227);
  const auto message = lasError(bytes);
  EXPECT_THAT(message, HasSubstr("byte 94"));
  EXPECT_THAT(message, HasSubstr("375"));
}

TEST(LasMalformed, PointDataOffsetInsideTheHeader) {
  std::string bytes = buildLas(sampleSpec(2, 0));
  put<std::uint32_t>(bytes, 96, 12);
  const auto message = lasError(bytes);
  EXPECT_THAT(message, HasSubstr("byte 96"));
  EXPECT_THAT(message, HasSubstr("point data offset 12 lies inside the header, expected at least 227"));
}

TEST(LasMalformed, PointDataOffsetPastTheEnd) {
  std::string bytes = buildLas(sampleSpec(2, 0));
  put<std::uint32_t>(bytes, 96, static_cast<std::uint32_t>(bytes.size() + 100));
  const auto message = lasError(bytes);
  EXPECT_THAT(message, HasSubstr("byte 96"));
  EXPECT_THAT(message, HasSubstr("beyond the end of the file"));
}

TEST(LasMalformed, RecordLengthTooShortForTheFormat) {
  std::string bytes = buildLas(sampleSpec(2, 3));
  put<std::uint16_t>(bytes, 105, 30);
  const auto message = lasError(bytes);
  EXPECT_THAT(message, HasSubstr("byte 105"));
  EXPECT_THAT(message, HasSubstr("point record length 30 is too short for point data format 3, expected at least 34"));
}

TEST(LasMalformed, UnsupportedPointFormat) {
  std::string bytes = buildLas(sampleSpec(4, 6));
  bytes[104] = 11;
  EXPECT_THAT(lasError(bytes), HasSubstr("point data format 11, expected 0 to 10"));
}

TEST(LasMalformed, HugePointCountFailsBeforeAllocating) {
  std::string bytes = buildLas(sampleSpec(4, 6));
  put<std::uint64_t>(bytes, 247, std::uint64_t(1) << 40);
  const auto message = lasError(bytes);
  EXPECT_THAT(message, HasSubstr("byte 247"));
  EXPECT_THAT(message, HasSubstr("point count 1099511627776"));
  EXPECT_THAT(message, HasSubstr("bytes after the point data offset"));

  std::string legacy = buildLas(sampleSpec(2, 1));
  put<std::uint32_t>(legacy, 107, std::numeric_limits<std::uint32_t>::max());
  EXPECT_THAT(lasError(legacy), HasSubstr("point count 4294967295"));
}

TEST(LasMalformed, TruncatedPointData) {
  const LasSpec spec = sampleSpec(2, 2);
  const std::string bytes = buildLas(spec);
  const auto message = lasError(bytes.substr(0, bytes.size() - 5));
  const std::size_t available = 3 * recordLength(spec) - 5;
  EXPECT_THAT(message, HasSubstr("point count 3"));
  EXPECT_THAT(message, HasSubstr("the " + std::to_string(available) + " bytes after the point data offset"));
}

TEST(LasMalformed, ZeroOrNonFiniteScale) {
  std::string bytes = buildLas(sampleSpec(2, 0));
  put<double>(bytes, 139, 0.0);
  const auto zero = lasError(bytes);
  EXPECT_THAT(zero, HasSubstr("byte 139"));
  EXPECT_THAT(zero, HasSubstr("y scale factor"));
  EXPECT_THAT(zero, HasSubstr("expected a finite non-zero number"));

  put<double>(bytes, 139, 0.01);
  put<double>(bytes, 147, std::numeric_limits<double>::quiet_NaN());
  EXPECT_THAT(lasError(bytes), HasSubstr("z scale factor"));
}

TEST(LasMalformed, LazCompressionBitAsksToDecompress) {
  std::string bytes = buildLas(sampleSpec(2, 3));
  bytes[104] = static_cast<char>(3 | 0x80);
  const auto message = lasError(bytes);
  EXPECT_THAT(message, HasSubstr("byte 104"));
  EXPECT_THAT(message, HasSubstr("LAZ-compressed"));
  EXPECT_THAT(message, HasSubstr("decompress"));
  EXPECT_THAT(message, HasSubstr("laszip -i in.laz -o out.las"));
}

TEST(LasMalformed, LazExtensionIsNamed) {
  std::string bytes = buildLas(sampleSpec(4, 7));
  bytes[104] = static_cast<char>(7 | 0x80);
  TempDir dir;
  writeFile(dir / "scan.laz", bytes);
  try {
    io::openLasReader(dir / "scan.laz");
    ADD_FAILURE() << "a compressed .laz file was accepted";
  } catch (const InputError& error) {
    EXPECT_THAT(error.what(), HasSubstr(".laz file is LAZ-compressed"));
    EXPECT_THAT(error.what(), HasSubstr("pdal translate in.laz out.las"));
  }
  // The generic entry point refuses .laz by its extension, with the same advice.
  EXPECT_THAT(openError(dir / "scan.laz"), HasSubstr("decompress"));
}

}  // namespace
}  // namespace piperun
