#include "piperun/point_cloud.h"
#include "piperun/spacing.h"

#include <gtest/gtest.h>

#include <optional>
#include <string>

#include <type_traits>

namespace piperun {
namespace {

PointChunk gridChunk(int nx, int ny, double step, const Eigen::Vector3d& offset) {
  PointChunk chunk;
  for (int i = 0; i < nx; ++i) {
    for (int j = 0; j < ny; ++j) chunk.positions.push_back(offset + Eigen::Vector3d(i * step, j * step, 0.0));
  }
  return chunk;
}

TEST(PointCloud, CopyIsExplicitAndMoveIsCheap) {
  static_assert(!std::is_copy_constructible_v<PointCloud>);
  static_assert(std::is_nothrow_move_constructible_v<PointCloud>);
  PointCloud cloud;
  cloud.append(gridChunk(10, 10, 0.1, Eigen::Vector3d::Zero()));
  const auto* data = cloud.positions.data();
  PointCloud moved = std::move(cloud);
  EXPECT_EQ(moved.positions.data(), data);
  PointCloud copy = moved.clone();
  EXPECT_NE(copy.positions.data(), data);
  EXPECT_EQ(copy.size(), 100u);
}

TEST(PointCloud, AppendKeepsAttributesAndWorldCoordinates) {
  PointCloud cloud;
  cloud.origin = Eigen::Vector3d(500000.0, 4000000.0, 100.0);
  PointChunk chunk;
  chunk.positions = {{500000.123, 4000000.456, 100.789}, {500001.0, 4000002.0, 103.0}};
  chunk.intensities = {0.25f, 0.5f};
  chunk.labels = {3, -1};
  cloud.append(chunk);
  cloud.append(chunk);
  ASSERT_EQ(cloud.size(), 4u);
  EXPECT_EQ(cloud.attributes(), unsigned(kIntensity | kLabels));
  EXPECT_NEAR(cloud.worldPosition(0).x(), 500000.123, 1e-4);
  EXPECT_NEAR(cloud.worldPosition(0).y(), 4000000.456, 1e-4);
  EXPECT_NEAR(cloud.worldPosition(3).z(), 103.0, 1e-5);
  const BoundingBox box = cloud.boundingBox();
  EXPECT_NEAR(box.min.x(), 500000.123, 1e-4);
  EXPECT_NEAR(box.max.y(), 4000002.0, 1e-4);

  PointChunk other;
  other.positions = {{0, 0, 0}};
  EXPECT_THROW(cloud.append(other), std::logic_error);  // lacks intensity and labels

  PointChunk copied;
  cloud.copyTo(copied, 1, 2);
  ASSERT_EQ(copied.size(), 2u);
  EXPECT_NEAR(copied.positions[0].z(), 103.0, 1e-5);
  EXPECT_EQ(copied.labels[1], 3);
}

TEST(PointCloud, InconsistentChunkIsRejected) {
  PointChunk chunk;
  chunk.positions = {{0, 0, 0}, {1, 1, 1}};
  chunk.colors = {Color(1, 2, 3)};
  EXPECT_THROW(chunk.checkConsistent(), std::logic_error);
  PointCloud cloud;
  EXPECT_THROW(cloud.append(chunk), std::logic_error);
}

TEST(PointCloud, EmptyCloudHasEmptyBox) {
  PointCloud cloud;
  EXPECT_TRUE(cloud.boundingBox().empty());
  EXPECT_EQ(cloud.boundingBox().size(), Eigen::Vector3d::Zero());
}

TEST(PointSpacing, RegularGridGivesItsStep) {
  PointCloud cloud;
  cloud.append(gridChunk(200, 200, 0.005, Eigen::Vector3d(1, 2, 3)));
  EXPECT_NEAR(estimatePointSpacing(cloud), 0.005, 1e-5);
}

TEST(PointSpacing, SpacingTooWideForPipesIsWarnedOfWithTheUnitsOption) {
  EXPECT_FALSE(sparseScanWarning(0.0));
  EXPECT_FALSE(sparseScanWarning(0.005));
  EXPECT_FALSE(sparseScanWarning(kMaxPlausibleSpacing));
  // The pump room in inches read as metres: its 4.6 mm spacing reads as 0.18 m.
  EXPECT_TRUE(sparseScanWarning(0.18));
  // In millimetres: 4.6 m.
  const std::optional<std::string> warning = sparseScanWarning(4.62);
  ASSERT_TRUE(warning);
  EXPECT_NE(warning->find("4.62 m apart"), std::string::npos) << *warning;
  EXPECT_NE(warning->find("--units (cm, mm, in, ft, us-ft)"), std::string::npos) << *warning;
}

TEST(PointSpacing, DegenerateClouds) {
  PointCloud cloud;
  EXPECT_EQ(estimatePointSpacing(cloud), 0.0);
  cloud.append(gridChunk(1, 1, 1.0, Eigen::Vector3d::Zero()));
  EXPECT_EQ(estimatePointSpacing(cloud), 0.0);
}

}  // namespace
}  // namespace piperun
