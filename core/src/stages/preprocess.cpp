// Stage 1 — preprocessing (paper §3). The steps and why they are done this way:
//
// 1. Voxel grid. With autoVoxel the leaf is twice the scan's median spacing within [5 mm, voxelSize]:
//    terrestrial scans (5–10 mm spacing) get the 1 cm leaf, a 1 mm close-range scan 5 mm, where a
//    1 cm leaf would leave a 4 cm cylinder a few dozen points. Points are bucketed in cubes of the
//    leaf's edge aligned to world multiples of it (cropping a scan does not move the grid) and each
//    occupied cube gives the centroid of its points. Sorting (cube key, point index) pairs fixes the output order whatever the thread count,
//    and puts points of neighbouring cubes at nearby indices (cache-friendly queries later).
// 2. Statistical outlier removal as in PCL's StatisticalOutlierRemoval: a point whose mean distance
//    to its nearest neighbours exceeds the global mean + ratio × std of that measure goes. Outliers
//    beyond ~10 % inflate that std until they hide themselves; outlierRobust then uses the median
//    and MAD instead, at the price of dropping sparse far-range surfaces on clean scans. On a scan
//    with few outliers the std is the density's alone (a terrestrial scan thins out with range),
//    and mean + 3 std falls at 2–3 times the median: the far surfaces' points would go. So a point
//    the statistics take stays when it is no farther from its neighbours than sparseSurfaceSpacings
//    times the median and than twice its neighbours are from theirs: a stray point stands apart
//    from the surface its neighbours lie on, a sparse surface's point does not.
//    The neighbour search (nearest_neighbors.h) is exact and runs in a grid of cells sized from the
//    spacing; on scans it is faster than PCL's FLANN k-d tree, which it replaced (1.23 s → 0.53 s on
//    the medium preset's 1.1 M points, 2 cores).
// 3. Normals: PCA of the point and the non-outliers among its nearest neighbours; the normal is the
//    eigenvector of the smallest eigenvalue, curvature the surface variation λ0 / (λ0 + λ1 + λ2). The
//    sign of a normal is arbitrary: the method only uses unoriented normals (n and −n alike). Which
//    neighbours are outliers is known only once step 2 has seen every point. Step 2's search keeps
//    each point's normal neighbours for this step when they take no more than keptNeighborsMB
//    (4 bytes a neighbour a point); beyond it (3.4 GB for the 53 M voxel points of a 100 M point
//    scan) this step searches them again and uses each list as it is found: the same normals, the
//    neighbour steps about 30 % longer (49 → 63 s on that scan).
// 4. Large planes (floors, walls, equipment faces) would drown the Gaussian sphere, so they go.
//    Planes are found cell by cell: a cell is planar when its points are thin about their PCA plane,
//    spread in two directions (not a line), most point normals agree with the plane normal, and a
//    quadratic height fit shows no bend (thin strips along a large pipe's crest pass the thickness
//    test but bend by 1/r). Adjacent planar cells whose planes agree in angle and offset are joined
//    with union-find; regions covering at least planeMinArea are planes. A point is a plane point
//    when it lies in the band of its cell's plane (region cells) or of an adjacent region cell's
//    plane (the floor around a pipe standing on it) with a normal parallel to that plane, or in the
//    bands of two regions at once (the seam where a wall meets the floor, whose PCA normals are
//    tilted). Points standing off the plane in a planar cell stay: a small pipe lying on a floor
//    keeps its upper half.
// 5. Tiles: cubes of tileSize from the low corner of the kept points' bounding box, each grown by
//    tileOverlap; a point belongs to every tile whose grown box contains it.

#include "piperun/stages/preprocess.h"

#include "piperun/spacing.h"

#include "piperun/error.h"

#include "angles.h"
#include "bounds.h"
#include "free_storage.h"
#include "nearest_neighbors.h"
#include "sort_by_key.h"
#include "union_find.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace piperun {
namespace {

constexpr const char* kTask = "preprocess";
/// Points per parallel chunk; cancellation is checked once per chunk.
constexpr std::size_t kChunk = 4096;

// Share of the progress bar at the end of each step.
constexpr double kVoxelDone = 0.15;
constexpr double kOutliersDone = 0.40;
constexpr double kNormalsDone = 0.75;
constexpr double kPlanesDone = 0.92;

// Fixed constants of the plane detection; the ones that depend on the scene's scale are parameters.
constexpr std::uint32_t kMinCellPoints = 20;  ///< Fewer points say too little about a cell's shape.
constexpr double kMinSpreadShare = 0.08;      ///< Second in-plane std ≥ this × cell size: not a line.
constexpr double kParallelAngleDeg = 20.0;    ///< A point normal within this of a plane normal agrees with it.
constexpr double kMinAgreement = 0.75;        ///< Share of a planar cell's normals that must agree.
constexpr double kJoinAngleDeg = 10.0;        ///< Adjacent planar cells join when their normals differ less...
constexpr double kJoinOffsetFactor = 2.0;     ///< ...and each centroid is within this × thickness of the other plane.
constexpr double kCellBandFactor = 3.0;       ///< Plane band of a region cell, × thickness (3 RMS).
constexpr double kFringeBandFactor = 2.0;     ///< Plane band in cells next to a region, × thickness.

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

constexpr double kMinAutoVoxel = 0.005;

void require(bool condition, const std::string& message) {
  if (!condition) throw std::invalid_argument("preprocess: " + message);
}

void validate(const PreprocessParams& params) {
  const auto finite = [](double v) { return std::isfinite(v); };
  require(finite(params.voxelSize) && params.voxelSize >= 0.0, "voxelSize must be >= 0 m");
  require(params.outlierNeighbors >= 0, "outlierNeighbors must be >= 0");
  require(finite(params.outlierStdRatio) && params.outlierStdRatio >= 0.0, "outlierStdRatio must be >= 0");
  require(finite(params.sparseSurfaceSpacings) && params.sparseSurfaceSpacings >= 0.0,
          "sparseSurfaceSpacings must be >= 0");
  require(params.normalNeighbors >= 3, "normalNeighbors must be at least 3");
  require(finite(params.keptNeighborsMB) && params.keptNeighborsMB >= 0.0, "keptNeighborsMB must be >= 0 MB");
  require(finite(params.planeCellSize) && params.planeCellSize > 0.0, "planeCellSize must be > 0 m");
  require(finite(params.planeMaxThickness) && params.planeMaxThickness > 0.0, "planeMaxThickness must be > 0 m");
  require(finite(params.planeMinArea) && params.planeMinArea >= 0.0, "planeMinArea must be >= 0 m²");
  require(finite(params.planeMaxCurvature) && params.planeMaxCurvature >= 0.0, "planeMaxCurvature must be >= 0 1/m");
  require(finite(params.tileSize) && params.tileSize > 0.0, "tileSize must be > 0 m");
  require(finite(params.tileOverlap) && params.tileOverlap >= 0.0, "tileOverlap must be >= 0 m");
}

/// Runs body(first, last) over [0, count) in parallel chunks, checking for cancellation before each.
template <typename Body>
void parallelChunks(std::size_t count, Progress& progress, const Body& body) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, kChunk),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      progress.checkCancelled();
                      body(range.begin(), range.end());
                    });
}

using Index3 = Eigen::Array<std::int64_t, 3, 1>;

/// Throws when a grid with these cell counts per axis could not number its cells with 63-bit keys.
void requireKeysFit(const Index3& counts, double edge) {
  const double cells = static_cast<double>(counts.x()) * static_cast<double>(counts.y()) * static_cast<double>(counts.z());
  require(cells < 0x1p63, "a grid of " + std::to_string(edge) + " m cells over the cloud's extent has too many cells");
}

/// Cubes of a fixed edge aligned to world multiples of the edge, numbered over the cubes spanned by
/// a box of offsets: key = (x · ny + y) · nz + z, with x, y, z counted from the lowest cube.
class CubeGrid {
 public:
  /// `offsetBounds` bounds the offsets (from `origin`) of every point that will be looked up.
  CubeGrid(const Eigen::Vector3d& origin, double edge, const BoundingBox& offsetBounds)
      : origin_(origin), edge_(edge), lowest_(worldCube(offsetBounds.min)) {
    counts_ = worldCube(offsetBounds.max) - lowest_ + 1;
    requireKeysFit(counts_, edge);
  }

  Index3 cubeOf(const Eigen::Vector3f& offset) const { return worldCube(offset.cast<double>()) - lowest_; }
  bool contains(const Index3& cube) const { return (cube >= 0).all() && (cube < counts_).all(); }
  std::uint64_t key(const Index3& cube) const {
    return (static_cast<std::uint64_t>(cube.x()) * static_cast<std::uint64_t>(counts_.y()) +
            static_cast<std::uint64_t>(cube.y())) *
               static_cast<std::uint64_t>(counts_.z()) +
           static_cast<std::uint64_t>(cube.z());
  }

 private:
  Index3 worldCube(const Eigen::Vector3d& offset) const {
    return ((origin_ + offset) / edge_).array().floor().cast<std::int64_t>();
  }

  Eigen::Vector3d origin_;
  double edge_;
  Index3 lowest_;
  Index3 counts_;
};

/// Step 1: one point per occupied voxel, the centroid of its points; non-finite points are dropped.
PointCloud voxelCentroids(const PointCloud& input, double leaf, Progress& progress) {
  PointCloud output;
  output.origin = input.origin;
  const BoundingBox bounds = finiteBounds(input.positions).box;
  if (bounds.empty()) return output;
  if (leaf == 0.0) {
    output.positions.reserve(input.size());
    for (const Eigen::Vector3f& p : input.positions) {
      if (p.allFinite()) output.positions.push_back(p);
    }
    return output;
  }

  const CubeGrid grid(input.origin, leaf, bounds);
  KeyGroups voxels = groupItemsByKey(input.size(), [&](std::size_t i) {
    const Eigen::Vector3f& p = input.positions[i];
    return p.allFinite() ? grid.key(grid.cubeOf(p)) : kNoKey;
  });
  const std::size_t voxelCount = voxels.keys.size();
  freeStorage(voxels.keys);  // 8 bytes a voxel, held beside the scan: only the voxels' points are needed
  progress.checkCancelled();
  progress.report(kTask, 0.8 * kVoxelDone);

  const std::vector<std::uint32_t>& starts = voxels.begins;
  output.positions.resize(voxelCount);
  parallelChunks(voxelCount, progress, [&](std::size_t first, std::size_t last) {
    for (std::size_t v = first; v < last; ++v) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (std::uint32_t e = starts[v]; e < starts[v + 1]; ++e) sum += input.positions[voxels.items[e]].cast<double>();
      output.positions[v] = (sum / static_cast<double>(starts[v + 1] - starts[v])).cast<float>();
    }
  });
  return output;
}

/// Middle value of a copy of `values` (the upper one of an even count).
double median(std::vector<float> values) {
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

/// What step 2's search measured: every point's mean distance to its outlier neighbours and, when
/// kept for step 3, its first `keptK` neighbours.
struct OutlierSearch {
  std::vector<float> meanDistance;     ///< Empty when there is only one point.
  int keptK = 0;                       ///< Neighbours kept a point (0: none kept).
  std::vector<std::uint32_t> kept;     ///< keptK a point, nearest first.
};

/// Step 2's search: every point's mean distance to its `outlierK` nearest neighbours (at most the
/// other points), keeping its `keepK` nearest too when keepK > 0.
OutlierSearch searchOutlierNeighbors(const std::vector<Eigen::Vector3f>& positions, int outlierK, int keepK,
                                     double spacing, Progress& progress, double progressTo) {
  OutlierSearch search;
  const std::size_t n = positions.size();
  const int meanOf = neighborListSize(n, outlierK);
  if (meanOf == 0) return search;
  search.keptK = neighborListSize(n, keepK);
  const auto keptK = static_cast<std::size_t>(search.keptK);
  search.meanDistance.resize(n);
  search.kept.resize(n * keptK);
  visitNearestNeighbors(positions, std::max(outlierK, keepK), spacing, progress, kTask, kVoxelDone, progressTo,
                        [&](std::uint32_t point, const std::uint32_t* neighbors, const float* squaredDistances) {
                          float sum = 0.0f;
                          for (int j = 0; j < meanOf; ++j) sum += std::sqrt(squaredDistances[j]);
                          search.meanDistance[point] = sum / static_cast<float>(meanOf);
                          std::copy_n(neighbors, keptK, search.kept.begin() + static_cast<std::ptrdiff_t>(point * keptK));
                        });
  return search;
}

/// Hands every point's `k` nearest neighbours to `visit(point, neighbors)`: those step 2 kept when
/// it kept as many, otherwise found by a search of their own (progress from `progressFrom` to
/// `progressTo`).
template <typename Visit>
void visitNeighborLists(const std::vector<Eigen::Vector3f>& positions, const OutlierSearch& search, int k,
                        double spacing, Progress& progress, double progressFrom, double progressTo, Visit&& visit) {
  if (search.keptK >= k && !search.kept.empty()) {
    const auto keptK = static_cast<std::size_t>(search.keptK);
    parallelChunks(positions.size(), progress, [&](std::size_t first, std::size_t last) {
      for (std::size_t i = first; i < last; ++i) visit(static_cast<std::uint32_t>(i), &search.kept[i * keptK]);
    });
  } else {
    visitNearestNeighbors(positions, k, spacing, progress, kTask, progressFrom, progressTo,
                          [&](std::uint32_t i, const std::uint32_t* neighbors, const float*) { visit(i, neighbors); });
  }
}

/// Step 2: flags points whose mean neighbour distance exceeds centre + stdRatio × spread over all
/// points: mean and standard deviation, or with `robust` the median and the scaled median absolute
/// deviation (which heavy contamination cannot inflate).
std::vector<char> statisticalOutliers(const std::vector<float>& meanDistance, std::size_t n, double stdRatio,
                                      bool robust) {
  std::vector<char> outlier(n, 0);
  if (meanDistance.empty()) return outlier;
  double centre = 0.0;
  double spread = 0.0;
  if (robust) {
    centre = median(meanDistance);
    std::vector<float> deviations(n);
    for (std::size_t i = 0; i < n; ++i) deviations[i] = static_cast<float>(std::abs(meanDistance[i] - centre));
    spread = 1.4826 * median(std::move(deviations));  // the MAD of a normal distribution is 0.6745 σ
  } else {
    double sum = 0.0;
    double squaredSum = 0.0;
    for (float d : meanDistance) {
      sum += d;
      squaredSum += static_cast<double>(d) * d;
    }
    centre = sum / static_cast<double>(n);
    spread = std::sqrt(std::max(0.0, squaredSum / static_cast<double>(n) - centre * centre));
  }
  const double threshold = centre + stdRatio * spread;
  for (std::size_t i = 0; i < n; ++i) outlier[i] = meanDistance[i] > threshold;
  return outlier;
}

/// A point's mean neighbour distance may be at most this many times its neighbours' mean one to
/// count as a sparse surface's (the edge of a surface, with neighbours on one side, is about 1.5).
constexpr double kSparseSurfaceRatio = 2.0;

/// Step 2, then: keeps the points flagged in `outlier` that lie on a sparse surface (see the top of
/// this file), judged by their first `meanOf` neighbours.
void keepSparseSurfacePoints(std::vector<char>& outlier, const std::vector<float>& meanDistance, double maxSpacings,
                             const std::vector<Eigen::Vector3f>& positions, int meanOf, const OutlierSearch& search,
                             double spacing, Progress& progress, double progressFrom) {
  if (meanDistance.empty() || maxSpacings <= 0.0) return;
  const double maxDistance = maxSpacings * median(meanDistance);
  // A scan with outliers enough to set the threshold has no flagged point this near: no search.
  bool anyNear = false;
  for (std::size_t i = 0; i < outlier.size() && !anyNear; ++i) anyNear = outlier[i] && meanDistance[i] <= maxDistance;
  if (!anyNear) return;
  // Each decision reads the distances only, never another point's flag: any order gives the same.
  const auto judge = [&](std::uint32_t point, const std::uint32_t* neighbors) {
    if (!outlier[point] || meanDistance[point] > maxDistance) return;
    double sum = 0.0;
    for (int j = 0; j < meanOf; ++j) sum += meanDistance[neighbors[j]];
    if (meanDistance[point] <= kSparseSurfaceRatio * sum / meanOf) outlier[point] = 0;
  };
  visitNeighborLists(positions, search, meanOf, spacing, progress, progressFrom, kOutliersDone, judge);
}

/// Eigen-decomposition of the covariance of a set of points, smallest eigenvalue first.
struct PrincipalFrame {
  Eigen::Vector3d centroid;
  Eigen::Vector3d eigenvalues;   ///< Ascending, clamped at 0.
  Eigen::Matrix3d eigenvectors;  ///< Columns matching the eigenvalues.
};

/// Accumulates points relative to a reference point (keeps float offsets' precision in the sums).
class MomentSum {
 public:
  explicit MomentSum(const Eigen::Vector3d& reference) : reference_(reference) {}
  void add(const Eigen::Vector3d& p) {
    const Eigen::Vector3d d = p - reference_;
    first_ += d;
    second_.noalias() += d * d.transpose();
    ++count_;
  }
  std::size_t count() const { return count_; }
  PrincipalFrame frame() const {
    const double n = static_cast<double>(count_);
    const Eigen::Vector3d mean = first_ / n;
    const Eigen::Matrix3d covariance = second_ / n - mean * mean.transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
    solver.computeDirect(covariance);
    return {reference_ + mean, solver.eigenvalues().cwiseMax(0.0), solver.eigenvectors()};
  }

 private:
  Eigen::Vector3d reference_;
  Eigen::Vector3d first_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second_ = Eigen::Matrix3d::Zero();
  std::size_t count_ = 0;
};

/// Step 3: unit normal and curvature of every non-outlier point with at least two non-outlier
/// neighbours among its `normalK` nearest; `valid` flags those points (the others have no defined
/// normal).
struct SurfaceEstimates {
  std::vector<Eigen::Vector3f> normals;
  std::vector<float> curvature;
  std::vector<char> valid;
};

/// PCA of point i and the non-outliers among its `count` nearest neighbours.
void estimateNormalAt(std::uint32_t i, const std::uint32_t* neighbors, int count,
                      const std::vector<Eigen::Vector3f>& positions, const std::vector<char>& outlier,
                      SurfaceEstimates& estimates) {
  if (outlier[i]) return;
  const Eigen::Vector3d p = positions[i].cast<double>();
  MomentSum moments(p);
  moments.add(p);
  for (int j = 0; j < count; ++j) {
    if (!outlier[neighbors[j]]) moments.add(positions[neighbors[j]].cast<double>());
  }
  if (moments.count() < 3) return;
  const PrincipalFrame frame = moments.frame();
  const double total = frame.eigenvalues.sum();
  estimates.normals[i] = frame.eigenvectors.col(0).normalized().cast<float>();
  estimates.curvature[i] = total > 0.0 ? static_cast<float>(frame.eigenvalues[0] / total) : 0.0f;
  estimates.valid[i] = 1;
}

/// The normals from the `normalK` nearest neighbours of each point: those step 2 kept when it kept
/// as many, otherwise found by a search of their own.
SurfaceEstimates estimateNormals(const PointCloud& cloud, const OutlierSearch& search, const std::vector<char>& outlier,
                                 int normalK, double spacing, Progress& progress) {
  const std::size_t n = cloud.size();
  SurfaceEstimates estimates;
  estimates.normals.assign(n, Eigen::Vector3f::Zero());
  estimates.curvature.assign(n, 0.0f);
  estimates.valid.assign(n, 0);
  const auto& positions = cloud.positions;
  const int listSize = neighborListSize(n, normalK);
  visitNeighborLists(positions, search, listSize, spacing, progress, kOutliersDone, kNormalsDone,
                     [&](std::uint32_t i, const std::uint32_t* neighbors) {
                       estimateNormalAt(i, neighbors, listSize, positions, outlier, estimates);
                     });
  return estimates;
}

/// A cell of the plane grid and the plane fitted to its points.
struct PlaneCell {
  Index3 cube;
  std::uint32_t first = 0;  ///< Range of the cell's points in the grid's points by cell.
  std::uint32_t last = 0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  ///< Offset coordinates.
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double area = 0.0;  ///< Area covered by the points, from their in-plane spread.
  bool planar = false;
};

/// Largest absolute principal curvature (1/m) of the quadratic height field fitted to a cell's
/// points over their PCA plane: w = A u² + B uv + C v² + D u + E v + F.
double heightFieldCurvature(const PlaneCell& cell, const PrincipalFrame& frame, const std::vector<std::uint32_t>& points,
                            const PointCloud& cloud, double cellSize) {
  using Vector6d = Eigen::Matrix<double, 6, 1>;
  using Matrix6d = Eigen::Matrix<double, 6, 6>;
  Matrix6d normal = Matrix6d::Zero();
  Vector6d rhs = Vector6d::Zero();
  for (std::uint32_t e = cell.first; e < cell.last; ++e) {
    // Coordinates in cell-size units keep the normal equations well conditioned.
    const Eigen::Vector3d local =
        frame.eigenvectors.transpose() * (cloud.positions[points[e]].cast<double>() - frame.centroid) / cellSize;
    const double w = local[0], u = local[1], v = local[2];  // height along the normal, in-plane axes
    Vector6d basis;
    basis << u * u, u * v, v * v, u, v, 1.0;
    normal.selfadjointView<Eigen::Lower>().rankUpdate(basis);
    rhs += w * basis;
  }
  const Vector6d c = normal.selfadjointView<Eigen::Lower>().ldlt().solve(rhs);
  // Back to metres: A = c0 / cellSize (w and u, v were all divided by cellSize).
  const double a = c[0] / cellSize, b = c[1] / cellSize, cc = c[2] / cellSize;
  return std::abs(a + cc) + std::sqrt((a - cc) * (a - cc) + b * b);
}

/// Fits the cell's plane and decides whether it is a piece of a flat surface.
void classifyCell(PlaneCell& cell, const std::vector<std::uint32_t>& points, const PointCloud& cloud,
                  const std::vector<Eigen::Vector3f>& normals, const PreprocessParams& params) {
  const std::uint32_t count = cell.last - cell.first;
  MomentSum moments(cloud.positions[points[cell.first]].cast<double>());
  for (std::uint32_t e = cell.first; e < cell.last; ++e) moments.add(cloud.positions[points[e]].cast<double>());
  const PrincipalFrame frame = moments.frame();
  cell.centroid = frame.centroid;
  cell.normal = frame.eigenvectors.col(0).normalized();
  // A uniformly covered w × h rectangle has in-plane variances w²/12 and h²/12.
  cell.area = 12.0 * std::sqrt(frame.eigenvalues[1] * frame.eigenvalues[2]);
  if (count < kMinCellPoints) return;
  if (std::sqrt(frame.eigenvalues[0]) > params.planeMaxThickness) return;
  if (std::sqrt(frame.eigenvalues[1]) < kMinSpreadShare * params.planeCellSize) return;

  const double cosParallel = std::cos(radians(kParallelAngleDeg));
  std::uint32_t agreeing = 0;
  for (std::uint32_t e = cell.first; e < cell.last; ++e) {
    if (std::abs(normals[points[e]].cast<double>().dot(cell.normal)) >= cosParallel) ++agreeing;
  }
  if (agreeing < kMinAgreement * count) return;
  if (heightFieldCurvature(cell, frame, points, cloud, params.planeCellSize) > params.planeMaxCurvature) return;
  cell.planar = true;
}

/// Adjacent planar cells belong to one plane when their normals and offsets agree.
bool samePlane(const PlaneCell& a, const PlaneCell& b, double thickness) {
  const double maxOffset = kJoinOffsetFactor * thickness;
  return std::abs(a.normal.dot(b.normal)) >= std::cos(radians(kJoinAngleDeg)) &&
         std::abs((b.centroid - a.centroid).dot(a.normal)) <= maxOffset &&
         std::abs((a.centroid - b.centroid).dot(b.normal)) <= maxOffset;
}

/// The 26 neighbours of a cell, as offsets.
std::array<Index3, 26> neighborOffsets() {
  std::array<Index3, 26> offsets;
  int count = 0;
  for (int dx = -1; dx <= 1; ++dx) {
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dz = -1; dz <= 1; ++dz) {
        if (dx != 0 || dy != 0 || dz != 0) offsets[count++] = Index3(dx, dy, dz);
      }
    }
  }
  return offsets;
}

/// The points with normals grouped by the cells of the plane grid, sorted by cell key.
struct CellGrid {
  CubeGrid grid;
  std::vector<std::uint32_t> points;  ///< Point indices by cell (a cell's in index order).
  std::vector<PlaneCell> cells;
  std::vector<std::uint64_t> keys;  ///< Key of each cell, ascending.

  /// Index of the cell at `cube`, or -1 when no point falls there.
  std::int64_t cellAt(const Index3& cube) const {
    if (!grid.contains(cube)) return -1;
    const std::uint64_t key = grid.key(cube);
    const auto found = std::lower_bound(keys.begin(), keys.end(), key);
    return found != keys.end() && *found == key ? found - keys.begin() : -1;
  }
};

CellGrid groupIntoCells(const PointCloud& cloud, const std::vector<char>& valid, double cellSize, const BoundingBox& bounds) {
  CellGrid cells{CubeGrid(cloud.origin, cellSize, bounds), {}, {}, {}};
  KeyGroups groups = groupItemsByKey(cloud.size(), [&](std::size_t i) {
    return valid[i] ? cells.grid.key(cells.grid.cubeOf(cloud.positions[i])) : kNoKey;
  });
  cells.points = std::move(groups.items);
  cells.keys = std::move(groups.keys);
  cells.cells.resize(cells.keys.size());
  for (std::size_t c = 0; c < cells.cells.size(); ++c) {
    cells.cells[c].first = groups.begins[c];
    cells.cells[c].last = groups.begins[c + 1];
    cells.cells[c].cube = cells.grid.cubeOf(cloud.positions[cells.points[groups.begins[c]]]);
  }
  return cells;
}

/// Joins adjacent planar cells whose planes agree. Returns the region of each planar cell, named by
/// its root (its smallest cell), and -1 for the other cells.
std::vector<std::int64_t> coplanarRegions(const CellGrid& grid, double thickness) {
  const std::vector<PlaneCell>& cells = grid.cells;
  const std::array<Index3, 26> offsets = neighborOffsets();
  UnionFind regions(cells.size());  // the smallest cell of a region is its root
  for (std::size_t c = 0; c < cells.size(); ++c) {
    if (!cells[c].planar) continue;
    for (const Index3& offset : offsets) {
      const std::int64_t other = grid.cellAt(cells[c].cube + offset);
      if (other > static_cast<std::int64_t>(c) && cells[other].planar && samePlane(cells[c], cells[other], thickness)) {
        regions.unite(c, static_cast<std::size_t>(other));
      }
    }
  }
  std::vector<std::int64_t> regionOf(cells.size(), -1);
  for (std::size_t c = 0; c < cells.size(); ++c) {
    if (cells[c].planar) regionOf[c] = static_cast<std::int64_t>(regions.find(c));
  }
  return regionOf;
}

constexpr std::int64_t kOffPlanes = -1;
constexpr std::int64_t kOnSeam = -2;

/// Which plane each point lies on, for the regions of `regionOf` (-1 for cells in none): a region
/// cell's points are tested against the cell's plane, the points of a cell next to region cells
/// against those cells' planes. A point lies on a plane (`located` = its region) when it is in the
/// plane's band with a parallel normal, on a seam (kOnSeam) when it is in the bands of two regions,
/// else off the planes (kOffPlanes).
std::vector<std::int64_t> locateOnPlanes(const CellGrid& grid, const std::vector<std::int64_t>& regionOf,
                                         const PointCloud& cloud, const std::vector<Eigen::Vector3f>& normals,
                                         double thickness, Progress& progress) {
  struct BandPlane {
    const PlaneCell* cell;
    std::int64_t region;
    double band;
  };
  const std::vector<PlaneCell>& cells = grid.cells;
  const std::array<Index3, 26> offsets = neighborOffsets();
  const double cosParallel = std::cos(radians(kParallelAngleDeg));
  std::vector<std::int64_t> located(cloud.size(), kOffPlanes);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cells.size(), 16), [&](const tbb::blocked_range<std::size_t>& range) {
    progress.checkCancelled();
    std::array<BandPlane, 26> bands;
    for (std::size_t c = range.begin(); c < range.end(); ++c) {
      int bandCount = 0;
      if (regionOf[c] >= 0) {
        bands[bandCount++] = {&cells[c], regionOf[c], kCellBandFactor * thickness};
      } else {
        for (const Index3& offset : offsets) {
          const std::int64_t other = grid.cellAt(cells[c].cube + offset);
          if (other >= 0 && regionOf[other] >= 0) bands[bandCount++] = {&cells[other], regionOf[other], kFringeBandFactor * thickness};
        }
      }
      for (std::uint32_t e = cells[c].first; e < cells[c].last; ++e) {
        const std::uint32_t i = grid.points[e];
        const Eigen::Vector3d p = cloud.positions[i].cast<double>();
        const Eigen::Vector3d normal = normals[i].cast<double>();
        std::int64_t firstBand = -1;
        for (int b = 0; b < bandCount; ++b) {
          const BandPlane& plane = bands[b];
          if (std::abs((p - plane.cell->centroid).dot(plane.cell->normal)) > plane.band) continue;
          if (std::abs(normal.dot(plane.cell->normal)) >= cosParallel) {
            located[i] = plane.region;
            break;
          }
          if (firstBand >= 0 && firstBand != plane.region) {
            located[i] = kOnSeam;
            break;
          }
          if (firstBand < 0) firstBand = plane.region;
        }
      }
    }
  });
  return located;
}

/// Step 4: flags the points of large planes among the points with normals. Returns the plane count.
int findPlanePoints(const PointCloud& cloud, const SurfaceEstimates& surface, const PreprocessParams& params,
                    std::vector<char>& planePoint, Progress& progress) {
  const BoundingBox bounds = finiteBounds(cloud.positions, [&](std::size_t i) { return surface.valid[i] != 0; }).box;
  if (bounds.empty()) return 0;
  CellGrid grid = groupIntoCells(cloud, surface.valid, params.planeCellSize, bounds);
  progress.checkCancelled();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, grid.cells.size(), 16), [&](const tbb::blocked_range<std::size_t>& range) {
    progress.checkCancelled();
    for (std::size_t c = range.begin(); c < range.end(); ++c) {
      classifyCell(grid.cells[c], grid.points, cloud, surface.normals, params);
    }
  });
  progress.report(kTask, kNormalsDone + 0.5 * (kPlanesDone - kNormalsDone));

  std::vector<std::int64_t> regionOf = coplanarRegions(grid, params.planeMaxThickness);
  std::vector<std::int64_t> located =
      locateOnPlanes(grid, regionOf, cloud, surface.normals, params.planeMaxThickness, progress);
  progress.report(kTask, kNormalsDone + 0.8 * (kPlanesDone - kNormalsDone));

  // A region's area: the points on its plane, in its cells and around them, times the area per
  // point of its cells. Counting the points around the cells credits the plane for the cells it
  // shares with other surfaces (a box top's cells along its edges hold the sides too).
  const std::size_t cellCount = grid.cells.size();
  std::vector<double> cellArea(cellCount, 0.0), cellPoints(cellCount, 0.0), pointsOnPlane(cellCount, 0.0);
  for (std::size_t c = 0; c < cellCount; ++c) {
    if (regionOf[c] < 0) continue;
    cellArea[regionOf[c]] += grid.cells[c].area;
    cellPoints[regionOf[c]] += grid.cells[c].last - grid.cells[c].first;
  }
  for (std::int64_t region : located) {
    if (region >= 0) pointsOnPlane[region] += 1.0;
  }
  int planes = 0;
  for (std::size_t c = 0; c < cellCount; ++c) {
    const std::int64_t root = regionOf[c];  // roots come first in their region, so are seen unchanged
    if (root < 0) continue;
    if (pointsOnPlane[root] * cellArea[root] / cellPoints[root] < params.planeMinArea) {
      regionOf[c] = -1;
    } else if (root == static_cast<std::int64_t>(c)) {
      ++planes;
    }
  }
  if (planes == 0) return 0;

  located = locateOnPlanes(grid, regionOf, cloud, surface.normals, params.planeMaxThickness, progress);
  for (std::size_t i = 0; i < located.size(); ++i) planePoint[i] = located[i] != kOffPlanes;
  return planes;
}

/// The points with normals, kept or set aside as plane points, in point order. The kept points are
/// copied out, chunk by chunk in parallel; then the plane points (most of a site scan's) move up
/// in the voxel points' own arrays, which become theirs, so that the voxel points and a copy of
/// all of them are never held at once. Takes the voxel points, their estimates and the flags.
void splitPoints(PointCloud& sampled, SurfaceEstimates& surface, std::vector<char>& planePoint,
                 PreprocessResult& result) {
  constexpr std::size_t kSplitChunk = std::size_t{1} << 16;
  const std::size_t n = sampled.size();
  const std::size_t chunks = (n + kSplitChunk - 1) / kSplitChunk;
  const auto isKept = [&](std::size_t i) { return surface.valid[i] && !planePoint[i]; };
  const auto isPlane = [&](std::size_t i) { return surface.valid[i] && planePoint[i]; };
  std::vector<std::size_t> keptBefore(chunks + 1, 0);
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    for (std::size_t i = c * kSplitChunk, last = std::min(n, (c + 1) * kSplitChunk); i < last; ++i) {
      if (isKept(i)) ++keptBefore[c + 1];
    }
  });
  for (std::size_t c = 0; c < chunks; ++c) keptBefore[c + 1] += keptBefore[c];
  PointCloud& kept = result.points;
  kept.origin = sampled.origin;
  kept.positions.resize(keptBefore[chunks]);
  kept.normals.resize(keptBefore[chunks]);
  result.curvature.resize(keptBefore[chunks]);
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    std::size_t next = keptBefore[c];
    for (std::size_t i = c * kSplitChunk, last = std::min(n, (c + 1) * kSplitChunk); i < last; ++i) {
      if (!isKept(i)) continue;
      kept.positions[next] = sampled.positions[i];
      kept.normals[next] = surface.normals[i];
      result.curvature[next++] = surface.curvature[i];
    }
  });
  freeStorage(surface.curvature);

  // In order, so a point is read before a later one overwrites it.
  std::size_t planes = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!isPlane(i)) continue;
    sampled.positions[planes] = sampled.positions[i];
    surface.normals[planes++] = surface.normals[i];
  }
  freeStorage(surface.valid);
  freeStorage(planePoint);
  PointCloud& planePoints = result.planePoints;
  planePoints.origin = sampled.origin;
  planePoints.positions = std::move(sampled.positions);
  planePoints.normals = std::move(surface.normals);
  for (auto* values : {&planePoints.positions, &planePoints.normals}) {
    values->resize(planes);
    values->shrink_to_fit();  // one array at a time
  }
}

/// Step 5: cubic tiles from the low corner of the cloud's bounding box, grown by the overlap.
std::vector<Tile> buildTiles(const PointCloud& cloud, double size, double overlap, Progress& progress) {
  const BoundingBox bounds = cloud.boundingBox();
  if (bounds.empty()) return {};
  const Index3 counts = ((bounds.max - bounds.min) / size).array().floor().cast<std::int64_t>() + 1;
  requireKeysFit(counts, size);
  // Tile t's box along an axis is [low, high]; the same expressions give the boxes and the membership.
  const auto low = [&](int axis, std::int64_t t, double margin) {
    return bounds.min[axis] + (static_cast<double>(t) * size - margin);
  };
  const auto high = [&](int axis, std::int64_t t, double margin) {
    return bounds.min[axis] + (static_cast<double>(t + 1) * size + margin);
  };

  // (tile key, point) for every tile whose grown box contains the point; the axes are independent,
  // so the candidates along each axis are checked on their own and combined.
  std::vector<KeyedItem> memberships;
  memberships.reserve(cloud.size());
  std::array<std::vector<std::int64_t>, 3> along;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (i % kChunk == 0) progress.checkCancelled();
    const Eigen::Vector3d p = cloud.worldPosition(i);
    for (int axis = 0; axis < 3; ++axis) {
      along[axis].clear();
      const double x = p[axis] - bounds.min[axis];
      const auto first = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::floor((x - overlap) / size)) - 1);
      const auto last = std::min<std::int64_t>(counts[axis] - 1, static_cast<std::int64_t>(std::floor((x + overlap) / size)) + 1);
      for (std::int64_t t = first; t <= last; ++t) {
        if (p[axis] >= low(axis, t, overlap) && p[axis] <= high(axis, t, overlap)) along[axis].push_back(t);
      }
    }
    for (std::int64_t tx : along[0]) {
      for (std::int64_t ty : along[1]) {
        for (std::int64_t tz : along[2]) {
          const std::uint64_t key = (static_cast<std::uint64_t>(tx) * static_cast<std::uint64_t>(counts.y()) +
                                     static_cast<std::uint64_t>(ty)) *
                                        static_cast<std::uint64_t>(counts.z()) +
                                    static_cast<std::uint64_t>(tz);
          memberships.push_back({key, static_cast<std::uint32_t>(i)});
        }
      }
    }
  }
  stableSortByKey(memberships, keyOfItem);  // made in point order, so sorted by (tile, point)
  const std::vector<std::uint32_t> starts = runStarts(memberships, keyOfItem);

  std::vector<Tile> tiles;
  for (std::size_t t = 0; t + 1 < starts.size(); ++t) {
    const std::uint64_t key = memberships[starts[t]].first;
    const auto perX = static_cast<std::uint64_t>(counts.y() * counts.z());
    const Index3 index(static_cast<std::int64_t>(key / perX), static_cast<std::int64_t>(key % perX) / counts.z(),
                       static_cast<std::int64_t>(key % static_cast<std::uint64_t>(counts.z())));
    Tile tile;
    tile.id = static_cast<int>(t);
    for (int axis = 0; axis < 3; ++axis) {
      tile.core.min[axis] = low(axis, index[axis], 0.0);
      tile.core.max[axis] = high(axis, index[axis], 0.0);
      tile.box.min[axis] = low(axis, index[axis], overlap);
      tile.box.max[axis] = high(axis, index[axis], overlap);
    }
    tile.points.reserve(starts[t + 1] - starts[t]);
    for (std::uint32_t e = starts[t]; e < starts[t + 1]; ++e) tile.points.push_back(memberships[e].second);
    tiles.push_back(std::move(tile));
  }
  return tiles;
}

}  // namespace

PreprocessResult preprocess(const PointCloud& input, const PreprocessParams& params, Progress& progress) {
  // A share that owns nothing: the caller keeps the input.
  return preprocess(std::shared_ptr<const PointCloud>(std::shared_ptr<const PointCloud>(), &input), params, progress);
}

PreprocessResult preprocess(std::shared_ptr<const PointCloud> input, const PreprocessParams& params,
                            Progress& progress) {
  if (!input) throw std::invalid_argument("preprocess: no input cloud");
  validate(params);
  require(input->size() < std::numeric_limits<std::uint32_t>::max(), "clouds of 2^32 points or more are not supported");
  const Clock::time_point start = Clock::now();
  PreprocessResult result;
  auto& diagnostics = result.diagnostics;
  diagnostics.inputPoints = input->size();
  progress.report(kTask, 0.0);

  Clock::time_point stepStart = Clock::now();
  const double inputSpacing = estimatePointSpacing(*input);
  diagnostics.inputSpacing = inputSpacing;
  const double leaf =
      params.autoVoxel ? std::min(params.voxelSize, std::max(kMinAutoVoxel, 2.0 * inputSpacing)) : params.voxelSize;
  diagnostics.voxelSize = leaf;
  PointCloud sampled = voxelCentroids(*input, leaf, progress);
  input.reset();  // read for the last time
  const std::size_t n = sampled.size();
  diagnostics.afterVoxel = n;
  diagnostics.voxelSeconds = secondsSince(stepStart);
  progress.checkCancelled();
  progress.report(kTask, kVoxelDone);

  stepStart = Clock::now();
  // The cell size of the neighbour searches follows the spacing of the voxel points (the leaf, or
  // the scan's own spacing where that is wider); it changes the speed, not the neighbours.
  const double spacing = std::max(leaf, inputSpacing);
  const bool removeOutliers = params.outlierNeighbors > 0 && params.outlierStdRatio > 0.0;
  // The normals' neighbours are kept from the outlier search when they fit the memory allowed;
  // otherwise the normals search again (the same neighbours, so the same normals).
  const double keptBytes = static_cast<double>(n) * params.normalNeighbors * sizeof(std::uint32_t);
  const bool keepNeighbors = keptBytes <= params.keptNeighborsMB * 1e6;
  diagnostics.neighborSearches = n < 2 ? 0 : removeOutliers && !keepNeighbors ? 2 : 1;
  // The sparse surfaces' points read the outlier neighbours again: from the normals' lists when
  // those are kept and hold as many, otherwise from a second search (on site scans only).
  const int meanOf = neighborListSize(n, params.outlierNeighbors);
  const int keptK = keepNeighbors ? neighborListSize(n, params.normalNeighbors) : 0;  // as step 2 keeps them
  const bool searchAgain = removeOutliers && params.sparseSurfaceSpacings > 0.0 && keptK < meanOf;
  const double searchedOnce = searchAgain ? 0.5 * (kVoxelDone + kOutliersDone) : kOutliersDone;
  OutlierSearch search;
  if (removeOutliers) {
    search = searchOutlierNeighbors(sampled.positions, params.outlierNeighbors,
                                    keepNeighbors ? params.normalNeighbors : 0, spacing, progress, searchedOnce);
  }
  std::vector<char> outlier =
      statisticalOutliers(search.meanDistance, n, params.outlierStdRatio, params.outlierRobust);
  keepSparseSurfacePoints(outlier, search.meanDistance, params.sparseSurfaceSpacings, sampled.positions, meanOf,
                          search, spacing, progress, searchedOnce);
  freeStorage(search.meanDistance);
  diagnostics.outlierSeconds = secondsSince(stepStart);
  progress.checkCancelled();
  progress.report(kTask, kOutliersDone);

  stepStart = Clock::now();
  SurfaceEstimates surface = estimateNormals(sampled, search, outlier, params.normalNeighbors, spacing, progress);
  freeStorage(search.kept);
  freeStorage(outlier);
  // Points left without a normal (too few non-outlier neighbours) count as outliers.
  diagnostics.outliersRemoved = static_cast<std::size_t>(std::count(surface.valid.begin(), surface.valid.end(), 0));
  diagnostics.normalSeconds = secondsSince(stepStart);
  progress.checkCancelled();
  progress.report(kTask, kNormalsDone);

  stepStart = Clock::now();
  std::vector<char> planePoint(n, 0);
  if (params.removePlanes) {
    diagnostics.planes = findPlanePoints(sampled, surface, params, planePoint, progress);
  }
  diagnostics.planeSeconds = secondsSince(stepStart);
  progress.checkCancelled();
  progress.report(kTask, kPlanesDone);

  splitPoints(sampled, surface, planePoint, result);
  diagnostics.planePoints = result.planePoints.size();
  diagnostics.keptPoints = result.points.size();

  stepStart = Clock::now();
  result.tiles = buildTiles(result.points, params.tileSize, params.tileOverlap, progress);
  diagnostics.tileSeconds = secondsSince(stepStart);
  diagnostics.seconds = secondsSince(start);
  progress.report(kTask, 1.0);
  return result;
}

}  // namespace piperun
