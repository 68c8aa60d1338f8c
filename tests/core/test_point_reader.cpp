#include "piperun/error.h"
#include "piperun/io/point_reader.h"
#include "piperun/io/point_writer.h"
#include "test_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <limits>

namespace piperun {
namespace {

using test::TempDir;
using test::writeFile;

TEST(PointFormatDetection, ByExtensionAndContent) {
  TempDir dir;
  EXPECT_EQ(detectPointFormat(dir / "a.PLY"), PointFormat::Ply);
  EXPECT_EQ(detectPointFormat(dir / "a.pcd"), PointFormat::Pcd);
  EXPECT_EQ(detectPointFormat(dir / "a.csv"), PointFormat::Xyz);
  EXPECT_EQ(detectPointFormat(dir / "a.pts"), PointFormat::Pts);
  EXPECT_EQ(detectPointFormat(dir / "a.las"), PointFormat::Las);
  EXPECT_EQ(detectPointFormat(dir / "a.e57"), PointFormat::E57);
  writeFile(dir / "noext", "ply\nformat ascii 1.0\n");
  EXPECT_EQ(detectPointFormat(dir / "noext"), PointFormat::Ply);
  writeFile(dir / "scan.bin", "ASTM-E57\x01\x00\x00\x00");
  EXPECT_EQ(detectPointFormat(dir / "scan.bin"), PointFormat::E57);
}

TEST(PointFormatDetection, LazSaysHowToDecompress) {
  TempDir dir;
  writeFile(dir / "scan.laz", "LASF");
  try {
    openPointReader(dir / "scan.laz");
    FAIL() << "LAZ accepted";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("decompress"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("scan.laz"), std::string::npos);
  }
}

TEST(PointFormatDetection, UnknownAndMissingFiles) {
  TempDir dir;
  writeFile(dir / "notes.doc", "hello");
  EXPECT_THROW(openPointReader(dir / "notes.doc"), InputError);
  try {
    openPointReader(dir / "absent.ply");
    FAIL();
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("no such file"), std::string::npos);
  }
}

TEST(ReadPointCloud, DropsNonFinitePointsWithWarning) {
  TempDir dir;
  writeFile(dir / "points.xyz", "0 0 0\nnan 1 1\n1 2 3\ninf 0 0\n4 5 6\n");
  ReadReport report;
  const PointCloud cloud = readPointCloud(dir / "points.xyz", {}, &report);
  EXPECT_EQ(cloud.size(), 3u);
  EXPECT_EQ(report.nonFiniteDropped, 2u);
  ASSERT_EQ(report.warnings.size(), 1u);
  EXPECT_NE(report.warnings[0].find("dropped 2 points"), std::string::npos);
  EXPECT_FLOAT_EQ(cloud.positions[2].z(), 6.0f);
}

TEST(ReadPointCloud, FarCoordinatesKeepPrecisionThroughOrigin) {
  TempDir dir;
  writeFile(dir / "utm.xyz", "512345.6781 5412345.1234 312.0011\n512346.0004 5412346.9999 313.5\n");
  const PointCloud cloud = readPointCloud(dir / "utm.xyz");
  ASSERT_EQ(cloud.size(), 2u);
  EXPECT_GT(cloud.origin.norm(), 1e5);
  EXPECT_NEAR(cloud.worldPosition(0).x(), 512345.6781, 1e-6);
  EXPECT_NEAR(cloud.worldPosition(1).y(), 5412346.9999, 1e-6);
  EXPECT_NEAR(cloud.worldPosition(0).z(), 312.0011, 1e-6);
}

TEST(ReadPointCloud, CoordinatesInAnotherUnitAreReadAsMetres) {
  TempDir dir;
  // The same two points in metres and in millimetres, far enough out (4 km) to move the origin,
  // which must be chosen from the scaled coordinates, and with a normal, which no unit scales.
  writeFile(dir / "m.xyz", "x y z nx ny nz\n4000.1234 -2.4 1.25 0 0 1\n4000.2 -2.75 1.5 0 1 0\n");
  writeFile(dir / "mm.xyz", "x y z nx ny nz\n4000123.4 -2400 1250 0 0 1\n4000200 -2750 1500 0 1 0\n");
  ReadOptions millimetres;
  millimetres.units = "mm";
  ReadReport metricReport, scaledReport;
  const PointCloud metric = readPointCloud(dir / "m.xyz", {}, &metricReport);
  const PointCloud scaled = readPointCloud(dir / "mm.xyz", millimetres, &scaledReport);
  EXPECT_EQ(metricReport.units, "m");  // a text file declares no unit
  EXPECT_EQ(scaledReport.units, "mm");
  ASSERT_EQ(scaled.size(), 2u);
  EXPECT_EQ(scaled.origin, metric.origin);
  EXPECT_EQ(scaled.origin, Eigen::Vector3d(4000, -2, 1));
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_TRUE(scaled.worldPosition(i).isApprox(metric.worldPosition(i), 1e-12)) << i;
    EXPECT_EQ(scaled.normals[i], metric.normals[i]);
  }
  // The streaming reader delivers metres too (what `piperun convert --units` writes).
  auto reader = openPointReader(dir / "mm.xyz", "mm");
  PointChunk chunk;
  ASSERT_EQ(reader->read(chunk, 10), 2u);
  EXPECT_NEAR(chunk.positions[1].y(), -2.75, 1e-12);
  EXPECT_THROW(openPointReader(dir / "mm.xyz", "yd"), std::invalid_argument);
}

TEST(LengthUnits, EveryNamedUnitHasItsLengthInMetres) {
  EXPECT_EQ(*metresPerUnit("m"), 1.0);
  EXPECT_EQ(*metresPerUnit("cm"), 0.01);
  EXPECT_EQ(*metresPerUnit("mm"), 0.001);
  EXPECT_EQ(*metresPerUnit("in"), 0.0254);
  EXPECT_EQ(*metresPerUnit("ft"), 0.3048);
  EXPECT_NEAR(*metresPerUnit("us-ft"), 0.3048006096, 1e-10);
  for (const std::string& name : lengthUnitNames()) EXPECT_TRUE(metresPerUnit(name)) << name;
  EXPECT_FALSE(metresPerUnit("M"));
  EXPECT_FALSE(metresPerUnit("yd"));
  EXPECT_FALSE(metresPerUnit(""));
}

TEST(ReadPointCloud, ChunkSizeDoesNotChangeTheResult) {
  TempDir dir;
  std::string text;
  for (int i = 0; i < 1000; ++i) text += std::to_string(i * 0.01) + " " + std::to_string(i % 7) + " 1.5\n";
  writeFile(dir / "line.xyz", text);
  ReadOptions small;
  small.chunkPoints = 13;
  const PointCloud a = readPointCloud(dir / "line.xyz", small);
  const PointCloud b = readPointCloud(dir / "line.xyz");
  ASSERT_EQ(a.size(), 1000u);
  EXPECT_EQ(a.positions, b.positions);
}

TEST(ReadPointCloud, KeepsOnlyTheAttributesAskedFor) {
  TempDir dir;
  PointChunk chunk;
  chunk.positions = {{0, 0, 0}, {1, 2, 3}, {4, 5, 6}};
  chunk.colors = {Color(1, 2, 3), Color(4, 5, 6), Color(7, 8, 9)};
  chunk.intensities = {0.1f, 0.2f, 0.3f};
  chunk.labels = {4, 5, 6};
  PointCloud written;
  written.append(chunk);
  writePointCloud(dir / "scan.ply", written);

  EXPECT_EQ(readPointCloud(dir / "scan.ply").attributes(), kColors | kIntensity | kLabels);
  ReadOptions positionsOnly;
  positionsOnly.attributes = kNoAttributes;
  const PointCloud bare = readPointCloud(dir / "scan.ply", positionsOnly);
  EXPECT_EQ(bare.attributes(), kNoAttributes);
  EXPECT_EQ(bare.positions, written.positions);
  ReadOptions labelsOnly;
  labelsOnly.attributes = kLabels | kNormals;  // the file has no normals: none come
  const PointCloud labelled = readPointCloud(dir / "scan.ply", labelsOnly);
  EXPECT_EQ(labelled.attributes(), kLabels);
  EXPECT_EQ(labelled.labels, written.labels);
}

TEST(ReadPointCloud, CancelStopsReading) {
  TempDir dir;
  writeFile(dir / "line.xyz", "0 0 0\n1 1 1\n2 2 2\n");
  Progress progress;
  progress.cancel();
  ReadOptions options;
  options.progress = &progress;
  EXPECT_THROW(readPointCloud(dir / "line.xyz", options), Cancelled);
}

TEST(DropNonFinite, KeepsAttributesAligned) {
  PointChunk chunk;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  chunk.positions = {{0, 0, 0}, {nan, 0, 0}, {2, 2, 2}};
  chunk.labels = {10, 11, 12};
  chunk.colors = {Color(1, 1, 1), Color(2, 2, 2), Color(3, 3, 3)};
  EXPECT_EQ(dropNonFinite(chunk), 1u);
  ASSERT_EQ(chunk.size(), 2u);
  EXPECT_EQ(chunk.labels, (std::vector<std::int32_t>{10, 12}));
  EXPECT_EQ(chunk.colors[1], Color(3, 3, 3));
}

TEST(TextWriter, RoundTripThroughXyzReader) {
  TempDir dir;
  PointCloud cloud;
  PointChunk chunk;
  chunk.positions = {{0.125, -1.5, 2.0}, {3.0, 4.0, 5.0625}};
  chunk.normals = {Eigen::Vector3f(0, 0, 1), Eigen::Vector3f(1, 0, 0)};
  chunk.colors = {Color(255, 0, 10), Color(1, 2, 3)};
  chunk.intensities = {0.5f, 0.75f};
  chunk.labels = {7, -1};
  cloud.append(chunk);
  for (const char* name : {"points.xyz", "points.csv"}) {
    writePointCloud(dir / name, cloud);
    const PointCloud back = readPointCloud(dir / name);
    ASSERT_EQ(back.size(), 2u) << name;
    EXPECT_EQ(back.positions, cloud.positions) << name;
    EXPECT_EQ(back.normals, cloud.normals) << name;
    EXPECT_EQ(back.colors, cloud.colors) << name;
    EXPECT_EQ(back.intensities, cloud.intensities) << name;
    EXPECT_EQ(back.labels, cloud.labels) << name;
  }
}

TEST(PointWriter, UnsupportedExtensionAndUnwritablePath) {
  TempDir dir;
  PointCloud cloud;
  PointChunk chunk;
  chunk.positions = {{0, 0, 0}};
  cloud.append(chunk);
  EXPECT_THROW(writePointCloud(dir / "points.e57", cloud), std::invalid_argument);
  EXPECT_THROW(writePointCloud(dir / "missing-folder" / "points.xyz", cloud), OutputError);
}

}  // namespace
}  // namespace piperun
