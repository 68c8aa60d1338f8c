// XYZ/TXT/CSV/ASC and Leica PTS readers: layouts, separators, headers, blocks, malformed input.

#include "piperun/error.h"
#include "piperun/io/point_reader.h"
#include "test_util.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <sstream>

namespace piperun {
namespace {

using test::TempDir;
using test::writeFile;
using ::testing::HasSubstr;

template <class T>
void appendAll(std::vector<T>& to, const std::vector<T>& from) {
  to.insert(to.end(), from.begin(), from.end());
}

/// Every point of a file, read through openPointReader in chunks of `chunkPoints`.
PointChunk readAll(const std::filesystem::path& path, std::size_t chunkPoints = 1u << 20) {
  auto reader = openPointReader(path);
  PointChunk all;
  PointChunk chunk;
  while (reader->read(chunk, chunkPoints) > 0) {
    EXPECT_LE(chunk.size(), chunkPoints);
    chunk.checkConsistent();
    appendAll(all.positions, chunk.positions);
    appendAll(all.normals, chunk.normals);
    appendAll(all.colors, chunk.colors);
    appendAll(all.intensities, chunk.intensities);
    appendAll(all.labels, chunk.labels);
  }
  EXPECT_EQ(all.attributes(), reader->info().attributes);
  return all;
}

/// The message of the InputError that reading the file throws.
std::string readError(const std::filesystem::path& path) {
  try {
    readAll(path);
  } catch (const InputError& error) {
    return error.what();
  }
  ADD_FAILURE() << "reading " << path << " did not throw InputError";
  return {};
}

PointChunk readText(const std::string& name, const std::string& text) {
  TempDir dir;
  writeFile(dir / name, text);
  return readAll(dir / name);
}

std::string readTextError(const std::string& name, const std::string& text) {
  TempDir dir;
  writeFile(dir / name, text);
  return readError(dir / name);
}

// ---------------------------------------------------------------------------------------------
// XYZ / TXT / CSV / ASC

TEST(XyzReader, WhitespaceSeparatedColumns) {
  const auto points = readText("scan.xyz", "1 2 3\n  4.5\t5.5   6.5\n-7e-1 8 +9\n");
  ASSERT_EQ(points.size(), 3u);
  EXPECT_EQ(points.positions[0], Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(points.positions[1], Eigen::Vector3d(4.5, 5.5, 6.5));
  EXPECT_EQ(points.positions[2], Eigen::Vector3d(-0.7, 8, 9));
  EXPECT_EQ(points.attributes(), kNoAttributes);
}

TEST(XyzReader, CommaAndSemicolonSeparatedColumns) {
  const auto commas = readText("scan.csv", "1,2,3\n4, 5 ,6\n");
  ASSERT_EQ(commas.size(), 2u);
  EXPECT_EQ(commas.positions[1], Eigen::Vector3d(4, 5, 6));

  const auto semicolons = readText("scan.txt", "1.25;2;3\n4;5;6.75\n");
  ASSERT_EQ(semicolons.size(), 2u);
  EXPECT_EQ(semicolons.positions[0], Eigen::Vector3d(1.25, 2, 3));
  EXPECT_EQ(semicolons.positions[1], Eigen::Vector3d(4, 5, 6.75));
}

TEST(XyzReader, HeaderNamesColumnsInAnyOrder) {
  TempDir dir;
  writeFile(dir / "scan.csv", "Intensity;Z;Blue;X;\"Green\";Y;RED;Class;Time\n12.5;3;30;1;20;2;10;7;99\n");
  const auto points = readAll(dir / "scan.csv");
  ASSERT_EQ(points.size(), 1u);
  EXPECT_EQ(points.positions[0], Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(points.colors[0], Color(10, 20, 30));
  EXPECT_FLOAT_EQ(points.intensities[0], 12.5f);
  EXPECT_EQ(points.labels[0], 7);

  const auto info = openPointReader(dir / "scan.csv")->info();
  EXPECT_EQ(info.fields.size(), 9u);
  EXPECT_EQ(info.fields[0], "Intensity");
  EXPECT_FALSE(info.declaredPoints.has_value());
}

TEST(XyzReader, HeaderWithLongNormalNames) {
  const auto points = readText("scan.asc", "normal_x normal_y normal_z x y z\n0 0.6 0.8 1 2 3\n");
  ASSERT_EQ(points.size(), 1u);
  EXPECT_EQ(points.positions[0], Eigen::Vector3d(1, 2, 3));
  EXPECT_TRUE(points.normals[0].isApprox(Eigen::Vector3f(0, 0.6f, 0.8f)));
  EXPECT_EQ(points.attributes(), kNormals);
}

TEST(XyzReader, CommentLineNamingXyzIsTheHeader) {
  // CloudCompare's ASCII export.
  const auto points = readText("scan.txt", "//X,Y,Z,R,G,B,Nx,Ny,Nz\n1,2,3,255,0,7,0,0,1\n");
  ASSERT_EQ(points.size(), 1u);
  EXPECT_EQ(points.colors[0], Color(255, 0, 7));
  EXPECT_EQ(points.normals[0], Eigen::Vector3f(0, 0, 1));
}

TEST(XyzReader, ColorColumnsWithoutHeader) {
  const auto points = readText("scan.xyz", "1 2 3 255 128 0\n4 5 6 1 2 3\n");
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points.attributes(), kColors);
  EXPECT_EQ(points.colors[0], Color(255, 128, 0));
  EXPECT_EQ(points.colors[1], Color(1, 2, 3));
}

TEST(XyzReader, NormalColumnsWithoutHeader) {
  const auto points = readText("scan.xyz", "1 2 3 0.0 0.6 0.8\n4 5 6 1 0 0\n");
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points.attributes(), kNormals);
  EXPECT_TRUE(points.normals[0].isApprox(Eigen::Vector3f(0, 0.6f, 0.8f)));
  EXPECT_EQ(points.normals[1], Eigen::Vector3f(1, 0, 0));
}

TEST(XyzReader, IntensityColumn) {
  const auto points = readText("scan.xyz", "1 2 3 -2048\n4 5 6 0.25\n");
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points.attributes(), kIntensity);
  EXPECT_FLOAT_EQ(points.intensities[0], -2048.0f);
  EXPECT_FLOAT_EQ(points.intensities[1], 0.25f);
}

TEST(XyzReader, IntensityAndColorColumns) {
  // Intensity 100 fits 0..255 too: seven columns are read as x y z i r g b.
  const auto points = readText("scan.xyz", "1 2 3 100 10 20 30\n");
  ASSERT_EQ(points.size(), 1u);
  EXPECT_EQ(points.attributes(), kIntensity | kColors);
  EXPECT_FLOAT_EQ(points.intensities[0], 100.0f);
  EXPECT_EQ(points.colors[0], Color(10, 20, 30));
}

TEST(XyzReader, ColorAndNormalColumns) {
  const auto points = readText("scan.xyz", "1 2 3 10 20 30 0 0 1\n4 5 6 40 50 60 0.6 0.8 0\n");
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points.attributes(), kColors | kNormals);
  EXPECT_EQ(points.colors[1], Color(40, 50, 60));
  EXPECT_EQ(points.normals[0], Eigen::Vector3f(0, 0, 1));
  EXPECT_TRUE(points.normals[1].isApprox(Eigen::Vector3f(0.6f, 0.8f, 0)));
}

TEST(XyzReader, ExtraColumnsAreIgnored) {
  const auto five = readText("scan.xyz", "1 2 3 0.5 remark\n4 5 6 0.75 other\n");
  ASSERT_EQ(five.size(), 2u);
  EXPECT_EQ(five.attributes(), kIntensity);
  EXPECT_FLOAT_EQ(five.intensities[1], 0.75f);

  const auto eight = readText("scan.xyz", "1 2 3 7 10 20 30 anything\n");
  ASSERT_EQ(eight.size(), 1u);
  EXPECT_EQ(eight.attributes(), kIntensity | kColors);
  EXPECT_EQ(eight.colors[0], Color(10, 20, 30));
}

TEST(XyzReader, CommentsAndBlankLinesAreSkipped) {
  const auto points = readText("scan.xyz", "# exported by a scanner\n\n// units: m\n1 2 3\n   \n  # note\n4 5 6\n\n");
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points.positions[1], Eigen::Vector3d(4, 5, 6));
}

TEST(XyzReader, CrlfLineEndsAndNoTrailingNewline) {
  const auto points = readText("scan.csv", "x,y,z\r\n1,2,3\r\n4,5,6");
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points.positions[0], Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(points.positions[1], Eigen::Vector3d(4, 5, 6));
}

TEST(XyzReader, ByteOrderMarkBeforeHeader) {
  const auto points = readText("scan.csv", "\xEF\xBB\xBFx,y,z,i\n1,2,3,4\n");
  ASSERT_EQ(points.size(), 1u);
  EXPECT_FLOAT_EQ(points.intensities[0], 4.0f);
}

TEST(XyzReader, ChunkedReadingEqualsOneChunk) {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> coordinate(-100.0, 100.0);
  std::uniform_int_distribution<int> channel(0, 255);
  std::ostringstream text;
  text.precision(17);
  for (int i = 0; i < 1000; ++i) {
    text << coordinate(random) << ' ' << coordinate(random) << ' ' << coordinate(random) << ' ' << channel(random)
         << ' ' << channel(random) << ' ' << channel(random) << '\n';
  }
  TempDir dir;
  writeFile(dir / "scan.xyz", text.str());
  const auto whole = readAll(dir / "scan.xyz");
  const auto chunked = readAll(dir / "scan.xyz", 7);
  ASSERT_EQ(whole.size(), 1000u);
  EXPECT_EQ(chunked.positions, whole.positions);
  EXPECT_EQ(chunked.colors, whole.colors);
}

TEST(XyzReader, ProgressReachesOneAtTheEnd) {
  TempDir dir;
  writeFile(dir / "scan.xyz", "1 2 3\n4 5 6\n7 8 9\n");
  auto reader = openPointReader(dir / "scan.xyz");
  PointChunk chunk;
  EXPECT_EQ(reader->read(chunk, 1), 1u);
  EXPECT_GT(reader->progress(), 0.0);
  EXPECT_LT(reader->progress(), 1.0);
  while (reader->read(chunk, 1) > 0) {
  }
  EXPECT_DOUBLE_EQ(reader->progress(), 1.0);
}

TEST(XyzReader, NonFiniteValuesAreDeliveredAndDroppedByReadPointCloud) {
  TempDir dir;
  writeFile(dir / "scan.xyz", "nan 1 2\n1 2 3\n4 inf 6\n");
  const auto points = readAll(dir / "scan.xyz");
  ASSERT_EQ(points.size(), 3u);
  EXPECT_TRUE(std::isnan(points.positions[0].x()));
  EXPECT_TRUE(std::isinf(points.positions[2].y()));

  ReadReport report;
  const auto cloud = readPointCloud(dir / "scan.xyz", {}, &report);
  EXPECT_EQ(cloud.size(), 1u);
  EXPECT_EQ(report.nonFiniteDropped, 2u);
}

TEST(XyzReader, ReadPointCloudKeepsAttributes) {
  TempDir dir;
  writeFile(dir / "scan.txt", "x y z r g b label\n1 2 3 10 20 30 4\n5 6 7 40 50 60 -1\n");
  const auto cloud = readPointCloud(dir / "scan.txt");
  ASSERT_EQ(cloud.size(), 2u);
  EXPECT_TRUE(cloud.worldPosition(1).isApprox(Eigen::Vector3d(5, 6, 7)));
  EXPECT_EQ(cloud.colors[1], Color(40, 50, 60));
  EXPECT_EQ(cloud.labels, (std::vector<std::int32_t>{4, -1}));
}

TEST(XyzMalformed, NonNumericValueNamesTheLine) {
  const auto message = readTextError("scan.xyz", "1 2 3\n\n4 five 6\n");
  EXPECT_THAT(message, HasSubstr("line 3"));
  EXPECT_THAT(message, HasSubstr("'five'"));
  EXPECT_THAT(message, HasSubstr("column 2"));
  EXPECT_THAT(message, HasSubstr("expected at least 3 fields"));
}

TEST(XyzMalformed, TooFewColumns) {
  const auto message = readTextError("scan.xyz", "1 2 3 10 20 30\n4 5 6 7\n");
  EXPECT_THAT(message, HasSubstr("line 2"));
  EXPECT_THAT(message, HasSubstr("4 fields, expected at least 6 fields (x y z r g b)"));
}

TEST(XyzMalformed, SingleNumberPerLine) {
  const auto message = readTextError("scan.xyz", "12345\n1 2 3\n");
  EXPECT_THAT(message, HasSubstr("line 1"));
  EXPECT_THAT(message, HasSubstr("1 field, expected at least 3 fields (x y z)"));
}

TEST(XyzMalformed, FiveMegabyteLine) {
  const auto message = readTextError("scan.xyz", "1 2 " + std::string(5u << 20, '3') + "\n4 5 6\n");
  EXPECT_THAT(message, HasSubstr("line 1"));
  EXPECT_THAT(message, HasSubstr("longer than"));
}

TEST(XyzMalformed, HeaderWithoutZ) {
  const auto message = readTextError("scan.csv", "x,y,intensity\n1,2,3\n");
  EXPECT_THAT(message, HasSubstr("line 1"));
  EXPECT_THAT(message, HasSubstr("no z column"));
}

TEST(XyzMalformed, HeaderWithPartOfTheColors) {
  const auto message = readTextError("scan.csv", "x,y,z,red,green\n1,2,3,4,5\n");
  EXPECT_THAT(message, HasSubstr("only 2 of r g b"));
}

TEST(XyzMalformed, ColorOutOfRange) {
  const auto message = readTextError("scan.xyz", "1 2 3 10 20 30\n1 2 3 10 300 30\n");
  EXPECT_THAT(message, HasSubstr("line 2"));
  EXPECT_THAT(message, HasSubstr("expected 0..255"));
}

TEST(XyzMalformed, FractionalLabel) {
  const auto message = readTextError("scan.txt", "x y z class\n1 2 3 2.5\n");
  EXPECT_THAT(message, HasSubstr("line 2"));
  EXPECT_THAT(message, HasSubstr("expected a 32-bit integer"));
}

// ---------------------------------------------------------------------------------------------
// PTS

TEST(PtsReader, OneBlock) {
  TempDir dir;
  writeFile(dir / "scan.pts", "3\n1 2 3\n4 5 6\n7 8 9\n");
  const auto points = readAll(dir / "scan.pts");
  ASSERT_EQ(points.size(), 3u);
  EXPECT_EQ(points.positions[2], Eigen::Vector3d(7, 8, 9));
  EXPECT_EQ(points.attributes(), kNoAttributes);
  const auto info = openPointReader(dir / "scan.pts")->info();
  EXPECT_EQ(info.format, "PTS");
  EXPECT_FALSE(info.declaredPoints.has_value());
}

TEST(PtsReader, TwoBlocks) {
  const auto points = readText("scan.pts", "2\n1 2 3 -100\n4 5 6 200\n1\n7 8 9 2047\n");
  ASSERT_EQ(points.size(), 3u);
  EXPECT_EQ(points.positions[2], Eigen::Vector3d(7, 8, 9));
  EXPECT_EQ(points.intensities, (std::vector<float>{-100, 200, 2047}));
}

TEST(PtsReader, IntensityOnly) {
  const auto points = readText("scan.pts", "2\n0.5 0.25 -1 -2048\n1 1 1 2047\n");
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points.attributes(), kIntensity);
  EXPECT_EQ(points.positions[0], Eigen::Vector3d(0.5, 0.25, -1));
  EXPECT_EQ(points.intensities, (std::vector<float>{-2048, 2047}));
}

TEST(PtsReader, IntensityAndColor) {
  const auto points = readText("scan.pts", "2\r\n1 2 3 -5 255 128 0\r\n4 5 6 7 0 1 2\r\n");
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points.attributes(), kIntensity | kColors);
  EXPECT_EQ(points.intensities, (std::vector<float>{-5, 7}));
  EXPECT_EQ(points.colors[0], Color(255, 128, 0));
  EXPECT_EQ(points.colors[1], Color(0, 1, 2));
}

TEST(PtsReader, ColorWithoutIntensity) {
  const auto points = readText("scan.pts", "1\n1 2 3 10 20 30\n");
  ASSERT_EQ(points.size(), 1u);
  EXPECT_EQ(points.attributes(), kColors);
  EXPECT_EQ(points.colors[0], Color(10, 20, 30));
}

TEST(PtsReader, EmptyBlocksAndBlankLines) {
  const auto points = readText("scan.pts", "\n0\n\n2\n1 2 3\n\n4 5 6\n0\n");
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points.positions[1], Eigen::Vector3d(4, 5, 6));
}

TEST(PtsReader, ChunksSpanBlocks) {
  TempDir dir;
  writeFile(dir / "scan.pts", "3\n1 1 1 1\n2 2 2 2\n3 3 3 3\n2\n4 4 4 4\n5 5 5 5");
  const auto whole = readAll(dir / "scan.pts");
  const auto chunked = readAll(dir / "scan.pts", 2);
  ASSERT_EQ(whole.size(), 5u);
  EXPECT_EQ(chunked.positions, whole.positions);
  EXPECT_EQ(chunked.intensities, (std::vector<float>{1, 2, 3, 4, 5}));
}

TEST(PtsMalformed, HugeCountFailsFast) {
  const auto message = readTextError("scan.pts", "1000000000000\n1 2 3\n");
  EXPECT_THAT(message, HasSubstr("line 1"));
  EXPECT_THAT(message, HasSubstr("point count 1000000000000"));
  EXPECT_THAT(message, HasSubstr("bytes"));
}

TEST(PtsMalformed, FewerPointsThanTheCountAtTheEnd) {
  const auto message = readTextError("scan.pts", "3\n1.000 2.000 3.000\n4.000 5.000 6.000\n");
  EXPECT_THAT(message, HasSubstr("line 3"));
  EXPECT_THAT(message, HasSubstr("declares 3 points, found 2"));
}

TEST(PtsMalformed, FewerPointsThanTheCountBeforeTheNextBlock) {
  const auto message = readTextError("scan.pts", "3\n1.000 2.000 3.000\n1\n4.000 5.000 6.000\n");
  EXPECT_THAT(message, HasSubstr("line 3"));
  EXPECT_THAT(message, HasSubstr("declares 3 points, found 1"));
}

TEST(PtsMalformed, MorePointsThanTheCount) {
  const auto message = readTextError("scan.pts", "1\n1 2 3\n4 5 6\n");
  EXPECT_THAT(message, HasSubstr("line 3"));
  EXPECT_THAT(message, HasSubstr("more points than the count 1 on line 1"));
}

TEST(PtsMalformed, MissingCountLine) {
  const auto message = readTextError("scan.pts", "1 2 3\n4 5 6\n");
  EXPECT_THAT(message, HasSubstr("line 1"));
  EXPECT_THAT(message, HasSubstr("expected a point count"));
}

TEST(PtsMalformed, NegativeCount) {
  EXPECT_THAT(readTextError("scan.pts", "-2\n1 2 3\n"), HasSubstr("negative"));
}

TEST(PtsMalformed, NonNumericValue) {
  const auto message = readTextError("scan.pts", "2\n1 2 3 4\n1 2 x 4\n");
  EXPECT_THAT(message, HasSubstr("line 3"));
  EXPECT_THAT(message, HasSubstr("'x' in column 3"));
}

}  // namespace
}  // namespace piperun
