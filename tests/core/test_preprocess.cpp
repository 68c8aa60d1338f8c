#include "piperun/error.h"
#include "piperun/io/point_reader.h"
#include "piperun/stages/preprocess.h"
#include "test_util.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace piperun {
namespace {

constexpr double kPi = 3.14159265358979323846;

double angleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::min(1.0, std::abs(a.normalized().dot(b.normalized())))) * 180.0 / kPi;
}

/// Builds test scenes from randomly sampled surfaces (uniform density, Gaussian noise along the normal).
class SceneBuilder {
 public:
  explicit SceneBuilder(std::uint64_t seed) : rng_(seed) {}

  /// The parallelogram corner + a·u + b·v, a, b in [0, 1].
  void plane(const Eigen::Vector3d& corner, const Eigen::Vector3d& u, const Eigen::Vector3d& v, double spacing,
             double noise) {
    const Eigen::Vector3d normal = u.cross(v).normalized();
    const auto count = static_cast<int>(u.cross(v).norm() / (spacing * spacing));
    for (int i = 0; i < count; ++i) add(corner + uniform() * u + uniform() * v, normal, noise);
  }

  /// The half of a cylinder's wall facing `view` (a pipe scanned from one side).
  void cylinder(const Eigen::Vector3d& start, const Eigen::Vector3d& end, double radius, const Eigen::Vector3d& view,
                double spacing, double noise) {
    const Eigen::Vector3d axis = (end - start).normalized();
    const Eigen::Vector3d facing = (view - view.dot(axis) * axis).normalized();
    const Eigen::Vector3d side = axis.cross(facing);
    const double length = (end - start).norm();
    const auto count = static_cast<int>(kPi * radius * length / (spacing * spacing));
    for (int i = 0; i < count; ++i) {
      const double angle = (uniform() - 0.5) * kPi;
      const Eigen::Vector3d normal = std::cos(angle) * facing + std::sin(angle) * side;
      add(start + uniform() * length * axis + radius * normal, normal, noise);
    }
  }

  /// Points spread uniformly through a box (clutter and outliers).
  void scatter(const Eigen::Vector3d& low, const Eigen::Vector3d& high, int count) {
    for (int i = 0; i < count; ++i) {
      chunk_.positions.push_back(low + Eigen::Vector3d(uniform(), uniform(), uniform()).cwiseProduct(high - low));
    }
  }

  PointCloud cloud(const Eigen::Vector3d& origin = Eigen::Vector3d::Zero()) const {
    PointCloud cloud;
    cloud.origin = origin;
    cloud.append(chunk_);
    return cloud;
  }

 private:
  double uniform() { return std::uniform_real_distribution<double>(0.0, 1.0)(rng_); }
  void add(const Eigen::Vector3d& p, const Eigen::Vector3d& normal, double noise) {
    const double offset = noise > 0.0 ? std::normal_distribution<double>(0.0, noise)(rng_) : 0.0;
    chunk_.positions.push_back(p + offset * normal);
  }

  std::mt19937_64 rng_;
  PointChunk chunk_;
};

/// Distance from p to the wall of the cylinder from a to b; infinite beyond its ends.
double cylinderWallDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b, double radius) {
  const Eigen::Vector3d axis = (b - a).normalized();
  const Eigen::Vector3d d = p - a;
  const double along = d.dot(axis);
  if (along < 0.0 || along > (b - a).norm()) return std::numeric_limits<double>::infinity();
  return std::abs((d - along * axis).norm() - radius);
}

/// Number of points of `cloud` for which `test` holds.
std::size_t countPoints(const PointCloud& cloud, const std::function<bool(const Eigen::Vector3d&)>& test) {
  std::size_t count = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) count += test(cloud.worldPosition(i)) ? 1 : 0;
  return count;
}

PreprocessParams withoutPlanes() {
  PreprocessParams params;
  params.removePlanes = false;
  return params;
}

TEST(PreprocessVoxel, CentroidsOfKnownLattice) {
  // 4 × 4 × 4 lattice points inside each of 5 × 3 × 2 voxels, far from the world origin.
  const double leaf = 0.01;
  const Eigen::Vector3d corner(1000.0, 2000.0, 10.0);
  PointChunk chunk;
  for (int vx = 0; vx < 5; ++vx) {
    for (int vy = 0; vy < 3; ++vy) {
      for (int vz = 0; vz < 2; ++vz) {
        for (int i = 0; i < 64; ++i) {
          const Eigen::Vector3d inVoxel((i % 4 + 0.5) / 4.0, (i / 4 % 4 + 0.5) / 4.0, (i / 16 + 0.5) / 4.0);
          chunk.positions.push_back(corner + leaf * (Eigen::Vector3d(vx, vy, vz) + inVoxel));
        }
      }
    }
  }
  PointCloud cloud;
  cloud.origin = corner;
  cloud.append(chunk);
  PreprocessParams params = withoutPlanes();
  params.voxelSize = leaf;
  params.autoVoxel = false;
  params.outlierStdRatio = 0.0;
  params.normalNeighbors = 3;

  const PreprocessResult result = preprocess(cloud, params);
  EXPECT_EQ(result.diagnostics.inputPoints, 5u * 3u * 2u * 64u);
  EXPECT_EQ(result.diagnostics.afterVoxel, 30u);
  ASSERT_EQ(result.points.size(), 30u);
  EXPECT_EQ(result.points.origin, corner);
  std::vector<bool> seen(30, false);
  for (std::size_t i = 0; i < result.points.size(); ++i) {
    // Each centroid is the centre of its voxel.
    const Eigen::Vector3d cell = (result.points.worldPosition(i) - corner) / leaf - Eigen::Vector3d::Constant(0.5);
    const Eigen::Vector3d rounded = cell.array().round();
    EXPECT_LT((cell - rounded).norm(), 1e-3) << "centroid " << i << " off its voxel centre";
    const int index = static_cast<int>((rounded.x() * 3 + rounded.y()) * 2 + rounded.z());
    ASSERT_GE(index, 0);
    ASSERT_LT(index, 30);
    EXPECT_FALSE(seen[index]);
    seen[index] = true;
  }
  // Sorted by voxel: x slowest, z fastest.
  EXPECT_LT(result.points.positions[0].x(), result.points.positions[29].x());
  EXPECT_LT(result.points.positions[0].z(), result.points.positions[1].z());
}

TEST(PreprocessVoxel, AutomaticLeafFollowsThePointSpacing) {
  // A 1 mm lattice (a close-range scan) gets the 5 mm floor; a 2 cm lattice the 1 cm ceiling.
  for (const auto& [spacing, expectedLeaf] : {std::pair{0.001, 0.005}, std::pair{0.02, 0.01}, std::pair{0.004, 0.008}}) {
    PointChunk chunk;
    for (int i = 0; i < 120; ++i) {
      for (int j = 0; j < 120; ++j) chunk.positions.emplace_back(i * spacing, j * spacing, 0.0);
    }
    PointCloud cloud;
    cloud.append(chunk);
    PreprocessParams params = withoutPlanes();
    params.outlierStdRatio = 0.0;
    const PreprocessResult result = preprocess(cloud, params);
    EXPECT_NEAR(result.diagnostics.voxelSize, expectedLeaf, 1e-6) << "spacing " << spacing;
  }
}

TEST(PreprocessVoxel, ZeroLeafKeepsEveryFinitePoint) {
  SceneBuilder scene(3);
  scene.plane({0, 0, 0}, {0.5, 0, 0}, {0, 0.5, 0}, 0.01, 0.0);
  PointCloud cloud = scene.cloud();
  const std::size_t finite = cloud.size();
  cloud.positions.push_back(Eigen::Vector3f(std::numeric_limits<float>::quiet_NaN(), 0.0f, 0.0f));
  PreprocessParams params = withoutPlanes();
  params.voxelSize = 0.0;
  params.outlierStdRatio = 0.0;
  const PreprocessResult result = preprocess(cloud, params);
  EXPECT_EQ(result.diagnostics.afterVoxel, finite);
  EXPECT_EQ(result.points.size(), finite);
}

TEST(PreprocessOutliers, RemovesScatteredPointsAndKeepsTheSurface) {
  SceneBuilder scene(5);
  scene.plane({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0.01, 0.001);
  const std::size_t surfacePoints = scene.cloud().size();
  scene.scatter({0, 0, 0.08}, {1, 1, 0.5}, 60);
  const PointCloud cloud = scene.cloud();
  PreprocessParams params = withoutPlanes();
  params.voxelSize = 0.0;

  const PreprocessResult result = preprocess(cloud, params);
  const auto offSurface = [](const Eigen::Vector3d& p) { return p.z() > 0.05; };
  EXPECT_EQ(countPoints(result.points, offSurface), 0u);
  EXPECT_GE(result.diagnostics.outliersRemoved, 60u);
  EXPECT_GE(result.points.size(), static_cast<std::size_t>(0.99 * static_cast<double>(surfacePoints)));
  EXPECT_EQ(result.diagnostics.keptPoints + result.diagnostics.outliersRemoved, cloud.size());
}

TEST(PreprocessOutliers, AScanWithFewOutliersKeepsItsSparseFarSurface) {
  // A terrestrial scan thins out with range: a near floor at 1 cm spacing and a far wall at 2.5 cm.
  // Without outliers to widen the spread of the neighbour distances, mean + 3 std falls inside the
  // far wall's. Its points lie as far from their neighbours as those do from theirs, so they stay;
  // points in the air, far from every other, still go.
  SceneBuilder scene(7);
  scene.plane({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0.01, 0.001);
  scene.plane({0, 3, 0}, {1, 0, 0}, {0, 0, 1}, 0.025, 0.001);
  const PointCloud clean = scene.cloud();
  scene.scatter({0, 1.2, 0.3}, {1, 2.8, 1.0}, 10);
  const PointCloud withStrays = scene.cloud();
  PreprocessParams params = withoutPlanes();
  params.voxelSize = 0.0;
  const auto onFarWall = [](const Eigen::Vector3d& p) { return p.y() > 2.99; };
  const auto inTheAir = [](const Eigen::Vector3d& p) { return p.y() > 1.1 && p.y() < 2.9; };
  const auto farWall = static_cast<double>(countPoints(clean, onFarWall));

  EXPECT_GE(countPoints(preprocess(clean, params).points, onFarWall), static_cast<std::size_t>(0.99 * farWall));
  const PreprocessResult strays = preprocess(withStrays, params);
  EXPECT_EQ(countPoints(strays.points, inTheAir), 0u);
  EXPECT_GE(countPoints(strays.points, onFarWall), static_cast<std::size_t>(0.99 * farWall));
  params.sparseSurfaceSpacings = 0.0;
  EXPECT_LT(countPoints(preprocess(clean, params).points, onFarWall), static_cast<std::size_t>(0.9 * farWall));
}

TEST(PreprocessOutliers, RobustStatisticsHoldUnderHeavyContamination) {
  // A fifth of the points scattered through the volume above a floor: they inflate the mean and std
  // of the neighbour distances enough to hide themselves, but not the median and MAD.
  SceneBuilder scene(6);
  scene.plane({0, 0, 0}, {2, 0, 0}, {0, 2, 0}, 0.01, 0.001);
  const std::size_t surfacePoints = scene.cloud().size();
  scene.scatter({0, 0, 0.05}, {2, 2, 2}, 10000);
  const PointCloud cloud = scene.cloud();
  PreprocessParams params = withoutPlanes();
  params.voxelSize = 0.0;
  const auto offSurface = [](const Eigen::Vector3d& p) { return p.z() > 0.03; };

  const PreprocessResult plain = preprocess(cloud, params);
  EXPECT_GT(countPoints(plain.points, offSurface), 5000u);
  params.outlierRobust = true;
  const PreprocessResult robust = preprocess(cloud, params);
  EXPECT_LT(countPoints(robust.points, offSurface), 500u);
  EXPECT_GE(countPoints(robust.points, [](const Eigen::Vector3d& p) { return p.z() < 0.01; }),
            static_cast<std::size_t>(0.99 * static_cast<double>(surfacePoints)));
}

TEST(PreprocessNormals, PlaneAndCylinderWithinTwoDegrees) {
  const Eigen::Vector3d planeNormal = Eigen::Vector3d(0.3, -0.2, 0.93).normalized();
  const Eigen::Vector3d u = planeNormal.unitOrthogonal();
  const Eigen::Vector3d v = planeNormal.cross(u);
  const Eigen::Vector3d a(2.0, 0.0, 0.0), b(2.0, 1.0, 1.0);  // a sloped pipe axis
  const double radius = 0.15;
  SceneBuilder scene(7);
  scene.plane(-0.5 * (u + v), u, v, 0.007, 0.0);
  scene.cylinder(a, b, radius, {1, 0, 0}, 0.003, 0.0);
  PreprocessParams params = withoutPlanes();
  params.voxelSize = 0.0;

  const PreprocessResult result = preprocess(scene.cloud(), params);
  ASSERT_TRUE(result.points.hasNormals());
  ASSERT_EQ(result.curvature.size(), result.points.size());
  double worstPlane = 0.0, worstCylinder = 0.0, planeCurvature = 0.0;
  std::size_t planeCount = 0, cylinderCount = 0;
  const Eigen::Vector3d axis = (b - a).normalized();
  for (std::size_t i = 0; i < result.points.size(); ++i) {
    const Eigen::Vector3d p = result.points.worldPosition(i);
    const Eigen::Vector3d n = result.points.normals[i].cast<double>();
    EXPECT_NEAR(n.norm(), 1.0, 1e-5);
    if (p.x() < 1.0) {
      worstPlane = std::max(worstPlane, angleDeg(n, planeNormal));
      planeCurvature = std::max(planeCurvature, static_cast<double>(result.curvature[i]));
      ++planeCount;
      continue;
    }
    // Away from the rims of the visible half, where the neighbourhood is one-sided.
    const Eigen::Vector3d d = p - a;
    const Eigen::Vector3d radial = d - d.dot(axis) * axis;
    const double along = d.dot(axis);
    if (along < 0.05 || along > (b - a).norm() - 0.05 || radial.normalized().dot(Eigen::Vector3d::UnitX()) < 0.2) continue;
    worstCylinder = std::max(worstCylinder, angleDeg(n, radial));
    ++cylinderCount;
  }
  EXPECT_GT(planeCount, 10000u);
  EXPECT_GT(cylinderCount, 5000u);
  EXPECT_LT(worstPlane, 2.0);
  EXPECT_LT(worstCylinder, 2.0);
  EXPECT_LT(planeCurvature, 1e-4);
}

TEST(PreprocessNormals, CurvatureIsLowOnANoisyPlaneAndHighAtACrease) {
  // A 2 mm-noise floor meeting a wall: surface variation stays low on the floor and peaks along the seam.
  SceneBuilder scene(8);
  scene.plane({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0.007, 0.002);
  scene.plane({0, 0, 0}, {1, 0, 0}, {0, 0, 1}, 0.007, 0.002);
  const PreprocessResult result = preprocess(scene.cloud(), withoutPlanes());
  std::vector<float> floor, seam;
  for (std::size_t i = 0; i < result.points.size(); ++i) {
    const Eigen::Vector3d p = result.points.worldPosition(i);
    if (p.y() > 0.1 && p.x() > 0.1 && p.x() < 0.9) floor.push_back(result.curvature[i]);
    if (p.y() < 0.005 && p.z() < 0.005 && p.x() > 0.1 && p.x() < 0.9) seam.push_back(result.curvature[i]);
  }
  ASSERT_GT(floor.size(), 1000u);
  ASSERT_GT(seam.size(), 20u);
  const auto median = [](std::vector<float> values) {
    std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
    return values[values.size() / 2];
  };
  EXPECT_LT(median(floor), 0.02f);
  EXPECT_GT(median(seam), 0.05f);
  EXPECT_GT(median(seam), 4.0f * median(floor));
}

/// A floor, two walls, a 30 cm pipe resting on the floor and a row of small pipes above it.
struct RoomScene {
  Eigen::Vector3d bigStart{0.5, 1.8, 0.3}, bigEnd{2.5, 1.8, 0.3};
  double bigRadius = 0.3;
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> smallPipes;
  double smallRadius = 0.02;
  PointCloud cloud;

  /// Surfaces sampled at `spacing` (the small pipes four times as densely, at most 4 mm), plus
  /// `clutter` points scattered through the room.
  RoomScene(std::uint64_t seed, double spacing, int clutter = 0) {
    SceneBuilder scene(seed);
    const double noise = 0.0015;
    scene.plane({0, 0, 0}, {3, 0, 0}, {0, 3, 0}, spacing, noise);      // floor
    scene.plane({0, 0, 0}, {0, 3, 0}, {0, 0, 1.5}, spacing, noise);    // wall x = 0
    scene.plane({0, 0, 0}, {3, 0, 0}, {0, 0, 1.5}, spacing, noise);    // wall y = 0
    scene.cylinder(bigStart, bigEnd, bigRadius, {0, 1, 0.3}, spacing, noise);
    for (int i = 0; i < 5; ++i) {
      const double y = 0.6 + 0.05 * i;
      smallPipes.emplace_back(Eigen::Vector3d(0.5, y, 0.12), Eigen::Vector3d(2.5, y, 0.12));
      scene.cylinder(smallPipes.back().first, smallPipes.back().second, smallRadius, {0, 0.3, 1},
                     std::min(0.004, spacing / 4.0), noise);
    }
    scene.scatter({0, 0, 0}, {3, 3, 1.5}, clutter);
    cloud = scene.cloud();
  }

  bool onBigPipe(const Eigen::Vector3d& p) const {
    return p.z() > 0.03 && cylinderWallDistance(p, bigStart, bigEnd, bigRadius) < 0.01;
  }
  bool onSmallPipe(const Eigen::Vector3d& p) const {
    for (const auto& [start, end] : smallPipes) {
      if (cylinderWallDistance(p, start, end, smallRadius) < 0.008) return true;
    }
    return false;
  }
  bool onRoomSurface(const Eigen::Vector3d& p) const {
    const bool nearPipes = cylinderWallDistance(p, bigStart, bigEnd, bigRadius) < 0.05;
    return !nearPipes && (std::abs(p.z()) < 0.01 || std::abs(p.x()) < 0.01 || std::abs(p.y()) < 0.01);
  }
};

TEST(PreprocessPlanes, RemovesFloorAndWallsButKeepsPipes) {
  const RoomScene room(11, 0.01);
  const PreprocessResult result = preprocess(room.cloud, PreprocessParams{});
  EXPECT_EQ(result.diagnostics.planes, 3);
  EXPECT_EQ(result.diagnostics.planePoints, result.planePoints.size());

  const auto bigPipe = [&](const Eigen::Vector3d& p) { return room.onBigPipe(p); };
  const auto smallPipes = [&](const Eigen::Vector3d& p) { return room.onSmallPipe(p); };
  const auto roomSurface = [&](const Eigen::Vector3d& p) { return room.onRoomSurface(p); };
  const std::size_t bigKept = countPoints(result.points, bigPipe);
  const std::size_t smallKept = countPoints(result.points, smallPipes);
  const std::size_t roomKept = countPoints(result.points, roomSurface);
  EXPECT_GT(bigKept, 5000u);
  EXPECT_GT(smallKept, 1000u);
  EXPECT_LE(countPoints(result.planePoints, bigPipe), bigKept / 100);
  EXPECT_LE(countPoints(result.planePoints, smallPipes), smallKept / 100);
  // Almost every floor and wall point goes; what stays are seams and the floor under the pipe.
  EXPECT_LE(roomKept, countPoints(result.planePoints, roomSurface) / 50);
}

TEST(PreprocessPlanes, KeepsAPipeRackLyingOnABeam) {
  // A 5 m beam (top face and one side) with six 2 cm pipes lying across it, spaced 5 cm.
  SceneBuilder scene(12);
  const double spacing = 0.007, noise = 0.0015, radius = 0.02;
  scene.plane({0, 0.5, 1.0}, {5, 0, 0}, {0, 0.3, 0}, spacing, noise);
  scene.plane({0, 0.5, 0.7}, {5, 0, 0}, {0, 0, 0.3}, spacing, noise);
  std::vector<double> pipeX;
  for (int i = 0; i < 6; ++i) {
    pipeX.push_back(2.0 + 0.05 * i);
    scene.cylinder({pipeX.back(), -0.5, 1.0 + radius}, {pipeX.back(), 1.8, 1.0 + radius}, radius, {0, -0.3, 1}, 0.004, noise);
  }
  const auto onPipe = [&](const Eigen::Vector3d& p) {
    for (double x : pipeX) {
      if (cylinderWallDistance(p, {x, -0.5, 1.0 + radius}, {x, 1.8, 1.0 + radius}, radius) < 0.008 && p.z() > 1.005) return true;
    }
    return false;
  };
  const auto onBeam = [&](const Eigen::Vector3d& p) {
    return (std::abs(p.z() - 1.0) < 0.01 || std::abs(p.y() - 0.5) < 0.01) && (p.x() < 1.9 || p.x() > 2.4);
  };

  // The beam's faces are narrow strips split by the rack: a lower area threshold makes them planes.
  PreprocessParams params;
  params.planeMinArea = 0.25;
  const PreprocessResult result = preprocess(scene.cloud(), params);
  EXPECT_GE(result.diagnostics.planes, 2);
  const std::size_t pipeKept = countPoints(result.points, onPipe);
  EXPECT_GT(pipeKept, 3000u);
  EXPECT_LE(countPoints(result.planePoints, onPipe), pipeKept / 100);
  EXPECT_GT(countPoints(result.planePoints, onBeam), 4 * countPoints(result.points, onBeam));
}

TEST(PreprocessPlanes, LeavesAPipeOnlySceneUntouched) {
  SceneBuilder scene(13);
  const double spacing = 0.006, noise = 0.002;
  scene.cylinder({0, 0, 0.5}, {3, 0, 0.5}, 0.3, {0, -1, 0.2}, spacing, noise);
  scene.cylinder({0, 1, 0}, {2, 2, 1.5}, 0.1, {0, -1, 0}, spacing, noise);
  scene.cylinder({3, 2, 0}, {3, 2, 2.5}, 0.05, {-1, -1, 0}, 0.004, noise);
  scene.cylinder({0, 3, 1}, {3, 2.5, 1}, 0.02, {0, -1, 0.5}, 0.004, noise);
  const PreprocessResult result = preprocess(scene.cloud(), PreprocessParams{});
  EXPECT_EQ(result.diagnostics.planes, 0);
  EXPECT_EQ(result.planePoints.size(), 0u);
  EXPECT_EQ(result.diagnostics.keptPoints + result.diagnostics.outliersRemoved, result.diagnostics.afterVoxel);
}

TEST(PreprocessTiles, CoverEveryPointAndOverlapByTheMargin) {
  SceneBuilder scene(17);
  scene.scatter({-3, 1, 0}, {9, 8, 3}, 20000);
  PreprocessParams params = withoutPlanes();
  params.voxelSize = 0.0;
  params.outlierStdRatio = 0.0;
  params.tileSize = 5.0;
  params.tileOverlap = 0.5;
  const PreprocessResult result = preprocess(scene.cloud({100, 200, 0}), params);
  const PointCloud& points = result.points;
  ASSERT_EQ(points.size(), 20000u);
  ASSERT_EQ(result.tiles.size(), 3u * 2u * 1u);  // 12 × 7 × 3 m in 5 m cubes

  std::vector<int> coresContaining(points.size(), 0);
  for (std::size_t t = 0; t < result.tiles.size(); ++t) {
    const Tile& tile = result.tiles[t];
    EXPECT_EQ(tile.id, static_cast<int>(t));
    EXPECT_TRUE(tile.core.size().isApprox(Eigen::Vector3d::Constant(5.0)));
    EXPECT_TRUE((tile.box.min - tile.core.min).isApprox(Eigen::Vector3d::Constant(-0.5)));
    EXPECT_TRUE((tile.box.max - tile.core.max).isApprox(Eigen::Vector3d::Constant(0.5)));
    if (t > 0) {
      const Eigen::Vector3d& previous = result.tiles[t - 1].core.min;
      EXPECT_TRUE(std::lexicographical_compare(previous.data(), previous.data() + 3, tile.core.min.data(),
                                               tile.core.min.data() + 3))
          << "tiles out of grid order";
    }
    EXPECT_TRUE(std::is_sorted(tile.points.begin(), tile.points.end()));
    // The tile lists exactly the points inside its grown box.
    std::vector<std::uint32_t> inside;
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector3d p = points.worldPosition(i);
      if ((p.array() >= tile.box.min.array()).all() && (p.array() <= tile.box.max.array()).all()) {
        inside.push_back(static_cast<std::uint32_t>(i));
      }
      if ((p.array() >= tile.core.min.array()).all() && (p.array() < tile.core.max.array()).all()) ++coresContaining[i];
    }
    EXPECT_EQ(tile.points, inside) << "tile " << t;
  }
  EXPECT_TRUE(std::all_of(coresContaining.begin(), coresContaining.end(), [](int c) { return c == 1; }));
}

TEST(PreprocessTiles, ASceneSmallerThanATileIsOneTile) {
  SceneBuilder scene(19);
  scene.plane({0, 0, 0}, {2, 0, 0}, {0, 2, 1}, 0.02, 0.001);
  const PreprocessResult result = preprocess(scene.cloud(), withoutPlanes());
  ASSERT_EQ(result.tiles.size(), 1u);
  EXPECT_EQ(result.tiles[0].points.size(), result.points.size());
}

TEST(PreprocessDeterminism, SameResultWithOneAndTwoThreads) {
  const RoomScene room(23, 0.015, 2000);
  PreprocessParams params;
  params.tileSize = 1.0;
  params.tileOverlap = 0.2;
  const auto run = [&](int threads) {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    return preprocess(room.cloud, params);
  };
  const PreprocessResult one = run(1);
  const PreprocessResult two = run(2);
  EXPECT_GT(one.diagnostics.outliersRemoved, 0u);
  EXPECT_GT(one.diagnostics.planes, 0);
  EXPECT_EQ(one.points.positions, two.points.positions);
  EXPECT_EQ(one.points.normals, two.points.normals);
  EXPECT_EQ(one.curvature, two.curvature);
  EXPECT_EQ(one.planePoints.positions, two.planePoints.positions);
  ASSERT_EQ(one.tiles.size(), two.tiles.size());
  for (std::size_t t = 0; t < one.tiles.size(); ++t) EXPECT_EQ(one.tiles[t].points, two.tiles[t].points);
}

TEST(PreprocessNormals, TheSameWhetherTheNeighboursAreKeptOrSearchedAgain) {
  const RoomScene room(37, 0.015, 2000);
  for (const int outlierNeighbors : {8, 24}) {  // fewer and more than the normals' 16
    PreprocessParams params;
    params.outlierNeighbors = outlierNeighbors;
    const PreprocessResult kept = preprocess(room.cloud, params);
    params.keptNeighborsMB = 0.0;
    const PreprocessResult searched = preprocess(room.cloud, params);
    EXPECT_EQ(kept.diagnostics.neighborSearches, 1);
    EXPECT_EQ(searched.diagnostics.neighborSearches, 2);
    EXPECT_GT(kept.diagnostics.outliersRemoved, 0u);
    EXPECT_EQ(kept.diagnostics.outliersRemoved, searched.diagnostics.outliersRemoved);
    EXPECT_EQ(kept.points.positions, searched.points.positions) << outlierNeighbors << " outlier neighbours";
    EXPECT_EQ(kept.points.normals, searched.points.normals) << outlierNeighbors << " outlier neighbours";
    EXPECT_EQ(kept.curvature, searched.curvature) << outlierNeighbors << " outlier neighbours";
    EXPECT_EQ(kept.planePoints.positions, searched.planePoints.positions) << outlierNeighbors << " outlier neighbours";
  }
}

TEST(PreprocessInput, AHandedOverInputIsFreedOnceTheVoxelGridIsMade) {
  const RoomScene room(41, 0.015, 500);
  const PreprocessResult kept = preprocess(room.cloud, PreprocessParams{});
  auto input = std::make_shared<const PointCloud>(room.cloud.clone());
  const std::weak_ptr<const PointCloud> watched = input;
  bool freedBeforeTheEnd = false;
  Progress progress([&](const std::string&, double fraction) {
    if (fraction < 1.0 && watched.expired()) freedBeforeTheEnd = true;
  });
  const PreprocessResult handed = preprocess(std::move(input), PreprocessParams{}, progress);
  EXPECT_TRUE(freedBeforeTheEnd);
  EXPECT_EQ(handed.points.positions, kept.points.positions);
  EXPECT_EQ(handed.points.normals, kept.points.normals);
  EXPECT_EQ(handed.diagnostics.inputPoints, room.cloud.size());
  EXPECT_THROW(preprocess(std::shared_ptr<const PointCloud>(), PreprocessParams{}), std::invalid_argument);
}

TEST(PreprocessProgress, ReportsToTheEndAndCanBeCancelled) {
  const RoomScene room(29, 0.015);
  std::vector<double> fractions;
  Progress reporting([&](const std::string& task, double fraction) {
    EXPECT_EQ(task, "preprocess");
    fractions.push_back(fraction);
  });
  preprocess(room.cloud, PreprocessParams{}, reporting);
  ASSERT_GE(fractions.size(), 5u);
  EXPECT_EQ(fractions.back(), 1.0);

  Progress cancelledBefore;
  cancelledBefore.cancel();
  EXPECT_THROW(preprocess(room.cloud, PreprocessParams{}, cancelledBefore), Cancelled);

  Progress* self = nullptr;
  double lastFraction = 0.0;
  Progress cancelledDuring([&](const std::string&, double fraction) {
    lastFraction = fraction;
    if (fraction > 0.2) self->cancel();
  });
  self = &cancelledDuring;
  EXPECT_THROW(preprocess(room.cloud, PreprocessParams{}, cancelledDuring), Cancelled);
  EXPECT_LT(lastFraction, 0.9);
}

TEST(PreprocessParamsCheck, RejectsInvalidParameters) {
  SceneBuilder scene(31);
  scene.plane({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0.05, 0.0);
  const PointCloud cloud = scene.cloud();
  const auto invalid = [&](const std::function<void(PreprocessParams&)>& change) {
    PreprocessParams params;
    change(params);
    EXPECT_THROW(preprocess(cloud, params), std::invalid_argument);
  };
  invalid([](PreprocessParams& p) { p.voxelSize = -0.01; });
  invalid([](PreprocessParams& p) { p.normalNeighbors = 2; });
  invalid([](PreprocessParams& p) { p.keptNeighborsMB = -1.0; });
  invalid([](PreprocessParams& p) { p.sparseSurfaceSpacings = -1.0; });
  invalid([](PreprocessParams& p) { p.tileSize = 0.0; });
  invalid([](PreprocessParams& p) { p.planeMaxThickness = std::nan(""); });
  const PreprocessResult empty = preprocess(PointCloud{}, PreprocessParams{});
  EXPECT_TRUE(empty.points.empty());
  EXPECT_TRUE(empty.tiles.empty());
}

TEST(PreprocessRealScan, PumpRoomKeepsTheRisersAndRemovesTheFloor) {
  const auto path = test::realDataDir() / "pumpA_pump_station.pcd";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "no real scan at " << path;
  const PointCloud cloud = readPointCloud(path);
  const PreprocessResult result = preprocess(cloud, PreprocessParams{});
  EXPECT_GE(result.diagnostics.planes, 1);
  // The two vertical risers (r ≈ 0.087 m), between 0.3 m and 1.2 m above the lowest point.
  const double floor = cloud.boundingBox().min.z();
  const std::vector<Eigen::Vector2d> risers = {{0.59, -3.25}, {-1.10, -1.95}};
  const auto onRiser = [&](const Eigen::Vector3d& p) {
    if (p.z() < floor + 0.3 || p.z() > floor + 1.2) return false;
    for (const Eigen::Vector2d& axis : risers) {
      if (std::abs((p.head<2>() - axis).norm() - 0.087) < 0.02) return true;
    }
    return false;
  };
  const std::size_t riserKept = countPoints(result.points, onRiser);
  EXPECT_GT(riserKept, 500u);
  EXPECT_LE(countPoints(result.planePoints, onRiser), riserKept / 50);
}

}  // namespace
}  // namespace piperun
