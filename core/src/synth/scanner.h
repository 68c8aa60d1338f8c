#pragma once
// A simulated terrestrial laser scanner: rays on an azimuth × elevation grid from a station, the
// nearest surface along each ray (so occlusion is exact), range noise along the surface normal
// and uniform outliers.

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "synth/shapes.h"

namespace piperun::synth {

struct Ray {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();  ///< Unit.
};

struct RayHit {
  double distance = 0.0;                              ///< Along the ray.
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< Unit surface normal at the hit.
};

/// The nearest intersection of `ray` with `shape` at a distance in (minDistance, maxDistance).
/// Cylinders and tori are exact (a torus by isolating the real roots of its quartic).
std::optional<RayHit> intersect(const Shape& shape, const Ray& ray, double minDistance, double maxDistance);

struct ScanSettings {
  double angularStep = 0.005;                 ///< Between neighbouring rays in azimuth and elevation (radians).
  double minElevation = -1.0471975511965976;  ///< -60°, the blind cone under the scanner.
  double maxElevation = 1.5707963267948966;   ///< +90°.
  double minRange = 0.3;                      ///< Closer hits are not recorded (m).
  double maxRange = 60.0;                     ///< Farther hits are not recorded (m).
  double noiseSigma = 0.0;                    ///< Gaussian noise along the surface normal (m).
  double outlierFraction = 0.0;               ///< Outliers per surface point, uniform in outlierBox.
  /// Share of the rays next to a depth edge (a range jump of more than kMixedPixelJump from the ray
  /// before it in the row or the column) that return a range between the two surfaces, as a beam
  /// straddling a silhouette does (a mixed pixel).
  double mixedPixelShare = 0.0;
  OrientedBox outlierBox;
  std::uint64_t seed = 1;
};

/// The points of one azimuth strip of a scan, in scan order (world coordinates).
struct ScanStrip {
  std::vector<Eigen::Vector3d> positions;
  std::vector<float> intensities;    ///< |cos(incidence)| × reflectance, in [0, 1].
  std::vector<std::int32_t> labels;  ///< The surface's label; -1 for outliers and mixed pixels.
  std::uint64_t outliers = 0;
  std::uint64_t mixedPixels = 0;
};

/// A range jump between neighbouring rays that makes a depth edge (m).
constexpr double kMixedPixelJump = 0.05;

class Scanner {
 public:
  explicit Scanner(std::vector<Surface> surfaces);

  /// Scans the scene from `station`. Strips of azimuth are traced in parallel and handed to
  /// `emit` one at a time, in azimuth order, with the fraction of the scan done. Each strip's
  /// noise is seeded from (settings.seed, stationIndex, strip), so the points do not depend on
  /// the thread count. Memory is bounded by a few strips in flight.
  void scan(const Eigen::Vector3d& station, int stationIndex, const ScanSettings& settings,
            const std::function<void(ScanStrip&& strip, double fraction)>& emit) const;

  /// Rays from `station` that hit a surface within range (used to choose the angular step).
  std::uint64_t countHits(const Eigen::Vector3d& station, const ScanSettings& settings) const;

  /// The nearest surface along `ray` within (minDistance, maxDistance), testing every surface:
  /// a brute-force reference. Returns the hit and the surface index.
  std::optional<std::pair<RayHit, int>> castRay(const Ray& ray, double minDistance, double maxDistance) const;

  /// Whether any surface crosses `ray` within (minDistance, maxDistance): a line-of-sight test
  /// through a bounding-box hierarchy over the surfaces' pieces.
  bool occluded(const Ray& ray, double minDistance, double maxDistance) const;

  const std::vector<Surface>& surfaces() const { return surfaces_; }

 private:
  /// A surface cut into pieces small enough for tight bounding spheres (cutting a cylinder, box or
  /// torus does not change the nearest hit).
  struct Piece {
    Shape shape;
    int surface = 0;
    Eigen::Vector3d boundCenter = Eigen::Vector3d::Zero();
    double boundRadius = 0.0;
    Eigen::Vector3d boxMin = Eigen::Vector3d::Zero();  ///< Axis-aligned bounds.
    Eigen::Vector3d boxMax = Eigen::Vector3d::Zero();
  };
  struct StationGrid;
  /// A box of the hierarchy over the pieces: a leaf holds pieceOrder_[first .. first + count),
  /// an inner node has its two halves at nodes_[children] and nodes_[children + 1].
  struct HierarchyNode {
    Eigen::Vector3d min = Eigen::Vector3d::Zero();
    Eigen::Vector3d max = Eigen::Vector3d::Zero();
    int first = 0;
    int count = 0;
    int children = -1;
  };

  StationGrid prepare(const Eigen::Vector3d& station, int stationIndex, const ScanSettings& settings) const;
  /// Traces the strip's rays column by column, each column from its lowest row up, and calls
  /// onHit(ray, hit, surface index, column, row) for every ray that hits.
  template <typename OnHit>
  void traceStrip(const StationGrid& grid, int strip, const ScanSettings& settings, OnHit&& onHit) const;
  /// Fills nodes_[node] with pieceOrder_[first .. first + count), halving it until leaves are small.
  void buildHierarchy(int node, int first, int count);

  std::vector<Surface> surfaces_;
  std::vector<Piece> pieces_;
  std::vector<int> pieceOrder_;
  std::vector<HierarchyNode> nodes_;
};

}  // namespace piperun::synth
