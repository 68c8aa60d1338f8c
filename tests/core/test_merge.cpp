#include "piperun/stages/merge.h"

#include <gtest/gtest.h>

namespace piperun {
namespace {

PipeSegment segment(const Eigen::Vector3d& start, const Eigen::Vector3d& end, double radius,
                     std::vector<std::uint32_t> inliers = {}) {
  PipeSegment s;
  s.start = start;
  s.end = end;
  s.radius = radius;
  s.rms = 0.002;
  s.confidence = 0.8;
  s.inliers = std::move(inliers);
  return s;
}

TEST(Merge, OverlappingDuplicatesFromTwoTilesBecomeOnePipe) {
  const auto result = mergeSegments({segment({0, 0, 1}, {3, 0, 1}, 0.05, {1, 2, 3}),
                                     segment({2.5, 0.003, 1.002}, {5, 0.002, 1.001}, 0.052, {3, 4})},
                                    {});
  ASSERT_EQ(result.segments.size(), 1u);
  const PipeSegment& pipe = result.segments[0];
  EXPECT_NEAR((pipe.end - pipe.start).norm(), 5.0, 0.01);
  EXPECT_NEAR(std::min(pipe.start.x(), pipe.end.x()), 0.0, 0.01);
  EXPECT_NEAR(std::max(pipe.start.x(), pipe.end.x()), 5.0, 0.01);
  EXPECT_GT(pipe.radius, 0.05);
  EXPECT_LT(pipe.radius, 0.052);
  EXPECT_EQ(pipe.inliers, (std::vector<std::uint32_t>{1, 2, 3, 4}));
}

TEST(Merge, AbuttingPiecesWithSmallGapMergeOppositeOrientationsToo) {
  const auto result = mergeSegments({segment({0, 0, 0}, {1, 0, 0}, 0.1), segment({2, 0, 0}, {1.03, 0, 0}, 0.1)}, {});
  ASSERT_EQ(result.segments.size(), 1u);
  EXPECT_NEAR((result.segments[0].end - result.segments[0].start).norm(), 2.0, 1e-9);
}

TEST(Merge, KeepsApartWhatIsNotOnePipe) {
  MergeParams params;
  // A large gap, a parallel neighbour in a rack, another radius, a perpendicular pipe.
  const auto result = mergeSegments({segment({0, 0, 0}, {1, 0, 0}, 0.05), segment({1.5, 0, 0}, {2.5, 0, 0}, 0.05),
                                     segment({0, 0.13, 0}, {1, 0.13, 0}, 0.05), segment({0, 0, 0}, {1, 0, 0}, 0.1),
                                     segment({0.5, 0, 0}, {0.5, 1, 0}, 0.05)},
                                    params);
  EXPECT_EQ(result.segments.size(), 5u);
}

TEST(Merge, ResultDoesNotDependOnInputOrder) {
  std::vector<PipeSegment> pieces = {segment({0, 0, 0}, {1, 0, 0}, 0.05), segment({0.9, 0, 0}, {2, 0, 0}, 0.05),
                                     segment({0, 1, 0}, {0, 2, 0}, 0.03), segment({0, 2.02, 0}, {0, 3, 0}, 0.031)};
  const auto forward = mergeSegments(pieces, {});
  std::reverse(pieces.begin(), pieces.end());
  const auto backward = mergeSegments(pieces, {});
  ASSERT_EQ(forward.segments.size(), 2u);
  ASSERT_EQ(backward.segments.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_TRUE(forward.segments[i].start.isApprox(backward.segments[i].start, 1e-12));
    EXPECT_TRUE(forward.segments[i].end.isApprox(backward.segments[i].end, 1e-12));
    EXPECT_DOUBLE_EQ(forward.segments[i].radius, backward.segments[i].radius);
  }
  EXPECT_GT((forward.segments[0].end - forward.segments[0].start).norm(), 1.9);  // longest first
}

}  // namespace
}  // namespace piperun
