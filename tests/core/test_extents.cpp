#include "piperun/stages/extents.h"

#include "random.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

namespace piperun {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// A cylinder along +x through (0, 0, 1) scanned from the side (−y): points on the facing half,
/// evenly across the silhouette, 1 cm apart, 2 mm noise; `keep(x)` says where the pipe is visible.
struct ScannedPipe {
  PointCloud cloud;
  PlacementResult placement;
  double radius = 0.05;

  explicit ScannedPipe(double length, const std::function<bool(double)>& keep, double pipeRadius = 0.05)
      : radius(pipeRadius) {
    Rng rng(3);
    for (double x = 0.005; x < length; x += 0.01) {
      if (!keep(x)) continue;
      for (double s = -radius + 0.005; s < radius; s += 0.01) addSurfacePoint(x, std::asin(s / radius), rng);
    }
    Cylinder cylinder;
    cylinder.point = Eigen::Vector3d(0.7, 0.0, 1.0);  // anywhere on the axis
    cylinder.direction = Eigen::Vector3d::UnitX();
    cylinder.radius = radius;
    placement.cylinders.push_back(cylinder);
    refreshInliers();
  }

  /// A point on the surface at axial position x and angle phi from the facing side.
  void addSurfacePoint(double x, double phi, Rng& rng) {
    const double r = radius + 0.002 * rng.normal();
    cloud.positions.emplace_back(static_cast<float>(x), static_cast<float>(-r * std::cos(phi)),
                                 static_cast<float>(1.0 + r * std::sin(phi)));
    cloud.normals.emplace_back(0.0f, static_cast<float>(-std::cos(phi)), static_cast<float>(std::sin(phi)));
  }

  void refreshInliers() {
    auto& inliers = placement.cylinders[0].inliers;
    inliers.resize(cloud.size());
    for (std::uint32_t i = 0; i < inliers.size(); ++i) inliers[i] = i;
  }
};

TEST(Extents, ContinuousPipeIsOneSegmentWithItsEnds) {
  const ScannedPipe pipe(2.0, [](double) { return true; });
  const ExtentsResult result = computeExtents({pipe.cloud, pipe.placement}, ExtentsParams{});
  ASSERT_EQ(result.segments.size(), 1u);
  const PipeSegment& segment = result.segments[0];
  EXPECT_LT((segment.start - Eigen::Vector3d(0.0, 0.0, 1.0)).norm(), 0.02);
  EXPECT_LT((segment.end - Eigen::Vector3d(2.0, 0.0, 1.0)).norm(), 0.02);
  EXPECT_EQ(segment.radius, pipe.radius);
  EXPECT_EQ(segment.cylinderIndex, 0);
  EXPECT_EQ(segment.inliers.size(), pipe.cloud.size());
  EXPECT_DOUBLE_EQ(segment.confidence, 1.0);
  EXPECT_GT(segment.rms, 0.0012);
  EXPECT_LT(segment.rms, 0.0028);
  EXPECT_EQ(result.diagnostics.keptSections, result.diagnostics.sections);
}

TEST(Extents, ShortOcclusionIsBridged) {
  // 30 cm hidden behind something in front: shorter than the closing (10 sections of 4 cm).
  const ScannedPipe pipe(3.0, [](double x) { return x < 1.2 || x > 1.5; });
  const ExtentsResult result = computeExtents({pipe.cloud, pipe.placement}, ExtentsParams{});
  ASSERT_EQ(result.segments.size(), 1u);
  const PipeSegment& segment = result.segments[0];
  EXPECT_LT(std::abs(segment.start.x() - 0.0), 0.02);
  EXPECT_LT(std::abs(segment.end.x() - 3.0), 0.02);
  EXPECT_GT(segment.confidence, 0.85);
  EXPECT_LT(segment.confidence, 0.95);
}

TEST(Extents, LongGapSplitsCollinearPipes) {
  const ScannedPipe pipe(3.0, [](double x) { return x < 1.0 || x > 2.0; });
  const ExtentsResult result = computeExtents({pipe.cloud, pipe.placement}, ExtentsParams{});
  ASSERT_EQ(result.segments.size(), 2u);
  const auto [first, second] = std::minmax(result.segments[0], result.segments[1], [](const PipeSegment& a, const PipeSegment& b) {
    return a.start.x() < b.start.x();
  });
  EXPECT_LT(std::abs(first.start.x() - 0.0), 0.02);
  EXPECT_LT(std::abs(first.end.x() - 1.0), 0.02);
  EXPECT_LT(std::abs(second.start.x() - 2.0), 0.02);
  EXPECT_LT(std::abs(second.end.x() - 3.0), 0.02);
  EXPECT_EQ(first.inliers.size() + second.inliers.size(), pipe.cloud.size());
  EXPECT_DOUBLE_EQ(first.confidence, 1.0);
}

TEST(Extents, OcclusionBetweenLongRunsIsBridged) {
  // 60 cm hidden (15 sections: beyond the closing, within bridgeSections) between 1.2 m runs.
  const ScannedPipe pipe(3.0, [](double x) { return x < 1.2 || x > 1.8; });
  const ExtentsResult result = computeExtents({pipe.cloud, pipe.placement}, ExtentsParams{});
  ASSERT_EQ(result.segments.size(), 1u);
  EXPECT_LT(std::abs(result.segments[0].start.x() - 0.0), 0.02);
  EXPECT_LT(std::abs(result.segments[0].end.x() - 3.0), 0.02);
  EXPECT_NEAR(result.segments[0].confidence, 0.8, 0.03);
}

TEST(Extents, GapLongerThanItsRunsIsNotBridged) {
  // The same 60 cm gap between two 40 cm pieces: too little pipe on either side to vouch for it.
  const ScannedPipe pipe(1.4, [](double x) { return x < 0.4 || x > 1.0; });
  const ExtentsResult result = computeExtents({pipe.cloud, pipe.placement}, ExtentsParams{});
  ASSERT_EQ(result.segments.size(), 2u);
  for (const PipeSegment& segment : result.segments) EXPECT_NEAR((segment.end - segment.start).norm(), 0.4, 0.02);
}

TEST(Extents, PieceMostlyMadeUpByTheClosingIsDropped) {
  // Visible 4 cm in every 16 cm: the closing joins the pieces into a run where well under half of
  // the sections passed (a visible stretch may straddle two), as a chance fit through scattered
  // surface patches leaves.
  const ScannedPipe pipe(2.0, [](double x) { return std::fmod(x, 0.16) < 0.04; });
  ExtentsResult result = computeExtents({pipe.cloud, pipe.placement}, ExtentsParams{});
  EXPECT_TRUE(result.segments.empty());

  ExtentsParams lenient;
  lenient.minConfidence = 0.2;
  result = computeExtents({pipe.cloud, pipe.placement}, lenient);
  ASSERT_EQ(result.segments.size(), 1u);
  EXPECT_GT(result.segments[0].confidence, 0.2);
  EXPECT_LT(result.segments[0].confidence, 0.5);
}

TEST(Extents, PipeSeenWholeBeyondItsGlimpsesKeepsItsWholePart) {
  // 20 cm, then a 4 cm glimpse between two occlusions, then 40 cm seen whole: the closing joins
  // them into a run where about half the sections passed, too few to keep it, but its 40 cm part
  // holds most of its points and passed throughout.
  const ScannedPipe pipe(1.2, [](double x) { return x < 0.2 || (x > 0.44 && x < 0.48) || x > 0.8; });
  ExtentsResult result = computeExtents({pipe.cloud, pipe.placement}, ExtentsParams{});
  ASSERT_EQ(result.segments.size(), 1u);
  EXPECT_NEAR(result.segments[0].start.x(), 0.8, 0.02);
  EXPECT_NEAR(result.segments[0].end.x(), 1.2, 0.02);
  EXPECT_DOUBLE_EQ(result.segments[0].confidence, 1.0);

  // Two parts of 24 cm either side of a 2 cm glimpse: neither holds over half the run's points.
  const ScannedPipe even(0.96, [](double x) { return x < 0.24 || (x > 0.45 && x < 0.47) || x > 0.72; });
  result = computeExtents({even.cloud, even.placement}, ExtentsParams{});
  EXPECT_TRUE(result.segments.empty());
}

TEST(Extents, NoiseBlobsAndSliversAreDropped) {
  ScannedPipe pipe(1.5, [](double) { return true; });
  Rng rng(9);
  // Beyond the pipe on the same line: two 3 cm blobs of surface points, and a 60 cm sliver where
  // a neighbouring surface grazes the cylinder along one line of angles.
  for (const double blob : {2.0, 2.6}) {
    for (int k = 0; k < 60; ++k) pipe.addSurfacePoint(blob + rng.uniform(0.0, 0.03), rng.uniform(-1.2, 1.2), rng);
  }
  for (double x = 3.0; x < 3.6; x += 0.005) pipe.addSurfacePoint(x, 1.3 + rng.uniform(-0.1, 0.1), rng);
  pipe.refreshInliers();

  const ExtentsResult result = computeExtents({pipe.cloud, pipe.placement}, ExtentsParams{});
  ASSERT_EQ(result.segments.size(), 1u);
  EXPECT_LT(std::abs(result.segments[0].start.x() - 0.0), 0.02);
  EXPECT_LT(std::abs(result.segments[0].end.x() - 1.5), 0.02);
}

TEST(Extents, StrayPointsOnTheLineBeyondAnEndDoNotCarryItOn) {
  // Single stray points on the cylinder's surface past the pipe's end, each within the closing of
  // the next, at angles far enough apart to span an arc, and a coverage threshold low enough for
  // one point to pass (as the local density of a sparse stretch sets it on a noisy scan): the
  // closing joins them to the pipe, as 20 % outliers did over a metre past an elbow.
  ScannedPipe pipe(1.5, [](double) { return true; });
  Rng rng(4);
  const std::pair<double, double> strays[] = {{1.62, -1.0}, {1.70, 0.8}, {1.90, -0.3}, {2.10, 1.2}, {2.30, -0.9}};
  for (const auto& [x, phi] : strays) pipe.addSurfacePoint(x, phi, rng);
  pipe.refreshInliers();
  ExtentsParams lowThreshold;
  lowThreshold.minPointsPerMetre = 20.0;  // under one point a section
  const ExtentsResult result = computeExtents({pipe.cloud, pipe.placement}, lowThreshold);
  ASSERT_EQ(result.segments.size(), 1u);
  EXPECT_LT(std::abs(result.segments[0].start.x() - 0.0), 0.02);
  // The last closing length (40 cm) before the end must hold points in over a third of its
  // sections: the end goes back over the lone points until it does.
  EXPECT_LT(result.segments[0].end.x(), 1.75);

  // A pipe's own last stretch seen through a gap shorter than its run keeps its end.
  const ScannedPipe glimpsed(2.0, [](double x) { return x < 1.5 || x > 1.6; });
  const ExtentsResult whole = computeExtents({glimpsed.cloud, glimpsed.placement}, ExtentsParams{});
  ASSERT_EQ(whole.segments.size(), 1u);
  EXPECT_LT(std::abs(whole.segments[0].end.x() - 2.0), 0.02);
}

TEST(Extents, SmallPipeFromOneSideAndShortPieces) {
  // A 1.5 cm pipe shows only three or four points across from one station.
  const ScannedPipe small(1.0, [](double x) { return x < 0.45 || x > 0.5; }, 0.015);
  const ExtentsResult result = computeExtents({small.cloud, small.placement}, ExtentsParams{});
  ASSERT_EQ(result.segments.size(), 1u);
  EXPECT_LT(std::abs(result.segments[0].end.x() - 1.0), 0.02);

  ExtentsParams longOnly;
  longOnly.minLength = 1.2;
  EXPECT_TRUE(computeExtents({small.cloud, small.placement}, longOnly).segments.empty());
}

TEST(Extents, SparseFarPipeIsJudgedOverNeighbouringSections) {
  // One point per section, as a far scanner leaves on a thin pipe, each at another angle: no single
  // section spans an arc, a few neighbouring ones do.
  ScannedPipe pipe(0.0, [](double) { return true; });
  Rng rng(5);
  const double angles[] = {-1.0, 0.0, 1.0};
  int k = 0;
  for (double x = 0.02; x < 2.0; x += 0.04) pipe.addSurfacePoint(x, angles[k++ % 3], rng);
  pipe.refreshInliers();
  const ExtentsResult result = computeExtents({pipe.cloud, pipe.placement}, ExtentsParams{});
  ASSERT_EQ(result.segments.size(), 1u);
  EXPECT_LT(std::abs(result.segments[0].start.x() - 0.02), 0.02);
  EXPECT_LT(std::abs(result.segments[0].end.x() - 1.98), 0.02);
}

TEST(Extents, AxisCoverageThreshold) {
  // The second half is scanned at a fifth of the density (every fifth ring of points).
  ScannedPipe pipe(2.0, [](double x) { return x < 1.0 || std::fmod(x, 0.05) < 0.01; });
  ExtentsParams whole;
  whole.minDensityRatio = 0.5;
  whole.densityWindow = 10.0;  // the whole cylinder's median density: the thin half fails
  const ExtentsResult thinDropped = computeExtents({pipe.cloud, pipe.placement}, whole);
  ASSERT_EQ(thinDropped.segments.size(), 1u);
  EXPECT_LT(std::abs(thinDropped.segments[0].end.x() - 1.0), 0.03);

  ExtentsParams local = whole;
  local.densityWindow = 0.3;  // the median within 30 cm: the thin half is judged by its own density
  const ExtentsResult thinFollowed = computeExtents({pipe.cloud, pipe.placement}, local);
  ASSERT_EQ(thinFollowed.segments.size(), 1u);
  EXPECT_GT(thinFollowed.segments[0].end.x(), 1.95);

  ExtentsParams fixed;
  fixed.minPointsPerMetre = 100.0;  // 4 points a section: the thin half passes too
  const ExtentsResult thinKept = computeExtents({pipe.cloud, pipe.placement}, fixed);
  ASSERT_EQ(thinKept.segments.size(), 1u);
  EXPECT_GT(thinKept.segments[0].end.x(), 1.95);
}

TEST(Extents, SameResultForAnyThreadCount) {
  ScannedPipe pipe(3.0, [](double x) { return x < 1.0 || x > 2.0; });
  // A second cylinder, so that the cylinders run in parallel.
  pipe.placement.cylinders.push_back(pipe.placement.cylinders[0]);
  pipe.placement.cylinders[1].inliers.resize(pipe.cloud.size() / 2);
  const auto run = [&](int threads) {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    return computeExtents({pipe.cloud, pipe.placement}, ExtentsParams{});
  };
  const ExtentsResult one = run(1), two = run(2);
  ASSERT_EQ(one.segments.size(), 3u);
  ASSERT_EQ(one.segments.size(), two.segments.size());
  for (std::size_t k = 0; k < one.segments.size(); ++k) {
    EXPECT_EQ(one.segments[k].start, two.segments[k].start);
    EXPECT_EQ(one.segments[k].end, two.segments[k].end);
    EXPECT_EQ(one.segments[k].inliers, two.segments[k].inliers);
    EXPECT_EQ(one.segments[k].cylinderIndex, k < 2 ? 0 : 1);
  }
}

TEST(Extents, EmptyCylinderGivesNothing) {
  PointCloud cloud;
  PlacementResult placement;
  placement.cylinders.emplace_back();
  const ExtentsResult result = computeExtents({cloud, placement}, ExtentsParams{});
  EXPECT_TRUE(result.segments.empty());
  EXPECT_EQ(result.diagnostics.sections, 0u);
}

}  // namespace
}  // namespace piperun
