#include "piperun/stages/placement.h"

#include "piperun/error.h"

#include "random.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <optional>
#include <tuple>
#include <vector>

namespace piperun {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegree = kPi / 180.0;

struct TrueCylinder {
  Eigen::Vector3d start;  // relative to the cloud origin
  Eigen::Vector3d axis;   // unit
  double length;
  double radius;
};

Eigen::Vector3d perpendicular(const Eigen::Vector3d& axis) {
  Eigen::Index smallest = 0;
  axis.cwiseAbs().minCoeff(&smallest);
  return axis.cross(Eigen::Vector3d::Unit(smallest)).normalized();
}

/// `n` tilted in a random direction by a normally distributed angle of `degrees` standard deviation,
/// with a random sign (estimated normals are not oriented).
Eigen::Vector3d perturbed(const Eigen::Vector3d& n, double degrees, Rng& rng) {
  const Eigen::Vector3d tilt = Eigen::AngleAxisd(rng.uniform(0.0, 2.0 * kPi), n) * perpendicular(n);
  const Eigen::Vector3d result = Eigen::AngleAxisd(degrees * kDegree * rng.normal(), tilt) * n;
  return rng.chance(0.5) ? result : Eigen::Vector3d(-result);
}

void addPoint(PointCloud& cloud, const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
  cloud.positions.push_back(p.cast<float>());
  cloud.normals.push_back(n.cast<float>());
}

/// A cylinder as one scanner far along `view` sees it: the facing half, sampled evenly across its
/// silhouette (so points thin out towards grazing incidence) on rings whose samples shift from ring
/// to ring (scan lines do not line up with a pipe), with noise along the normal and normals off by
/// a few degrees.
void addScannedCylinder(PointCloud& cloud, const TrueCylinder& c, const Eigen::Vector3d& view, Rng& rng,
                        double spacing = 0.01, double noise = 0.002, double normalNoiseDeg = 4.0) {
  const Eigen::Vector3d side = c.axis.cross(view).normalized();
  const Eigen::Vector3d front = side.cross(c.axis);  // towards the scanner
  for (double along = 0.5 * spacing; along < c.length; along += spacing) {
    for (double x = -c.radius + rng.uniform(0.0, spacing); x < c.radius; x += spacing) {
      const double phi = std::asin(x / c.radius);
      const Eigen::Vector3d normal = std::cos(phi) * front + std::sin(phi) * side;
      const Eigen::Vector3d p = c.start + along * c.axis + (c.radius + noise * rng.normal()) * normal;
      addPoint(cloud, p, perturbed(normal, normalNoiseDeg, rng));
    }
  }
}

DirectionsResult oneDirection(const PointCloud& cloud, const Eigen::Vector3d& axis) {
  DirectionsResult directions;
  PrincipalDirection direction;
  direction.axis = axis.normalized();
  direction.stripe.resize(cloud.size());
  for (std::uint32_t i = 0; i < direction.stripe.size(); ++i) direction.stripe[i] = i;
  directions.directions.push_back(direction);
  return directions;
}

double angleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::min(1.0, std::abs(a.normalized().dot(b.normalized())))) / kDegree;
}

double axisOffset(const Cylinder& found, const TrueCylinder& truth) {
  const Eigen::Vector3d q = found.point - truth.start;
  return (q - q.dot(truth.axis) * truth.axis).norm();
}

/// The found cylinder closest to `truth` (by axis offset), or null.
const Cylinder* match(const PlacementResult& result, const TrueCylinder& truth) {
  const Cylinder* best = nullptr;
  for (const Cylinder& c : result.cylinders) {
    if (angleDeg(c.direction, truth.axis) > 3.0) continue;
    if (!best || axisOffset(c, truth) < axisOffset(*best, truth)) best = &c;
  }
  return best;
}

TEST(Placement, OneSidedCylinderIsFittedPrecisely) {
  Rng rng(7);
  PointCloud cloud;
  cloud.origin = Eigen::Vector3d(431000.0, 5120000.0, 212.0);  // georeferenced: results stay relative
  const TrueCylinder truth{{0.3, -0.2, 0.1}, Eigen::Vector3d(0.1, 0.05, 1.0).normalized(), 2.0, 0.05};
  addScannedCylinder(cloud, truth, Eigen::Vector3d(1.0, 0.3, 0.0).normalized(), rng);
  // The direction stage's estimate is about a degree off the true axis.
  const Eigen::Vector3d estimate = Eigen::AngleAxisd(1.0 * kDegree, perpendicular(truth.axis)) * truth.axis;

  const DirectionsResult directions = oneDirection(cloud, estimate);
  const PlacementResult result = placeCylinders({cloud, directions, 1}, PlacementParams{});

  ASSERT_EQ(result.cylinders.size(), 1u);
  const Cylinder& found = result.cylinders[0];
  EXPECT_NEAR(found.radius, truth.radius, 0.0015);
  EXPECT_LT(angleDeg(found.direction, truth.axis), 0.5);
  EXPECT_LT(axisOffset(found, truth), 0.002);
  EXPECT_NEAR(found.direction.norm(), 1.0, 1e-9);
  EXPECT_GT(found.inliers.size(), cloud.size() * 9 / 10);
  EXPECT_GT(found.rms, 0.001);
  EXPECT_LT(found.rms, 0.003);
  EXPECT_GT(found.candidates, static_cast<int>(found.inliers.size() / 2));
  EXPECT_EQ(found.directionIndex, 0);
  EXPECT_TRUE(std::is_sorted(found.inliers.begin(), found.inliers.end()));

  // The projection view: one plane per direction, candidates gathered around the circle.
  ASSERT_EQ(result.projections.size(), 1u);
  const auto& projection = result.projections[0];
  EXPECT_NEAR(projection.u.dot(projection.axis), 0.0, 1e-12);
  EXPECT_NEAR(projection.v.dot(projection.axis), 0.0, 1e-12);
  EXPECT_NEAR(projection.u.dot(projection.v), 0.0, 1e-12);
  const Eigen::Vector2d center(found.point.dot(projection.u), found.point.dot(projection.v));
  std::size_t onCircle = 0;
  for (const CircleCandidate& candidate : projection.candidates) {
    if (candidate.circle != 0) continue;
    ++onCircle;
    EXPECT_LT((candidate.center.cast<double>() - center).norm(), 0.05);
    EXPECT_NEAR(candidate.radius, truth.radius, 0.03);
  }
  EXPECT_GE(onCircle, static_cast<std::size_t>(PlacementParams{}.minCandidates));
  EXPECT_EQ(result.diagnostics.candidates, projection.candidates.size());
  EXPECT_EQ(result.diagnostics.projectedPoints, cloud.size());
}

TEST(Placement, NoisyScanWidensTheInlierBand) {
  // 1 cm of surface noise: a fixed 1.2 cm band would keep only about three quarters of the points.
  Rng rng(5);
  PointCloud cloud;
  const TrueCylinder truth{{0.0, 0.0, 0.0}, Eigen::Vector3d::UnitZ(), 2.0, 0.1};
  addScannedCylinder(cloud, truth, Eigen::Vector3d::UnitX(), rng, 0.01, 0.01, 8.0);
  const PlacementResult result = placeCylinders({cloud, oneDirection(cloud, truth.axis), 1}, PlacementParams{});
  ASSERT_EQ(result.cylinders.size(), 1u);
  const Cylinder& found = result.cylinders[0];
  EXPECT_NEAR(found.radius, truth.radius, 0.005);
  EXPECT_LT(axisOffset(found, truth), 0.005);
  EXPECT_GT(found.inliers.size(), cloud.size() * 9 / 10);
  EXPECT_GT(found.rms, 0.008);
}

TEST(Placement, SmallPipeBesideLargeOne) {
  Rng rng(11);
  PointCloud cloud;
  const Eigen::Vector3d axis = Eigen::Vector3d::UnitX();
  const TrueCylinder large{{0.0, 0.0, 0.0}, axis, 2.5, 0.30};
  const TrueCylinder small{{0.0, 0.0, 0.30 + 0.04 + 0.015}, axis, 2.5, 0.015};  // 4 cm clear above it
  const Eigen::Vector3d view = Eigen::Vector3d(0.0, -1.0, 0.4).normalized();
  addScannedCylinder(cloud, large, view, rng);
  addScannedCylinder(cloud, small, view, rng);

  const DirectionsResult directions = oneDirection(cloud, axis);
  const PlacementResult result = placeCylinders({cloud, directions, 3}, PlacementParams{});

  ASSERT_EQ(result.cylinders.size(), 2u);
  for (const TrueCylinder& truth : {large, small}) {
    const Cylinder* found = match(result, truth);
    ASSERT_NE(found, nullptr);
    EXPECT_NEAR(found->radius, truth.radius, 0.003) << "radius " << truth.radius;
    EXPECT_LT(axisOffset(*found, truth), 0.004) << "radius " << truth.radius;
    EXPECT_LT(angleDeg(found->direction, truth.axis), 0.5) << "radius " << truth.radius;
  }
}

TEST(Placement, RackOfParallelPipes) {
  Rng rng(5);
  PointCloud cloud;
  // Horizontal pipes in a row, 3 cm clear between neighbours, seen from below and in front.
  const Eigen::Vector3d axis = Eigen::Vector3d(1.0, 1.0, 0.0).normalized();
  const Eigen::Vector3d across = Eigen::Vector3d(-1.0, 1.0, 0.0).normalized();
  const std::vector<double> radii = {0.0365, 0.1096, 0.0211, 0.0572};
  std::vector<TrueCylinder> truths;
  double offset = 0.0;
  for (std::size_t k = 0; k < radii.size(); ++k) {
    if (k > 0) offset += radii[k - 1] + radii[k] + 0.03;
    truths.push_back({Eigen::Vector3d(0.0, 0.0, 2.5) + offset * across, axis, 3.0, radii[k]});
  }
  const Eigen::Vector3d view = Eigen::Vector3d(-0.3, 0.3, -1.0).normalized();
  for (const TrueCylinder& truth : truths) addScannedCylinder(cloud, truth, view, rng);

  const DirectionsResult directions = oneDirection(cloud, axis);
  const PlacementResult result = placeCylinders({cloud, directions, 1}, PlacementParams{});

  ASSERT_EQ(result.cylinders.size(), truths.size());
  for (const TrueCylinder& truth : truths) {
    const Cylinder* found = match(result, truth);
    ASSERT_NE(found, nullptr);
    EXPECT_NEAR(found->radius, truth.radius, 0.003) << "radius " << truth.radius;
    EXPECT_LT(axisOffset(*found, truth), 0.004) << "radius " << truth.radius;
  }
  // No point is an inlier of two cylinders.
  std::vector<std::uint32_t> all;
  for (const Cylinder& c : result.cylinders) all.insert(all.end(), c.inliers.begin(), c.inliers.end());
  std::sort(all.begin(), all.end());
  EXPECT_EQ(std::adjacent_find(all.begin(), all.end()), all.end());
  // Ordered by support.
  for (std::size_t k = 1; k < result.cylinders.size(); ++k) {
    EXPECT_GE(result.cylinders[k - 1].inliers.size(), result.cylinders[k].inliers.size());
  }
}

TEST(Placement, ObliqueSlopedPipeWithOutliers) {
  Rng rng(13);
  PointCloud cloud;
  const TrueCylinder truth{{-1.0, 2.0, 1.0}, Eigen::Vector3d(0.6, -0.75, 0.28).normalized(), 2.5, 0.0842};
  addScannedCylinder(cloud, truth, Eigen::Vector3d(0.2, 0.5, 0.84).normalized(), rng);
  // 20 % uniform outliers with random normals in the pipe's box.
  const std::size_t pipePoints = cloud.size();
  for (std::size_t k = 0; k < pipePoints / 5; ++k) {
    const Eigen::Vector3d p = truth.start + rng.uniform(0.0, truth.length) * truth.axis +
                              Eigen::Vector3d(rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3));
    addPoint(cloud, p, Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal()).normalized());
  }

  const DirectionsResult directions = oneDirection(cloud, truth.axis);
  const PlacementResult result = placeCylinders({cloud, directions, 2}, PlacementParams{});

  ASSERT_EQ(result.cylinders.size(), 1u);
  const Cylinder& found = result.cylinders[0];
  EXPECT_NEAR(found.radius, truth.radius, 0.002);
  EXPECT_LT(axisOffset(found, truth), 0.003);
  EXPECT_LT(angleDeg(found.direction, truth.axis), 0.5);
  // Inliers are mostly the pipe's points.
  const auto fromPipe = std::count_if(found.inliers.begin(), found.inliers.end(), [&](std::uint32_t i) { return i < pipePoints; });
  EXPECT_GT(fromPipe, static_cast<long>(found.inliers.size() * 95 / 100));
}

TEST(Placement, PlaneAndBoxEdgeGiveNoCylinder) {
  Rng rng(17);
  PointCloud cloud;
  const Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
  // A wall (normal +x) and a 20 cm square post, both along the direction.
  for (double z = 0.0; z < 2.0; z += 0.01) {
    for (double y = 0.0; y < 1.5; y += 0.01) {
      addPoint(cloud, Eigen::Vector3d(0.002 * rng.normal(), y, z), perturbed(Eigen::Vector3d::UnitX(), 3.0, rng));
    }
    for (double t = -0.1; t < 0.1; t += 0.01) {  // the two faces seen from (+x, +y)
      addPoint(cloud, Eigen::Vector3d(1.1 + 0.002 * rng.normal(), 0.5 + t, z), perturbed(Eigen::Vector3d::UnitX(), 3.0, rng));
      addPoint(cloud, Eigen::Vector3d(1.0 + t, 0.6 + 0.002 * rng.normal(), z), perturbed(Eigen::Vector3d::UnitY(), 3.0, rng));
    }
  }
  const DirectionsResult directions = oneDirection(cloud, axis);
  const PlacementResult result = placeCylinders({cloud, directions, 1}, PlacementParams{});
  EXPECT_TRUE(result.cylinders.empty());
  EXPECT_EQ(result.projections.size(), 1u);
}

/// The faces of an axis-aligned box along z (corner `low`, sizes `size`) that face `view`, with
/// normals blended across each edge over `smoothing` metres as a PCA normal estimate blends them.
void addScannedBox(PointCloud& cloud, const Eigen::Vector2d& low, const Eigen::Vector2d& size, double height,
                   const Eigen::Vector2d& view, Rng& rng, double smoothing = 0.02) {
  const Eigen::Vector2d center = low + 0.5 * size;
  for (int axis = 0; axis < 2; ++axis) {
    for (const double side : {-1.0, 1.0}) {
      const Eigen::Vector2d normal = side * Eigen::Vector2d::Unit(axis);
      if (normal.dot(view) <= 0.0) continue;
      const int along = 1 - axis;
      for (double z = 0.005; z < height; z += 0.01) {
        for (double t = 0.005; t < size[along]; t += 0.01) {
          Eigen::Vector2d p = center + 0.5 * side * size[axis] * Eigen::Vector2d::Unit(axis);
          p[along] = low[along] + t;
          // Towards an edge the normal turns half-way to the neighbouring face's.
          const double toEdge = std::min(t, size[along] - t);
          const double edgeSide = t < 0.5 * size[along] ? -1.0 : 1.0;
          const double blend = 0.5 * std::max(0.0, 1.0 - toEdge / smoothing);
          const Eigen::Vector2d n = ((1.0 - blend) * normal + blend * edgeSide * Eigen::Vector2d::Unit(along)).normalized();
          const Eigen::Vector3d position(p.x() + 0.002 * rng.normal() * normal.x(), p.y() + 0.002 * rng.normal() * normal.y(), z);
          addPoint(cloud, position, perturbed(Eigen::Vector3d(n.x(), n.y(), 0.0), 3.0, rng));
        }
      }
    }
  }
}

TEST(Placement, BoxEdgesAndSquarePostsGiveNoCylinder) {
  Rng rng(31);
  PointCloud cloud;
  // A 5 cm handrail post seen from two sides, a 15 cm column and a cabinet corner, each with
  // the smoothed normals that make an edge look like a quarter of a small pipe.
  addScannedBox(cloud, {0.0, 0.0}, {0.05, 0.05}, 1.1, Eigen::Vector2d(1.0, 0.6), rng);
  addScannedBox(cloud, {0.0, 0.0}, {0.05, 0.05}, 1.1, Eigen::Vector2d(-0.6, -1.0), rng);
  addScannedBox(cloud, {1.0, 0.0}, {0.15, 0.15}, 2.0, Eigen::Vector2d(-1.0, 0.8), rng);
  addScannedBox(cloud, {2.0, 1.0}, {0.6, 0.8}, 1.8, Eigen::Vector2d(-1.0, -0.5), rng);
  const DirectionsResult directions = oneDirection(cloud, Eigen::Vector3d::UnitZ());
  const PlacementResult result = placeCylinders({cloud, directions, 1}, PlacementParams{});
  for (const Cylinder& c : result.cylinders) {
    ADD_FAILURE() << "cylinder r=" << c.radius << " at (" << c.point.x() << ", " << c.point.y() << ") with "
                  << c.inliers.size() << " inliers";
  }
  // Without the checks that a fit looks like a pipe, these edges do pass for pipes.
  PlacementParams lax;
  lax.maxShellShare = lax.maxOutOfRound = 1e9;
  lax.minCandidateShare = 0.0;
  EXPECT_GE(placeCylinders({cloud, directions, 1}, lax).cylinders.size(), 3u);
}

/// Placement along `truth`'s axis finds one cylinder, its radius within 3 mm and its axis within
/// 4 mm of the truth, holding more than `inlierShare` of the points.
void expectOnePipe(const PointCloud& cloud, const TrueCylinder& truth, double inlierShare) {
  const DirectionsResult directions = oneDirection(cloud, truth.axis);
  const PlacementResult result = placeCylinders({cloud, directions, 1}, PlacementParams{});
  ASSERT_EQ(result.cylinders.size(), 1u);
  EXPECT_NEAR(result.cylinders[0].radius, truth.radius, 0.003);
  EXPECT_LT(axisOffset(result.cylinders[0], truth), 0.004);
  EXPECT_GT(static_cast<double>(result.cylinders[0].inliers.size()), inlierShare * static_cast<double>(cloud.size()));
}

TEST(Placement, PoorThreeDimensionalNormalsAreReestimatedInThePlane) {
  Rng rng(37);
  PointCloud cloud;
  // A 3 cm pipe where a neighbourhood of most points runs along the axis (a scan line along the
  // pipe), so their 3-D normals point anywhere around it, as on thin pipes far from the scanner.
  const TrueCylinder truth{{0.2, 0.1, 0.0}, Eigen::Vector3d(0.0, 0.2, 1.0).normalized(), 1.5, 0.03};
  addScannedCylinder(cloud, truth, Eigen::Vector3d::UnitX(), rng);
  const Eigen::Vector3d across = perpendicular(truth.axis);
  for (Eigen::Vector3f& normal : cloud.normals) {
    if (rng.chance(0.7)) normal = (Eigen::AngleAxisd(rng.uniform(0.0, 2.0 * kPi), truth.axis) * across).cast<float>();
  }
  expectOnePipe(cloud, truth, 0.8);
}

/// A riser along z (`radius`, `length` tall) seen from far along +x in scan columns at `degrees`
/// round from the facing side, a point every `step` down each with 2 mm noise, and every 3-D normal
/// facing the scanner (off by `normalNoiseDeg`), as on thin pipes seen from afar.
void addRiserInScanColumns(PointCloud& cloud, double radius, double length, const std::vector<double>& degrees,
                           double step, double normalNoiseDeg, Rng& rng) {
  for (const double column : degrees) {
    const Eigen::Vector3d radial(std::cos(column * kDegree), std::sin(column * kDegree), 0.0);
    for (double z = rng.uniform(0.0, step); z < length; z += step) {
      addPoint(cloud, (radius + 0.002 * rng.normal()) * radial + Eigen::Vector3d(0.0, 0.0, z),
               perturbed(Eigen::Vector3d::UnitX(), normalNoiseDeg, rng));
    }
  }
}

TEST(Placement, AThinPipeSeenInFourScanColumnsKeepsItsOuterColumns) {
  Rng rng(41);
  PointCloud cloud;
  // A 2.4 cm riser far from the scanner (along +x): the scan lines run down it in four columns
  // 1.2 cm apart across its silhouette, and the 3-D normals all face the scanner.
  const TrueCylinder truth{{0.0, 0.0, 0.0}, Eigen::Vector3d::UnitZ(), 2.4, 0.024};
  std::vector<double> columns;
  for (const double y : {-0.018, -0.006, 0.006, 0.018}) columns.push_back(std::asin(y / truth.radius) / kDegree);
  addRiserInScanColumns(cloud, truth.radius, truth.length, columns, 0.02, 10.0, rng);
  const DirectionsResult directions = oneDirection(cloud, truth.axis);
  const PlacementResult result = placeCylinders({cloud, directions, 1}, PlacementParams{});
  ASSERT_EQ(result.cylinders.size(), 1u);
  EXPECT_NEAR(result.cylinders[0].radius, truth.radius, 0.004);
  // Two neighbouring columns are two clusters in the plane: a parabola through them turned the
  // outer columns' normals tangent, and the pipe was lost.
  EXPECT_GT(result.cylinders[0].inliers.size(), cloud.size() * 9 / 10);
}

TEST(Placement, AThinPipeSeenInThreeScanColumnsTakesTheirArcsNormals) {
  Rng rng(47);
  PointCloud cloud;
  // A 3 cm riser seen in three scan columns 40° and 60° round from the middle one, 2.3 cm between
  // points down each, as on a sparse far branch. A k-neighbourhood spans the three columns, so
  // every 3-D normal is that of their plane: right on the middle column, 40° and 60° off on the
  // outer ones. Alone, each column is a tight cluster in the plane; across the three, an arc.
  const TrueCylinder truth{{0.0, 0.0, 0.0}, Eigen::Vector3d::UnitZ(), 3.0, 0.03};
  addRiserInScanColumns(cloud, truth.radius, truth.length, {-40.0, 0.0, 60.0}, 0.023, 5.0, rng);
  // With the outer columns' normals rejected, the middle column alone leaves the circle free to
  // slide along it: the fit went astray and no pipe was found.
  expectOnePipe(cloud, truth, 0.9);
}

/// The faces of a square post along z (centre `center`, half its width `half` < 6 cm, 1.1 m tall)
/// that a scanner far along `view` sees in columns `step` apart across it, offset by `offset`, with the
/// 3-D normals facing the scanner as on thin things seen from afar.
void addPostInScanColumns(PointCloud& cloud, const Eigen::Vector2d& center, double half, Eigen::Vector2d view,
                          double step, double offset, Rng& rng) {
  view.normalize();
  const Eigen::Vector2d across(-view.y(), view.x());
  for (double lateral = offset - 0.06; lateral < 0.06; lateral += step) {
    // The nearest face the ray at this lateral offset meets, coming from far along `view`.
    const Eigen::Vector2d start = lateral * across + view;
    std::optional<double> hit;
    for (int axis = 0; axis < 2; ++axis) {
      const double t = (start[axis] - std::copysign(half, view[axis])) / view[axis];
      const Eigen::Vector2d p = start - t * view;
      if (std::abs(p[1 - axis]) <= half && (!hit || t < *hit)) hit = t;
    }
    if (!hit) continue;
    const Eigen::Vector2d p = center + start - *hit * view;
    for (double z = rng.uniform(0.0, 0.025); z < 1.1; z += 0.025) {
      const Eigen::Vector2d noisy = p + 0.002 * rng.normal() * view;
      addPoint(cloud, Eigen::Vector3d(noisy.x(), noisy.y(), z),
               perturbed(Eigen::Vector3d(view.x(), view.y(), 0.0), 10.0, rng));
    }
  }
}

/// Placement along z over the cloud of a post: every cylinder found is a failure.
void expectNoCylinderOnAPost(const PointCloud& cloud) {
  const DirectionsResult directions = oneDirection(cloud, Eigen::Vector3d::UnitZ());
  const PlacementResult result = placeCylinders({cloud, directions, 1}, PlacementParams{});
  for (const Cylinder& c : result.cylinders) {
    ADD_FAILURE() << "cylinder r=" << c.radius << " at (" << c.point.x() << ", " << c.point.y() << ") with "
                  << c.inliers.size() << " of " << cloud.size() << " points as inliers";
  }
}

TEST(Placement, ASquarePostSeenInAFewScanColumnsIsNoPipe) {
  Rng rng(43);
  PointCloud cloud;
  // Over two scan columns the chord's normal stands in for the arc's, so at a corner it is the
  // normal of a circle inscribed there: the columns round the corner pass as a small pipe's
  // inliers, and a circle through them is round. The other columns in its band are not.
  addPostInScanColumns(cloud, {0.0, 0.0}, 0.034, {1.0, 1.0}, 0.015, 0.0, rng);
  expectNoCylinderOnAPost(cloud);
}

TEST(Placement, ASquarePostSeenInThreeScanColumnsIsNoPipeWhateverNormalsTheyTake) {
  Rng rng(43);
  PointCloud cloud;
  // A 5 cm handrail post seen in three columns 2 cm apart, two on one face and one on the other:
  // across the columns the normals are those of an arc, and a circle through them stays within
  // a millimetre of round. A fit that needs the normals across columns has its shape from those
  // few columns alone, so it gets no tolerance for noise on few points.
  addPostInScanColumns(cloud, {0.0, 0.0}, 0.025, {1.0, 0.5}, 0.02, 0.0, rng);
  expectNoCylinderOnAPost(cloud);
}

TEST(Placement, AWidePipeSeenInAFewScanColumnsPoolsTheModesItsCandidatesSplitInto) {
  Rng rng(6);
  PointCloud cloud;
  // An 84 mm riser seen as six scan columns over 122°, a point every 4 cm down each, as a far
  // station sees it. Each 3-D normal spans the columns beside its own, so it leans towards the
  // middle of the part seen (the side facing the scanner, 55° round) by nearly half its angle.
  // The pairs' normal lines then meet along a ridge of circles through the true one, which
  // mean-shift splits into modes each short of the candidates asked: the pipe was lost, though
  // each mode's fit converges on it.
  const TrueCylinder truth{{0.0, 0.0, 0.0}, Eigen::Vector3d::UnitZ(), 0.6, 0.084};
  constexpr double kFacingDeg = 55.0;
  constexpr double kLean = 0.45;
  for (const double column : {-5.0, 27.0, 50.0, 70.0, 91.0, 117.0}) {
    const Eigen::Vector3d radial(std::cos(column * kDegree), std::sin(column * kDegree), 0.0);
    const double normalDeg = column + kLean * (kFacingDeg - column);
    const Eigen::Vector3d normal(std::cos(normalDeg * kDegree), std::sin(normalDeg * kDegree), 0.0);
    for (double z = rng.uniform(0.0, 0.04); z < truth.length; z += 0.04) {
      addPoint(cloud, (truth.radius + 0.002 * rng.normal()) * radial + Eigen::Vector3d(0.0, 0.0, z),
               perturbed(normal, 5.0, rng));
    }
  }
  expectOnePipe(cloud, truth, 0.95);
}

TEST(Placement, ACircleWithFewerCandidatesThanAskedMakesACylinderThatMustTakeAJoint) {
  Rng rng(11);
  PointCloud cloud;
  const TrueCylinder truth{{0.0, 0.0, 0.0}, Eigen::Vector3d::UnitZ(), 1.0, 0.05};
  addScannedCylinder(cloud, truth, Eigen::Vector3d::UnitX(), rng);
  const DirectionsResult directions = oneDirection(cloud, truth.axis);
  PlacementParams params;
  const PlacementResult firm = placeCylinders({cloud, directions, 1}, params);
  const Cylinder* found = match(firm, truth);
  ASSERT_NE(found, nullptr);
  EXPECT_FALSE(found->mustJoin);

  // Asked for more candidates than its circle gathers, the pipe is found only on condition...
  params.minCandidates = found->candidates + 1;
  params.minJoinedCandidates = found->candidates / 2;
  const PlacementResult weak = placeCylinders({cloud, directions, 1}, params);
  const Cylinder* onCondition = match(weak, truth);
  ASSERT_NE(onCondition, nullptr);
  EXPECT_TRUE(onCondition->mustJoin);
  EXPECT_LT(axisOffset(*onCondition, truth), 0.002);
  // ...and not at all when no condition is offered.
  params.minJoinedCandidates = 0;
  EXPECT_EQ(match(placeCylinders({cloud, directions, 1}, params), truth), nullptr);
}

TEST(Placement, ACylinderWithFewerInliersThanAskedMustTakeAJoint) {
  // A short leg between two elbows, seen over 12 cm: a few dozen points.
  Rng rng(23);
  PointCloud cloud;
  const TrueCylinder leg{{0.0, 0.0, 0.0}, Eigen::Vector3d::UnitZ(), 0.12, 0.03};
  addScannedCylinder(cloud, leg, Eigen::Vector3d::UnitX(), rng, 0.015);
  const DirectionsResult directions = oneDirection(cloud, leg.axis);
  PlacementParams params;
  const PlacementResult result = placeCylinders({cloud, directions, 1}, params);
  const Cylinder* found = match(result, leg);
  ASSERT_NE(found, nullptr);
  ASSERT_LT(found->inliers.size(), static_cast<std::size_t>(params.minInliers));
  ASSERT_GE(found->candidates, params.minCandidates);
  // Found on condition of a joint, for its inliers alone...
  EXPECT_TRUE(found->mustJoin);
  EXPECT_NEAR(found->radius, leg.radius, 0.003);
  EXPECT_LT(axisOffset(*found, leg), 0.003);
  // ...not at all when no condition is offered, or when it holds fewer than the condition asks...
  params.minJoinedInliers = 0;
  EXPECT_EQ(match(placeCylinders({cloud, directions, 1}, params), leg), nullptr);
  params.minJoinedInliers = static_cast<int>(found->inliers.size()) + 1;
  EXPECT_EQ(match(placeCylinders({cloud, directions, 1}, params), leg), nullptr);
  // ...and firmly when asked for no more inliers than it holds.
  params.minInliers = static_cast<int>(found->inliers.size());
  const PlacementResult firmResult = placeCylinders({cloud, directions, 1}, params);
  const Cylinder* firm = match(firmResult, leg);
  ASSERT_NE(firm, nullptr);
  EXPECT_FALSE(firm->mustJoin);
}

TEST(Placement, DirectionsAreIndependentAndPointsExclusive) {
  Rng rng(19);
  PointCloud cloud;
  const TrueCylinder alongX{{0.0, 0.0, 1.0}, Eigen::Vector3d::UnitX(), 2.0, 0.06};
  const TrueCylinder alongY{{1.0, -1.0, 1.5}, Eigen::Vector3d::UnitY(), 2.0, 0.04};
  const Eigen::Vector3d view = Eigen::Vector3d(0.3, 0.2, -1.0).normalized();
  addScannedCylinder(cloud, alongX, view, rng);
  const auto firstCount = static_cast<std::uint32_t>(cloud.size());
  addScannedCylinder(cloud, alongY, view, rng);

  DirectionsResult directions;
  for (const auto& [axis, first, last] : {std::tuple{alongX.axis, 0u, firstCount},
                                          std::tuple{alongY.axis, firstCount, static_cast<std::uint32_t>(cloud.size())}}) {
    PrincipalDirection direction;
    direction.axis = axis;
    for (std::uint32_t i = first; i < last; ++i) direction.stripe.push_back(i);
    directions.directions.push_back(direction);
  }
  // Both stripes also hold the other pipe's points whose normal is perpendicular to both axes.
  for (std::uint32_t i = 0; i < cloud.size(); ++i) {
    if (std::abs(cloud.normals[i].z()) > 0.99f) directions.directions[i < firstCount ? 1 : 0].stripe.push_back(i);
  }
  for (auto& direction : directions.directions) std::sort(direction.stripe.begin(), direction.stripe.end());

  const PlacementResult result = placeCylinders({cloud, directions, 4}, PlacementParams{});
  ASSERT_EQ(result.cylinders.size(), 2u);
  EXPECT_EQ(result.cylinders[0].directionIndex, 0);
  EXPECT_EQ(result.cylinders[1].directionIndex, 1);
  EXPECT_NEAR(result.cylinders[0].radius, alongX.radius, 0.002);
  EXPECT_NEAR(result.cylinders[1].radius, alongY.radius, 0.002);
  std::vector<std::uint32_t> shared;
  std::set_intersection(result.cylinders[0].inliers.begin(), result.cylinders[0].inliers.end(),
                        result.cylinders[1].inliers.begin(), result.cylinders[1].inliers.end(), std::back_inserter(shared));
  EXPECT_TRUE(shared.empty());
  ASSERT_EQ(result.projections.size(), 2u);
  EXPECT_LT(angleDeg(result.projections[1].axis, alongY.axis), 1e-9);
}

TEST(Placement, EmptyInputs) {
  PointCloud cloud;
  const DirectionsResult none;
  const PlacementResult result = placeCylinders({cloud, none, 1}, PlacementParams{});
  EXPECT_TRUE(result.cylinders.empty());
  EXPECT_TRUE(result.projections.empty());

  const DirectionsResult empty = oneDirection(cloud, Eigen::Vector3d::UnitZ());
  const PlacementResult nothing = placeCylinders({cloud, empty, 1}, PlacementParams{});
  EXPECT_TRUE(nothing.cylinders.empty());
  EXPECT_EQ(nothing.projections.size(), 1u);
}

TEST(Placement, CancelledProgressStops) {
  Rng rng(23);
  PointCloud cloud;
  addScannedCylinder(cloud, {{0.0, 0.0, 0.0}, Eigen::Vector3d::UnitZ(), 1.0, 0.05}, Eigen::Vector3d::UnitX(), rng);
  const DirectionsResult directions = oneDirection(cloud, Eigen::Vector3d::UnitZ());
  Progress progress;
  progress.cancel();
  EXPECT_THROW(placeCylinders({cloud, directions, 1}, PlacementParams{}, progress), Cancelled);
}

TEST(Placement, SameResultForAnyThreadCount) {
  Rng rng(29);
  PointCloud cloud;
  const Eigen::Vector3d axis = Eigen::Vector3d(0.2, 1.0, 0.05).normalized();
  const Eigen::Vector3d across = axis.cross(Eigen::Vector3d::UnitZ()).normalized();
  for (int k = 0; k < 3; ++k) {
    addScannedCylinder(cloud, {Eigen::Vector3d(0.0, 0.0, 2.0) + 0.25 * k * across, axis, 2.5, 0.03 + 0.03 * k},
                       Eigen::Vector3d(0.0, 0.0, -1.0), rng);
  }
  const DirectionsResult directions = oneDirection(cloud, axis);
  const auto run = [&](int threads) {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    return placeCylinders({cloud, directions, 42}, PlacementParams{});
  };
  const PlacementResult one = run(1);
  const PlacementResult two = run(2);
  ASSERT_EQ(one.cylinders.size(), 3u);
  ASSERT_EQ(one.cylinders.size(), two.cylinders.size());
  for (std::size_t k = 0; k < one.cylinders.size(); ++k) {
    EXPECT_EQ(one.cylinders[k].point, two.cylinders[k].point);
    EXPECT_EQ(one.cylinders[k].direction, two.cylinders[k].direction);
    EXPECT_EQ(one.cylinders[k].radius, two.cylinders[k].radius);
    EXPECT_EQ(one.cylinders[k].inliers, two.cylinders[k].inliers);
  }
  ASSERT_EQ(one.projections[0].candidates.size(), two.projections[0].candidates.size());
  for (std::size_t i = 0; i < one.projections[0].candidates.size(); ++i) {
    const CircleCandidate& a = one.projections[0].candidates[i];
    const CircleCandidate& b = two.projections[0].candidates[i];
    ASSERT_TRUE(a.center == b.center && a.radius == b.radius && a.circle == b.circle) << "candidate " << i;
  }
  // Another seed draws other pairs but finds the same pipes.
  const PlacementResult reseeded = placeCylinders({cloud, directions, 43}, PlacementParams{});
  ASSERT_EQ(reseeded.cylinders.size(), 3u);
  EXPECT_NEAR(reseeded.cylinders[0].radius, one.cylinders[0].radius, 1e-4);
}

}  // namespace
}  // namespace piperun
