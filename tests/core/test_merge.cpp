#include "piperun/stages/merge.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

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

TEST(Merge, APipeMustTakeAJointOnlyWhenEachOfItsPiecesMust) {
  PipeSegment weak = segment({0, 0, 0}, {1, 0, 0}, 0.05, {1});
  weak.mustJoin = true;
  PipeSegment weakToo = segment({1.02, 0, 0}, {2, 0, 0}, 0.05, {2});
  weakToo.mustJoin = true;
  PipeSegment firm = segment({1.02, 0, 0}, {2, 0, 0}, 0.05, {2});
  const auto both = mergeSegments({weak, weakToo}, {});
  ASSERT_EQ(both.segments.size(), 1u);
  EXPECT_TRUE(both.segments[0].mustJoin);
  const auto vouched = mergeSegments({weak, firm}, {});
  ASSERT_EQ(vouched.segments.size(), 1u);
  EXPECT_FALSE(vouched.segments[0].mustJoin);
}

TEST(Merge, AbuttingPiecesWithSmallGapMergeOppositeOrientationsToo) {
  const auto result = mergeSegments({segment({0, 0, 0}, {1, 0, 0}, 0.1), segment({2, 0, 0}, {1.03, 0, 0}, 0.1)}, {});
  ASSERT_EQ(result.segments.size(), 1u);
  EXPECT_NEAR((result.segments[0].end - result.segments[0].start).norm(), 2.0, 1e-9);
}

TEST(Merge, AShortPieceOverALongPipesEndMergesThoughTheirAxesDifferByADegree) {
  // A 22 cm piece fitted over the last 20 cm of a 2.4 m pipe (r 7 cm), its axis 1.3° off: measured
  // from the long pipe's middle, 1.1 m away, its line misses by 2.5 cm, more than the 2.1 cm the
  // axes may lie apart, though the piece lies on the long pipe's axis within 3 mm.
  const double tilt = 1.3 * 3.14159265358979323846 / 180.0;
  const Eigen::Vector3d along(std::cos(tilt), std::sin(tilt), 0.0);
  const Eigen::Vector3d middle(-0.09, 0.0, 1.0);
  const auto result = mergeSegments({segment({-2.4, 0, 1}, {0, 0, 1}, 0.07, {1, 2}),
                                     segment(middle - 0.11 * along, middle + 0.11 * along, 0.069, {3})},
                                    {});
  ASSERT_EQ(result.segments.size(), 1u);
  EXPECT_NEAR((result.segments[0].end - result.segments[0].start).norm(), 2.42, 0.01);
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

/// Points on a pipe along +x (radius r, axis at y = z = 0) from x0 to x1, one ring of `perRing`
/// points (over the half facing +z) every `step` m, with normals `tilt` radians off radial (turned
/// towards +y, as normals estimated on a few scan columns stray). Returns their indices.
std::vector<std::uint32_t> addPipePoints(PointCloud& cloud, double r, double x0, double x1, double step, int perRing,
                                         double tilt) {
  std::vector<std::uint32_t> added;
  for (double x = x0; x <= x1 + 1e-9; x += step) {
    for (int k = 0; k < perRing; ++k) {
      const double angle = 3.14159265358979 * (k + 0.5) / perRing;
      const Eigen::Vector3d radial(0.0, std::cos(angle), std::sin(angle));
      const Eigen::Vector3d sideways(0.0, -std::sin(angle), std::cos(angle));
      added.push_back(static_cast<std::uint32_t>(cloud.positions.size()));
      cloud.positions.emplace_back(Eigen::Vector3d(x, 0, 0).cast<float>() + (r * radial).cast<float>());
      cloud.normals.push_back((std::cos(tilt) * radial + std::sin(tilt) * sideways).cast<float>());
    }
  }
  return added;
}

/// A pipe found from x = 0 to 2 (its inliers, 12 points every 1 cm) whose sparse tail carries
/// on from 2.04 to `tailTo` (3 points every 4 cm): the found segment, confident enough to extend.
PipeSegment foundWithTail(PointCloud& cloud, double r, double tailTo) {
  const auto inliers = addPipePoints(cloud, r, 0.0, 2.0, 0.01, 12, 0.0);
  addPipePoints(cloud, r, 2.04, tailTo, 0.04, 3, 0.0);
  PipeSegment found = segment({0, 0, 0}, {2, 0, 0}, r, inliers);
  found.confidence = 1.0;
  return found;
}

/// How far along +x a pipe reaches.
double farEnd(const PipeSegment& pipe) { return std::max(pipe.start.x(), pipe.end.x()); }

TEST(Merge, AnEndCarriesOnOverItsSparseTail) {
  // A pipe found up to x = 2 (its inliers); past it the scan thins out to one ring of 3 points
  // every 6 cm, whose normals stray 40° from radial (placement's 30° test left them out), up to
  // x = 2.6, then nothing.
  const double r = 0.05;
  PointCloud cloud;
  const auto inliers = addPipePoints(cloud, r, 0.0, 2.0, 0.01, 12, 0.0);
  addPipePoints(cloud, r, 2.06, 2.6, 0.06, 3, 40.0 * 3.14159265358979 / 180.0);
  PipeSegment found = segment({0, 0, 0}, {2, 0, 0}, r, inliers);
  found.confidence = 1.0;
  const auto result = mergeAndExtend(cloud, {found}, {});
  ASSERT_EQ(result.segments.size(), 1u);
  EXPECT_EQ(result.diagnostics.extendedEnds, 1u);
  const PipeSegment& pipe = result.segments[0];
  EXPECT_NEAR(std::max(pipe.start.x(), pipe.end.x()), 2.6, 1e-6);
  EXPECT_NEAR(std::min(pipe.start.x(), pipe.end.x()), 0.0, 1e-6);
  EXPECT_EQ(pipe.inliers.size(), cloud.size());

  // Off, or with the tail's normals beyond the angle, or on a pipe the extents found gappy: no.
  MergeParams off;
  off.maxExtension = 0.0;
  EXPECT_EQ(mergeAndExtend(cloud, {found}, off).diagnostics.extendedEnds, 0u);
  MergeParams strict;
  strict.extensionNormalAngleDeg = 30.0;
  EXPECT_EQ(mergeAndExtend(cloud, {found}, strict).diagnostics.extendedEnds, 0u);
  PipeSegment gappy = found;
  gappy.confidence = 0.8;
  EXPECT_EQ(mergeAndExtend(cloud, {gappy}, {}).diagnostics.extendedEnds, 0u);
}

TEST(Merge, AnEndCarriesOnAcrossAnOcclusionToALongerRunBeyond) {
  // Past the found end at x = 2 the tail is hidden from 2.2 to 2.6 (ten sections, behind a pipe in
  // front of it): the run beyond, 2.6 to 3.2, is longer than the occlusion, so the pipe carries on
  // to its end, as the extents bridge a gap; a run beyond shorter than the occlusion is not taken.
  const double r = 0.05;
  const auto tailEnd = [&](double beyondTo) {
    PointCloud cloud;
    const PipeSegment found = foundWithTail(cloud, r, 2.2);
    addPipePoints(cloud, r, 2.6, beyondTo, 0.04, 3, 0.0);
    return farEnd(mergeAndExtend(cloud, {found}, {}).segments[0]);
  };
  EXPECT_NEAR(tailEnd(3.2), 3.2, 1e-6);
  EXPECT_NEAR(tailEnd(2.8), 2.2, 1e-6);
}

TEST(Merge, AnEndCarriedTheWholeReachCarriesOnWhileTheSurfaceDoes) {
  // Medium seed 11: a pipe seen from below only over its last 2.5 m, which no placement found; one
  // reach of 2 m left the rest to a fit of another radius. Here the sparse tail runs from the found
  // end at x = 2 to 6.5, more than twice the reach: the end carries on to 6.5, and to a tail's end
  // within the second reach as well.
  const double r = 0.05;
  const auto tailEnd = [&](double tailTo, double reach) {
    PointCloud cloud;
    const PipeSegment found = foundWithTail(cloud, r, tailTo);
    MergeParams params;
    params.maxExtension = reach;
    const auto result = mergeAndExtend(cloud, {found}, params);
    EXPECT_EQ(result.diagnostics.extendedEnds, 1u);  // an end carried on in several reaches counts once
    return farEnd(result.segments.at(0));
  };
  EXPECT_NEAR(tailEnd(6.5, 2.0), 6.48, 1e-6);  // the tail's last ring, 4 cm apart from 2.04
  EXPECT_NEAR(tailEnd(5.0, 2.0), 5.0, 1e-6);
  // Over ten reaches of 0.5 m, to within a section of the tail's end (a reach must cover two
  // sections holding points, and the last may hold a single ring).
  EXPECT_NEAR(tailEnd(6.5, 0.5), 6.48, 0.04 + 1e-6);
}

TEST(Merge, AnEndStopsAtTheCapOfAPipeOnItsLineAndTheyBecomeOnePipe) {
  // A pipe found up to x = 2, its sparse tail carrying on to 2.9; a second piece of the same pipe
  // found from 2.5 to 3.5 (its inliers from 2.9 on: the extents took the stretch before from
  // points its own inliers left out). The tail stops at the piece's cap at 2.5 instead of running
  // on inside it, and the two, now meeting, are merged.
  const double r = 0.05;
  PointCloud cloud;
  const PipeSegment found = foundWithTail(cloud, r, 2.88);
  const auto pieceInliers = addPipePoints(cloud, r, 2.9, 3.5, 0.01, 12, 0.0);
  PipeSegment piece = segment({2.5, 0, 0}, {3.5, 0, 0}, r, pieceInliers);
  const auto result = mergeAndExtend(cloud, {found, piece}, {});
  ASSERT_EQ(result.segments.size(), 1u);
  EXPECT_NEAR(std::min(result.segments[0].start.x(), result.segments[0].end.x()), 0.0, 1e-6);
  EXPECT_NEAR(farEnd(result.segments[0]), 3.5, 1e-6);
}

TEST(Merge, AnEndCarriesOnBesideARackNeighbour) {
  // Medium seed 2: a 7 cm rack pipe's sparse tail runs beside a 5 cm neighbour 19 cm away (axis to
  // axis), which no pipe explains there. The neighbour's wall, 14 cm from the tail's axis, is no
  // clutter on it: the shell counted reaches a radius out but at most 5 cm.
  const double r = 0.07;
  PointCloud cloud;
  const PipeSegment found = foundWithTail(cloud, r, 2.8);
  const std::size_t neighbourFirst = cloud.size();
  addPipePoints(cloud, 0.05, 1.5, 3.0, 0.01, 12, 0.0);
  for (std::size_t i = neighbourFirst; i < cloud.size(); ++i) cloud.positions[i].y() += 0.19f;
  const auto result = mergeAndExtend(cloud, {found}, {});
  ASSERT_EQ(result.segments.size(), 1u);
  EXPECT_NEAR(farEnd(result.segments[0]), 2.8, 1e-6);
}

TEST(Merge, AnEndStopsAtClutterAndAtAnotherPipe) {
  const double r = 0.05;
  // A wall across the pipe's extension 30 cm past its end (points in the shell around the tube
  // and inside it): the tail before it is kept, not the one behind.
  PointCloud walled;
  const PipeSegment found = foundWithTail(walled, r, 2.8);
  for (double y = -0.3; y <= 0.3; y += 0.01) {
    for (double z = -0.3; z <= 0.3; z += 0.01) {
      walled.positions.emplace_back(2.3f, static_cast<float>(y), static_cast<float>(z));
      walled.normals.emplace_back(1.0f, 0.0f, 0.0f);
    }
  }
  const auto stopped = mergeAndExtend(walled, {found}, {});
  EXPECT_NEAR(farEnd(stopped.segments[0]), 2.28, 0.005);

  // A branch whose tail runs into a main pipe crossing its line at x = 2.5: it stops at the main
  // pipe's surface, not past it (where it would no longer make a tee).
  PointCloud crossing;
  const PipeSegment branch = foundWithTail(crossing, r, 2.8);
  PipeSegment main = segment({2.5, -1, 0}, {2.5, 1, 0}, 0.1);
  main.confidence = 0.8;
  const auto result = mergeAndExtend(crossing, {branch, main}, {});
  ASSERT_EQ(result.segments.size(), 2u);
  const PipeSegment& extended = result.segments[0].radius < 0.07 ? result.segments[0] : result.segments[1];
  const double reached = farEnd(extended);
  EXPECT_GT(reached, 2.3);
  EXPECT_LE(reached, 2.4 + 1e-9);
}

/// A 21 mm pipe found along +x from 0 to 2 whose extents ran on to 2.3 over the flank of a 56 mm
/// riser standing beside its line (axis at x = 2.35, y = 0.035, as on medium seed 6): past 2.0 its
/// inliers are only the riser's points within its band, 12 cm further on. `riserListed`: whether
/// the riser was found as a pipe.
MergeResult endOnARisersFlank(bool riserListed) {
  const double r = 0.021, riserRadius = 0.056;
  const Eigen::Vector3d riserAxis(2.35, 0.035, 0.0);
  PointCloud cloud;
  auto inliers = addPipePoints(cloud, r, 0.0, 2.0, 0.01, 12, 0.0);
  std::vector<std::uint32_t> riserInliers;
  for (double z = -0.3; z <= 0.3; z += 0.005) {
    for (int degrees = 0; degrees < 360; degrees += 3) {
      const double angle = degrees * 3.14159265358979 / 180.0;
      const Eigen::Vector3d radial(std::cos(angle), std::sin(angle), 0.0);
      const Eigen::Vector3d p = riserAxis + riserRadius * radial + Eigen::Vector3d(0, 0, z);
      const auto index = static_cast<std::uint32_t>(cloud.positions.size());
      cloud.positions.push_back(p.cast<float>());
      cloud.normals.push_back(radial.cast<float>());
      // Within the pipe's band of its surface, with a normal near its radial: the pipe took it.
      const Eigen::Vector3d fromLine(0.0, p.y(), p.z());
      const bool onPipe = std::fabs(fromLine.norm() - r) <= 0.006 && std::fabs(radial.dot(fromLine.normalized())) >= 0.87;
      (onPipe ? inliers : riserInliers).push_back(index);
    }
  }
  std::sort(inliers.begin(), inliers.end());
  PipeSegment found = segment({0, 0, 0}, {2.3, 0, 0}, r, inliers);
  found.confidence = 1.0;
  std::vector<PipeSegment> pipes{found};
  if (riserListed) pipes.push_back(segment(riserAxis - Eigen::Vector3d(0, 0, 0.3), riserAxis + Eigen::Vector3d(0, 0, 0.3), riserRadius, riserInliers));
  return mergeAndExtend(cloud, pipes, {});
}

TEST(Merge, AnEndOnACrossingPipesFlankMovesBackToItsOwnPoints) {
  const MergeResult result = endOnARisersFlank(true);
  EXPECT_EQ(result.diagnostics.retractedEnds, 1u);
  ASSERT_EQ(result.segments.size(), 2u);
  const PipeSegment& pipe = result.segments[0].radius < 0.03 ? result.segments[0] : result.segments[1];
  EXPECT_NEAR(farEnd(pipe), 2.0, 1e-6);
  EXPECT_NEAR(std::min(pipe.start.x(), pipe.end.x()), 0.0, 1e-6);
  EXPECT_TRUE(std::all_of(pipe.inliers.begin(), pipe.inliers.end(),
                          [&](std::uint32_t i) { return i < 201u * 12u; }));  // its own rings only

  // Without the riser found, nothing says whose the points are.
  const MergeResult alone = endOnARisersFlank(false);
  EXPECT_EQ(alone.diagnostics.retractedEnds, 0u);
  EXPECT_NEAR(farEnd(alone.segments[0]), 2.3, 1e-6);
}

TEST(Merge, ABranchWhoseOwnPointsReachItsMainKeepsItsEnd) {
  // A branch along +x seen up to the wall of a 10 cm main crossing its line at x = 2.5: its points
  // next to the wall lie on the main's surface too, but its own carry on to there.
  const double r = 0.05;
  PointCloud cloud;
  const auto inliers = addPipePoints(cloud, r, 0.0, 2.41, 0.01, 12, 0.0);
  PipeSegment branch = segment({0, 0, 0}, {2.41, 0, 0}, r, inliers);
  branch.confidence = 1.0;
  const PipeSegment main = segment({2.5, -1, 0}, {2.5, 1, 0}, 0.1);
  const auto result = mergeAndExtend(cloud, {branch, main}, {});
  EXPECT_EQ(result.diagnostics.retractedEnds, 0u);
  const PipeSegment& kept = result.segments[0].radius < 0.07 ? result.segments[0] : result.segments[1];
  EXPECT_NEAR(farEnd(kept), 2.41, 1e-6);
}

}  // namespace
}  // namespace piperun
