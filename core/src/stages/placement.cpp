// Stage 3 — cylinder placement (paper §5.1).
//
// A pipe along a principal direction a collapses, in the plane orthogonal to a, onto its
// cross-section circle, with every normal pointing radially. So two projected points and their
// normals fix a circle: the normal lines meet at the centre, and the two distances to it must agree.
//
// Pair selection decides what the method can see. Each stripe point draws partners among its
// projected neighbours at several scales (hash-grid cells stepping ×3 from minRadius to maxRadius,
// each confined to an axial slab): at the small scale a 1.5 cm pipe finds partners on its own
// circle even beside a 30 cm one, at the large scale the 30 cm pipe finds partners far enough apart
// for a well-conditioned intersection. Every point draws at every scale, so the work is linear in
// the stripe and a small pipe gets candidates in proportion to its points.
//
// The normals come from the projection too. Estimated in 3-D from k neighbours they are poor on
// small pipes far from the scanner (a neighbourhood then spans one or two scan lines), but in the
// plane all of a pipe's points lie on one arc; at each scale a point's normal is re-estimated from
// the arc through its projected neighbours when they form one.
//
// The candidates' modes in (cx, cy, r) are found by mean-shift with an anisotropic Gaussian kernel,
// seeded at the peaks of a 3-D histogram whose cells are the kernel's reach. A mode with enough
// candidates becomes a cylinder: its inliers (near the surface, normal radial) are refined by
// Gauss-Newton least squares on axis direction, axis point and radius, gathered again and refined
// again; on a noisy scan the inlier band then widens to the noise the inliers show. Then the fit
// must look like a pipe: no surface continuing just outside the inlier band (the faces beyond a box
// edge, whose smoothed normals mimic a small pipe), no systematic offset pattern around the axis (a
// square post), and a mode that holds many candidates per inlier (pairs of a real pipe agree on its
// circle; the faces of a corner agree on a ridge of circles). Where a real pipe's normals are poor for
// its curvature its candidates too spread along a ridge, which mean-shift splits into modes each
// short of the candidates asked; their fits converge on one cylinder, so such fits pool their
// candidates. Cylinders that share most inliers with a better supported one are dropped; every
// point then goes to the cylinder whose surface is closest, and cylinders left with too few
// inliers are dropped.
//
// Random draws come from generators seeded by (seed, direction, scale, cell), and parallel loops
// write by index, so the result does not depend on the thread count.

#include "piperun/stages/placement.h"

#include "angles.h"
#include "cell_table.h"
#include "random.h"
#include "sector_offsets.h"
#include "sort_by_key.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <tuple>
#include <utility>

namespace piperun {
namespace {

constexpr double kScaleStep = 3.0;        // ratio between neighbouring pair-selection scales
constexpr double kMinSlabLength = 0.3;    // axial extent of a pair-selection cell (m): short enough that
                                          // a direction 1° off smears a circle by only 5 mm
constexpr double kMinRadiusGap = 0.002;   // radius agreement floor (m), as documented in the params
constexpr double kKernelReach = 2.5;      // mean-shift kernel cut-off, in bandwidths
constexpr double kModeMergeDistance = 1.0;  // modes closer than this (in bandwidths) are one
constexpr double kMaxArcNormalScale = 0.15;  // largest pair-selection scale whose normals are re-estimated (m)
constexpr double kGatherCell = 0.05;      // 2-D cell of the inlier search grid (m)
constexpr double kMaxAxisTilt = 10.0 * kDegree;  // a refined axis farther than this from its direction
                                                 // was fitted to something that is not a pipe along it
constexpr double kDuplicateShare = 0.5;   // a cylinder sharing this share of its inliers is a copy
constexpr double kRadiusSlack = 0.8;     // a refined radius may leave [minRadius, maxRadius] by this factor
constexpr double kMinOutOfRound = 0.001;  // out-of-roundness always tolerated (m): noise on few points
constexpr int kMinSectorPoints = 10;       // a 10° sector counts in the out-of-roundness with this many inliers
constexpr double kBandOutOfRoundFactor = 2.0;  // all points in the band (other surfaces' too) may be this
                                               // many times as far out of round as the inliers...
constexpr int kMinBandSectorPoints = 5;   // ...in sectors of this many: a box edge seen by a few scan lines
constexpr double kShellReach = 2.5;       // outer edge of the shell tested beyond the inlier band, in bands
constexpr double kNoiseBands = 2.5;       // a noisy scan's inlier band, in standard deviations of its surface noise...
constexpr double kMaxBandFactor = 3.0;    // ...at most this many times inlierDistance...
constexpr double kMinWidening = 1.05;     // ...and taken only when wider than the band by this factor
constexpr int kMaxWidenings = 3;          // (the noise measured within a band grows with it)
constexpr double kJoinedShareFactor = 3.0;  // a circle short of minCandidates needs this many times the
                                            // candidates per inlier that minCandidateShare asks

// ---------------------------------------------------------------------------------------------
// A hash grid: items grouped by an integer cell key, a cell's items found in constant time.

constexpr std::int64_t kCellHalfRange = std::int64_t{1} << 20;  // 21 bits per coordinate

std::int64_t cellCoordinate(double value, double cellSize) {
  const double cell = std::floor(value / cellSize);
  const double limit = static_cast<double>(kCellHalfRange - 1);
  return static_cast<std::int64_t>(std::isfinite(cell) ? std::clamp(cell, -limit, limit) : 0.0);
}

std::uint64_t cellKey(std::int64_t x, std::int64_t y, std::int64_t z) {
  const auto field = [](std::int64_t c) { return static_cast<std::uint64_t>(c + kCellHalfRange); };
  return field(x) << 42 | field(y) << 21 | field(z);
}

std::array<std::int64_t, 3> cellCoordinates(std::uint64_t key) {
  constexpr std::uint64_t kMask = (std::uint64_t{1} << 21) - 1;
  return {static_cast<std::int64_t>((key >> 42) & kMask) - kCellHalfRange,
          static_cast<std::int64_t>((key >> 21) & kMask) - kCellHalfRange,
          static_cast<std::int64_t>(key & kMask) - kCellHalfRange};
}

class CellIndex {
 public:
  struct Range {
    const std::uint32_t* first = nullptr;
    const std::uint32_t* last = nullptr;
    const std::uint32_t* begin() const { return first; }
    const std::uint32_t* end() const { return last; }
    std::size_t size() const { return static_cast<std::size_t>(last - first); }
  };

  /// keys[i] is the cell of item i.
  explicit CellIndex(const std::vector<std::uint64_t>& keys) : cells_(groupByKey(sortedByKey(keys))) {
    cellOfKey_ = CellTable(cells_.keys.size());
    for (const std::uint64_t key : cells_.keys) cellOfKey_.insert(key);  // ids follow the (ascending) cells
  }

  std::size_t cellCount() const { return cells_.keys.size(); }
  std::uint64_t key(std::size_t cell) const { return cells_.keys[cell]; }

  /// (key, item) in (key, item) order. The cells of a stripe span a small box, so the keys, made
  /// compact over that box (each coordinate less its smallest, the same order), usually fit 33 bits:
  /// three passes of the radix sort.
  static std::vector<KeyedItem> sortedByKey(const std::vector<std::uint64_t>& keys) {
    constexpr std::uint64_t kField = (std::uint64_t{1} << 21) - 1;
    std::vector<KeyedItem> sorted(keys.size());
    std::array<std::uint64_t, 3> low{kField, kField, kField}, high{0, 0, 0};
    for (const std::uint64_t key : keys) {
      for (int f = 0; f < 3; ++f) {
        const std::uint64_t field = key >> (42 - 21 * f) & kField;
        low[f] = std::min(low[f], field);
        high[f] = std::max(high[f], field);
      }
    }
    std::array<int, 3> bits{};
    for (int f = 0; f < 3; ++f) {
      while (bits[f] < 21 && ((high[f] - low[f]) >> bits[f]) != 0) ++bits[f];
    }
    for (std::size_t i = 0; i < keys.size(); ++i) {
      const std::uint64_t key = keys[i];
      const std::uint64_t compact = ((key >> 42 & kField) - low[0]) << (bits[1] + bits[2]) |
                                    ((key >> 21 & kField) - low[1]) << bits[2] | ((key & kField) - low[2]);
      sorted[i] = {compact, static_cast<std::uint32_t>(i)};
    }
    stableSortByKey(sorted, keyOfItem);
    for (auto& entry : sorted) entry.first = keys[entry.second];
    return sorted;
  }
  Range items(std::size_t cell) const {
    return {cells_.items.data() + cells_.begins[cell], cells_.items.data() + cells_.begins[cell + 1]};
  }

  /// The items of the cell with `key` (empty when there is none).
  Range find(std::uint64_t key) const {
    const std::int64_t cell = cellOfKey_.find(key);
    return cell < 0 ? Range{} : items(static_cast<std::size_t>(cell));
  }

 private:
  KeyGroups cells_;       // item indices grouped by cell, cells in ascending key order
  CellTable cellOfKey_;   // key → cell
};

/// Splits [0, count) into fixed chunks (independent of the thread count) and runs them in parallel.
template <typename Body>
void forEachChunk(std::size_t count, std::size_t chunkSize, Body&& body) {
  const std::size_t chunks = (count + chunkSize - 1) / chunkSize;
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t chunk) {
    body(chunk, chunk * chunkSize, std::min(count, (chunk + 1) * chunkSize));
  });
}

template <typename T>
std::vector<T> concatenate(std::vector<std::vector<T>>& parts) {
  std::size_t total = 0;
  for (const auto& part : parts) total += part.size();
  std::vector<T> all;
  all.reserve(total);
  for (auto& part : parts) all.insert(all.end(), part.begin(), part.end());
  return all;
}

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

/// A unit vector orthogonal to `axis` (deterministic).
Eigen::Vector3d anyPerpendicular(const Eigen::Vector3d& axis) {
  Eigen::Index smallest = 0;
  axis.cwiseAbs().minCoeff(&smallest);
  return axis.cross(Eigen::Vector3d::Unit(smallest)).normalized();
}

// ---------------------------------------------------------------------------------------------
// The stripe in the direction's plane.

/// Normals in the plane estimated at one scale.
struct PlaneNormals {
  /// What a point's neighbourhood was: a tight cluster (a scan column seen end-on, whose normal
  /// only a wider neighbourhood across the next columns tells), or an arc curving like a pipe's.
  enum Shape : char { kOther = 0, kColumn, kCurvedArc };
  std::vector<Eigen::Vector2f> normals;
  std::vector<Shape> shapes;  // per point; empty when the normals were not estimated in the plane
};

struct StripeProjection {
  Eigen::Vector3d axis, u, v;
  std::vector<std::uint32_t> points;       // cloud indices
  std::vector<Eigen::Vector2f> positions;  // (p·u, p·v)
  std::vector<float> along;                // p·axis
  std::vector<Eigen::Vector2f> normals;    // unit projected 3-D normal; zero when too tilted to use
  float alongMin = 0.0f, alongMax = 0.0f;
  std::vector<double> scales;                            // pair-selection cell sizes
  std::vector<PlaneNormals> scaleNormals;  // normals in the plane estimated at each scale

  /// The scale whose normals are estimated over the widest neighbourhood (half a cell, see
  /// drawCandidates) that is about `radius` or smaller: wide enough to average the noise, not wider
  /// than the pipe's own arc.
  std::size_t normalScaleFor(double radius) const {
    constexpr double kSlack = 1.2;
    std::size_t best = 0;
    for (std::size_t s = 1; s < scales.size(); ++s) {
      if (0.5 * scales[s] <= kSlack * radius) best = s;
    }
    return best;
  }
};

StripeProjection projectStripe(const PointCloud& cloud, const PrincipalDirection& direction) {
  StripeProjection stripe;
  stripe.axis = direction.axis.normalized();
  stripe.u = anyPerpendicular(stripe.axis);
  stripe.v = stripe.axis.cross(stripe.u);
  const Eigen::Vector3f axis = stripe.axis.cast<float>(), u = stripe.u.cast<float>(), v = stripe.v.cast<float>();
  // A normal within 60° of the axis projects to less than half its length: its direction in the
  // plane is noise, so such a point needs the normal of the arc it lies on (see planeNormals).
  constexpr float kMinProjectedNormal = 0.5f;
  for (const std::uint32_t index : direction.stripe) {
    if (index >= cloud.size()) continue;
    const Eigen::Vector3f& p = cloud.positions[index];
    const Eigen::Vector3f& n = cloud.normals[index];
    const Eigen::Vector2f normal(n.dot(u), n.dot(v));
    const float length = normal.norm();
    stripe.points.push_back(index);
    stripe.positions.emplace_back(p.dot(u), p.dot(v));
    stripe.along.push_back(p.dot(axis));
    stripe.normals.push_back(length >= kMinProjectedNormal ? Eigen::Vector2f(normal / length) : Eigen::Vector2f::Zero());
  }
  if (!stripe.along.empty()) {
    const auto [low, high] = std::minmax_element(stripe.along.begin(), stripe.along.end());
    stripe.alongMin = *low;
    stripe.alongMax = *high;
  }
  return stripe;
}

// ---------------------------------------------------------------------------------------------
// Circle candidates.

struct Candidate {
  Eigen::Vector2f center;
  float radius;
};

struct CandidateLimits {
  double minRadius, maxRadius, agreement, minSine;
};

/// The circle through two projected points whose normals point at its centre, if the pair is usable.
std::optional<Candidate> circleThrough(const Eigen::Vector2d& pi, const Eigen::Vector2d& ni, const Eigen::Vector2d& pj,
                                       const Eigen::Vector2d& nj, const CandidateLimits& limits) {
  const double sine = cross2(ni, nj);
  if (std::abs(sine) < limits.minSine) return std::nullopt;
  // pi + ti ni = pj + tj nj; normals have arbitrary sign, so only |ti| and |tj| are distances.
  const Eigen::Vector2d d = pj - pi;
  const double ti = cross2(d, nj) / sine;
  const double tj = cross2(d, ni) / sine;
  const double radius = 0.5 * (std::abs(ti) + std::abs(tj));
  if (radius < limits.minRadius || radius > limits.maxRadius) return std::nullopt;
  if (std::abs(std::abs(ti) - std::abs(tj)) > std::max(kMinRadiusGap, limits.agreement * radius)) return std::nullopt;
  const Eigen::Vector2d center = pi + ti * ni;
  return Candidate{center.cast<float>(), static_cast<float>(radius)};
}

/// Pair-selection cell sizes from minRadius to maxRadius in steps of about kScaleStep: a partner in
/// the 3×3 cells around a point lies 0.3–2 cell sizes away, the chord range that suits r ≈ cell.
std::vector<double> pairScales(const PlacementParams& params) {
  const double ratio = std::max(1.0, params.maxRadius / params.minRadius);
  const int count = 1 + static_cast<int>(std::lround(std::log(ratio) / std::log(kScaleStep)));
  std::vector<double> scales;
  for (int k = 0; k < count; ++k) {
    scales.push_back(count == 1 ? params.minRadius : params.minRadius * std::pow(ratio, double(k) / (count - 1)));
  }
  return scales;
}

/// The stripe's points in cells of `cellSize` across the plane and `slab` along the axis, with
/// random draws among a cell's 3×3 neighbourhood in its slab.
class SlabGrid {
 public:
  SlabGrid(const StripeProjection& stripe, double cellSize, double slab)
      : stripe_(stripe), grid_(keys(stripe, cellSize, slab)) {}

  static constexpr std::size_t kCellsPerChunk = 256;
  std::size_t chunkCount() const { return (grid_.cellCount() + kCellsPerChunk - 1) / kCellsPerChunk; }

  /// The points of a cell and of its 3×3 neighbourhood in the slab (the cell included).
  struct Neighbourhood {
    std::size_t cell = 0;  // index of the cell, a stable key for its random draws
    CellIndex::Range points;
    const std::vector<std::uint32_t>* block = nullptr;       // the points of the 3×3 cells...
    const std::vector<Eigen::Vector2f>* positions = nullptr;  // ...and their positions, side by side

    /// A point of the neighbourhood drawn uniformly.
    std::uint32_t draw(Rng& rng) const {
      const std::uint64_t size = block->size();
      return (*block)[static_cast<std::size_t>(((rng.next() >> 32) * size) >> 32)];
    }
  };

  /// Calls body(chunk, neighbourhood) for every cell, in parallel over fixed chunks of cells.
  template <typename Body>
  void forEachCell(Body&& body) const {
    forEachChunk(grid_.cellCount(), kCellsPerChunk, [&](std::size_t chunk, std::size_t first, std::size_t last) {
      std::vector<std::uint32_t> block;
      std::vector<Eigen::Vector2f> positions;
      for (std::size_t cell = first; cell < last; ++cell) {
        const auto [x, y, z] = cellCoordinates(grid_.key(cell));
        block.clear();
        positions.clear();
        for (int k = 0; k < 9; ++k) {
          for (const std::uint32_t i : grid_.find(cellKey(x + k % 3 - 1, y + k / 3 - 1, z))) {
            block.push_back(i);
            positions.push_back(stripe_.positions[i]);
          }
        }
        body(chunk, Neighbourhood{cell, grid_.items(cell), &block, &positions});
      }
    });
  }

 private:
  static std::vector<std::uint64_t> keys(const StripeProjection& stripe, double cellSize, double slab) {
    std::vector<std::uint64_t> keys(stripe.points.size());
    for (std::size_t i = 0; i < keys.size(); ++i) {
      keys[i] = cellKey(cellCoordinate(stripe.positions[i].x(), cellSize), cellCoordinate(stripe.positions[i].y(), cellSize),
                        cellCoordinate(stripe.along[i], slab));
    }
    return keys;
  }

  const StripeProjection& stripe_;
  CellIndex grid_;
};

/// Normals in the plane from each point's projected neighbours within `radius`. A pipe along the
/// axis collapses onto its circle there, so its points form an arc even where the 3-D normals are
/// poor: far from the scanner a k-neighbourhood spans one or two scan lines and its PCA normal can
/// point anywhere around them (median errors of 30–60° on 1–5 cm pipes in generated scenes).
/// Where the neighbourhood is no arc (too few points, a blob, or a tight cluster of points that
/// share their angle and differ only by noise) the projected 3-D normal stays, and so does a
/// projected normal within 15° of the arc's (it averages over more points). Over two scan columns
/// the chord's normal is taken, half their angle off each. Each point's neighbourhood is marked a
/// column (a cluster of enough points that is no arc: a scan column seen end-on) or a curved arc
/// (one that took the parabola's slope), for InlierSearch::gather.
PlaneNormals planeNormals(const StripeProjection& stripe, const SlabGrid& grid, double radius) {
  constexpr std::size_t kNeighbours = 24;  // at most this many of the block are tried, evenly strided
  constexpr int kMinNeighbours = 5;
  constexpr double kMaxFlatness = 0.25;    // smaller / larger eigenvalue: an arc, not a blob
  constexpr double kMinExtent = 0.2;       // standard deviation along the arc, in radii: not a cluster
  // Determinant of the scaled moments below which no parabola is fitted: about 0.5 over three scan
  // columns and 0.8 over a dense arc, but 0.02–0.06 over two columns, two clusters through which
  // any parabola passes (its slope there turns the outer columns of a thin far pipe tangent).
  constexpr double kMinSpread = 0.1;
  constexpr double kMinCurvatureRadius = 1.5;  // an arc curving tighter than this many radii takes the parabola's slope
  const double keepCos = std::cos(15.0 * kDegree);
  PlaneNormals estimated{stripe.normals, std::vector<PlaneNormals::Shape>(stripe.points.size(), PlaneNormals::kOther)};
  std::vector<Eigen::Vector2f>& normals = estimated.normals;
  grid.forEachCell([&](std::size_t, const SlabGrid::Neighbourhood& neighbourhood) {
    const std::vector<Eigen::Vector2f>& block = *neighbourhood.positions;
    const std::size_t stride = (block.size() + kNeighbours - 1) / kNeighbours;
    std::array<Eigen::Vector2d, kNeighbours> near;
    for (const std::uint32_t i : neighbourhood.points) {
      const Eigen::Vector2d center = stripe.positions[i].cast<double>();
      Eigen::Vector2d mean = Eigen::Vector2d::Zero();
      int count = 0;
      // At most kNeighbours are visited; each is written and kept only when within the radius
      // (branch-free: whether a neighbour is near is unpredictable).
      for (std::size_t k = i % stride; k < block.size(); k += stride) {
        const Eigen::Vector2d d = block[k].cast<double>() - center;
        near[count] = d;
        count += d.squaredNorm() <= radius * radius;
      }
      if (count < kMinNeighbours) continue;
      for (int k = 0; k < count; ++k) mean += near[k];
      mean /= count;
      Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();
      for (int k = 0; k < count; ++k) covariance += (near[k] - mean) * (near[k] - mean).transpose();
      covariance /= count;
      const double half = 0.5 * (covariance(0, 0) - covariance(1, 1));
      const double spread = std::sqrt(half * half + covariance(0, 1) * covariance(0, 1));
      const double middle = 0.5 * (covariance(0, 0) + covariance(1, 1));
      const double major = middle + spread, minor = middle - spread;
      if (minor > kMaxFlatness * major || major < kMinExtent * kMinExtent * radius * radius) {
        estimated.shapes[i] = PlaneNormals::kColumn;
        continue;
      }
      // The major axis at half the angle of (half, covariance(0, 1)); spread > 0 here (an isotropic
      // blob failed the flatness test), so the half-angle formulas need no trigonometry.
      const double cosDouble = half / spread;
      const Eigen::Vector2d tangent(std::sqrt(0.5 * (1.0 + cosDouble)),
                                    std::copysign(std::sqrt(std::max(0.0, 0.5 * (1.0 - cosDouble))), covariance(0, 1)));
      const Eigen::Vector2d across(-tangent.y(), tangent.x());
      // A neighbourhood that wraps round a circle smaller than itself has a lopsided PCA line,
      // wrong by up to half the arc it covers there; a parabola n = a + b t + c t² in the principal
      // frame (t scaled to unit spread) then gives the slope at the point itself. Elsewhere the
      // line is kept: its direction is less noisy than the parabola's slope.
      const double unit = std::sqrt(major);
      const double perUnit = 1.0 / unit;
      // Sums of t^0..t^4 and of w, t w, t² w (scalars: an Eigen outer product per point went
      // through memory in the loop).
      double t1 = 0.0, t2 = 0.0, t3 = 0.0, t4 = 0.0, w0 = 0.0, w1 = 0.0, w2 = 0.0;
      for (int k = 0; k < count; ++k) {
        const double t = (near[k] - mean).dot(tangent) * perUnit;
        const double tt = t * t;
        const double w = (near[k] - mean).dot(across) * perUnit;
        t1 += t;
        t2 += tt;
        t3 += t * tt;
        t4 += tt * tt;
        w0 += w;
        w1 += t * w;
        w2 += tt * w;
      }
      // The normal equations [[n, t1, t2], [t1, t2, t3], [t2, t3, t4]] (b0, b1, b2) = (w0, w1, w2),
      // solved by their cofactors (symmetric): only b1 and b2 are needed.
      const auto n = static_cast<double>(count);
      const double c11 = t2 * t4 - t3 * t3, c12 = t2 * t3 - t1 * t4, c13 = t1 * t3 - t2 * t2;
      const double c22 = n * t4 - t2 * t2, c23 = t1 * t2 - n * t3, c33 = n * t2 - t1 * t1;
      const double determinant = n * c11 + t1 * c12 + t2 * c13;
      double slope = 0.0;
      if (determinant > kMinSpread * n * n * n) {
        const double b1 = (c12 * w0 + c22 * w1 + c23 * w2) / determinant;
        const double b2 = (c13 * w0 + c23 * w1 + c33 * w2) / determinant;
        const double curvature = 2.0 * std::abs(b2) / unit;
        if (curvature * kMinCurvatureRadius * radius > 1.0) {
          slope = b1 + 2.0 * b2 * (-mean.dot(tangent) / unit);
          estimated.shapes[i] = PlaneNormals::kCurvedArc;
        }
      }
      const Eigen::Vector2f normal = (across - slope * tangent).normalized().cast<float>();
      if (std::abs(normal.dot(stripe.normals[i])) < keepCos) normals[i] = normal;
    }
  });
  return estimated;
}

/// Candidates from pairs drawn at one scale: the cells are `cellSize` across, the normals are
/// estimated over half of that (a fraction of the radii this scale serves). Returns the normals.
PlaneNormals drawCandidates(const StripeProjection& stripe, std::size_t scaleIndex, double cellSize,
                            const PlacementParams& params, const CandidateLimits& limits, std::uint64_t seed,
                            std::uint64_t directionIndex, std::vector<Candidate>& out) {
  const SlabGrid grid(stripe, cellSize, std::max(kMinSlabLength, 2.0 * cellSize));
  // Pipes this large keep good 3-D normals (a median error of 2° above 6 cm radius in generated
  // scenes), and their large neighbourhoods are the costliest to fit.
  PlaneNormals estimated =
      cellSize <= kMaxArcNormalScale ? planeNormals(stripe, grid, 0.5 * cellSize) : PlaneNormals{stripe.normals, {}};
  const std::vector<Eigen::Vector2f>& normals = estimated.normals;
  std::vector<std::vector<Candidate>> parts(grid.chunkCount());
  grid.forEachCell([&](std::size_t chunk, const SlabGrid::Neighbourhood& neighbourhood) {
    Rng rng(seed, {directionIndex, scaleIndex, neighbourhood.cell});
    std::vector<Candidate>& found = parts[chunk];
    for (const std::uint32_t i : neighbourhood.points) {
      if (normals[i].isZero()) continue;
      for (int draw = 0; draw < params.pairsPerPoint; ++draw) {
        const std::uint32_t j = neighbourhood.draw(rng);
        if (j == i || normals[j].isZero()) continue;
        if (const auto candidate = circleThrough(stripe.positions[i].cast<double>(), normals[i].cast<double>(),
                                                 stripe.positions[j].cast<double>(), normals[j].cast<double>(), limits)) {
          found.push_back(*candidate);
        }
      }
    }
  });
  std::vector<Candidate> all = concatenate(parts);
  out.insert(out.end(), all.begin(), all.end());
  return estimated;
}

// ---------------------------------------------------------------------------------------------
// Mean-shift in (cx, cy, r), in units of the bandwidths.

struct Mode {
  Eigen::Vector3d at;  // (cx, cy, r): in bandwidths while searching, in metres in ModeSearch::circles
  double density = 0.0;
  int support = 0;
};

struct ModeSearch {
  std::vector<Mode> circles;      // modes with at least minCircleCandidates() candidates
  std::vector<int> candidateMode; // index into circles, -1 for none
};

/// The fewest candidates a circle's mode may hold: those with fewer than minCandidates make pipes
/// that must take a joint.
int minCircleCandidates(const PlacementParams& params) {
  return params.minJoinedCandidates > 0 ? std::min(params.minCandidates, params.minJoinedCandidates) : params.minCandidates;
}

/// The fewest inliers a cylinder may keep: those with fewer than minInliers make pipes that must
/// take a joint.
int minCylinderInliers(const PlacementParams& params) {
  return params.minJoinedInliers > 0 ? std::min(params.minInliers, params.minJoinedInliers) : params.minInliers;
}

ModeSearch findModes(const std::vector<Candidate>& candidates, const PlacementParams& params) {
  ModeSearch search;
  search.candidateMode.assign(candidates.size(), -1);
  if (candidates.empty()) return search;
  const Eigen::Vector3d scale(1.0 / params.centerBandwidth, 1.0 / params.centerBandwidth, 1.0 / params.radiusBandwidth);
  std::vector<Eigen::Vector3d> scaled(candidates.size());
  std::vector<std::uint64_t> keys(candidates.size());
  const auto keyOf = [](const Eigen::Vector3d& x) {
    return cellKey(cellCoordinate(x.x(), kKernelReach), cellCoordinate(x.y(), kKernelReach), cellCoordinate(x.z(), kKernelReach));
  };
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    scaled[i] = Eigen::Vector3d(candidates[i].center.x(), candidates[i].center.y(), candidates[i].radius).cwiseProduct(scale);
    keys[i] = keyOf(scaled[i]);
  }
  const CellIndex grid(keys);
  // Visits the candidates of the 27 cells around x (all within the kernel's reach of x among them).
  const auto forNeighbours = [&](const Eigen::Vector3d& x, auto&& visit) {
    const auto [cx, cy, cz] = cellCoordinates(keyOf(x));
    for (int k = 0; k < 27; ++k) {
      for (const std::uint32_t i : grid.find(cellKey(cx + k % 3 - 1, cy + (k / 3) % 3 - 1, cz + k / 9 - 1))) visit(i);
    }
  };

  // Seeds: histogram cells holding at least as many candidates as each of their 26 neighbours.
  const std::size_t seedMin = static_cast<std::size_t>(std::max(3, minCircleCandidates(params) / 5));
  constexpr std::size_t kCellsPerChunk = 1024;
  std::vector<std::vector<Eigen::Vector3d>> seedParts((grid.cellCount() + kCellsPerChunk - 1) / kCellsPerChunk);
  forEachChunk(grid.cellCount(), kCellsPerChunk, [&](std::size_t chunk, std::size_t first, std::size_t last) {
    for (std::size_t cell = first; cell < last; ++cell) {
      const std::size_t count = grid.items(cell).size();
      if (count < seedMin) continue;
      const auto [x, y, z] = cellCoordinates(grid.key(cell));
      bool peak = true;
      for (int k = 0; k < 27 && peak; ++k) {
        const std::uint64_t other = cellKey(x + k % 3 - 1, y + (k / 3) % 3 - 1, z + k / 9 - 1);
        const std::size_t otherCount = grid.find(other).size();
        peak = otherCount < count || (otherCount == count && other >= grid.key(cell));
      }
      if (!peak) continue;
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      for (const std::uint32_t i : grid.items(cell)) mean += scaled[i];
      seedParts[chunk].push_back(mean / static_cast<double>(count));
    }
  });
  const std::vector<Eigen::Vector3d> seeds = concatenate(seedParts);

  // Gaussian mean-shift from every seed.
  constexpr int kMaxShifts = 100;
  constexpr double kConverged = 1e-3;
  const double reach2 = kKernelReach * kKernelReach;
  std::vector<Mode> modes(seeds.size());
  tbb::parallel_for(std::size_t{0}, seeds.size(), [&](std::size_t s) {
    Eigen::Vector3d x = seeds[s];
    double density = 0.0;
    for (int shift = 0; shift < kMaxShifts; ++shift) {
      Eigen::Vector3d weighted = Eigen::Vector3d::Zero();
      density = 0.0;
      forNeighbours(x, [&](std::uint32_t i) {
        const double d2 = (scaled[i] - x).squaredNorm();
        if (d2 >= reach2) return;
        const double w = std::exp(-0.5 * d2);
        weighted += w * scaled[i];
        density += w;
      });
      if (density <= 0.0) break;
      const Eigen::Vector3d next = weighted / density;
      const double moved = (next - x).norm();
      x = next;
      if (moved < kConverged) break;
    }
    modes[s] = Mode{x, density, 0};
  });

  // Merge modes that converged to the same place, densest first.
  std::vector<std::size_t> order(modes.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return modes[a].density > modes[b].density; });
  std::vector<Mode> kept;
  for (const std::size_t m : order) {
    const bool duplicate = std::any_of(kept.begin(), kept.end(), [&](const Mode& k) {
      return (k.at - modes[m].at).norm() < kModeMergeDistance;
    });
    if (!duplicate && modes[m].density > 0.0) kept.push_back(modes[m]);
  }

  // Each candidate within the kernel's reach of a mode belongs to the nearest such mode.
  std::vector<double> nearest(candidates.size(), reach2);
  std::vector<int> owner(candidates.size(), -1);
  for (std::size_t m = 0; m < kept.size(); ++m) {
    forNeighbours(kept[m].at, [&](std::uint32_t i) {
      const double d2 = (scaled[i] - kept[m].at).squaredNorm();
      if (d2 < nearest[i]) {
        nearest[i] = d2;
        owner[i] = static_cast<int>(m);
      }
    });
  }
  for (const int m : owner) {
    if (m >= 0) ++kept[m].support;
  }
  std::vector<int> circleOf(kept.size(), -1);
  for (std::size_t m = 0; m < kept.size(); ++m) {
    if (kept[m].support < minCircleCandidates(params)) continue;
    circleOf[m] = static_cast<int>(search.circles.size());
    Mode circle = kept[m];
    circle.at = circle.at.cwiseQuotient(scale);
    search.circles.push_back(circle);
  }
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    if (owner[i] >= 0) search.candidateMode[i] = circleOf[owner[i]];
  }
  return search;
}

// ---------------------------------------------------------------------------------------------
// Inliers and least-squares refinement.

struct CylinderFit {
  Eigen::Vector3d point, direction;  // relative to the cloud origin; unit direction
  double radius = 0.0;
};

/// Signed distance of p to the surface and the unit radial direction at p (zero on the axis).
std::pair<double, Eigen::Vector3d> surfaceOffset(const CylinderFit& fit, const Eigen::Vector3d& p) {
  const Eigen::Vector3d q = p - fit.point;
  const Eigen::Vector3d radial = q - q.dot(fit.direction) * fit.direction;
  const double distance = radial.norm();
  if (distance <= 0.0) return {-fit.radius, Eigen::Vector3d::Zero()};
  return {distance - fit.radius, radial / distance};
}

class InlierSearch {
 public:
  InlierSearch(const PointCloud& cloud, const StripeProjection& stripe, const PlacementParams& params)
      : cloud_(cloud), stripe_(stripe), params_(params), minNormalCos_(std::cos(params.inlierNormalAngleDeg * kDegree)),
        grid_(gridKeys(stripe)) {}

  /// Stripe points (indices into the stripe) within `band` of the surface whose normal in the plane is
  /// radial, or for a column's point whose normal across the columns beside it is, ascending.
  /// `acrossColumns` counts those taken for the latter alone.
  std::vector<std::uint32_t> gather(const CylinderFit& fit, double band, std::size_t& acrossColumns) const {
    std::vector<std::uint32_t> inliers;
    acrossColumns = 0;
    const std::size_t scale = stripe_.normalScaleFor(fit.radius);
    const PlaneNormals& estimated = stripe_.scaleNormals[scale];
    // A scan column's point may take the normal of the wider neighbourhood across the next columns
    // when that curves like a pipe: a thin pipe seen in a few columns has no other. Not in a band
    // widened for a noisy scan, whose columns are blobs of noise.
    const bool widerNormals = band <= params_.inlierDistance && scale + 1 < stripe_.scaleNormals.size() &&
                              !estimated.shapes.empty() && !stripe_.scaleNormals[scale + 1].shapes.empty();
    const PlaneNormals* wider = widerNormals ? &stripe_.scaleNormals[scale + 1] : nullptr;
    visitNear(fit, band, [&](std::uint32_t i, double offset, const Eigen::Vector3d& radial) {
      if (std::abs(offset) >= band) return;
      const Eigen::Vector2d inPlane(radial.dot(stripe_.u), radial.dot(stripe_.v));
      const auto radialNormal = [&](const Eigen::Vector2f& normal) {
        return std::abs(normal.cast<double>().dot(inPlane)) >= minNormalCos_;
      };
      if (radialNormal(estimated.normals[i])) {
        inliers.push_back(i);
      } else if (wider && estimated.shapes[i] == PlaneNormals::kColumn && wider->shapes[i] == PlaneNormals::kCurvedArc &&
                 radialNormal(wider->normals[i])) {
        inliers.push_back(i);
        ++acrossColumns;
      }
    });
    std::sort(inliers.begin(), inliers.end());
    return inliers;
  }

  /// What lies around a fit between its inliers' axial extremes (stripe indices).
  struct Surroundings {
    std::size_t shell = 0;             ///< Points just outside the inlier band (up to kShellReach bands off
                                       ///< the surface): the faces that continue past a box edge.
    std::vector<std::uint32_t> inBand;  ///< Points within the band whatever their normals, ascending: the
                                        ///< whole arc the scanner saw.
  };

  Surroundings surroundings(const CylinderFit& fit, const std::vector<std::uint32_t>& inliers, double band) const {
    const auto [low, high] = axialRange(fit, inliers);
    Surroundings around;
    visitNear(fit, kShellReach * band, [&](std::uint32_t i, double offset, const Eigen::Vector3d&) {
      const double along = alongAxis(fit, i);
      if (along < low || along > high) return;
      if (offset >= band) {
        ++around.shell;
      } else if (offset > -band) {
        around.inBand.push_back(i);
      }
    });
    std::sort(around.inBand.begin(), around.inBand.end());
    return around;
  }

 private:
  double alongAxis(const CylinderFit& fit, std::uint32_t i) const {
    return (cloud_.positions[stripe_.points[i]].cast<double>() - fit.point).dot(fit.direction);
  }

  std::pair<double, double> axialRange(const CylinderFit& fit, const std::vector<std::uint32_t>& inliers) const {
    double low = std::numeric_limits<double>::infinity(), high = -low;
    for (const std::uint32_t i : inliers) {
      const double along = alongAxis(fit, i);
      low = std::min(low, along);
      high = std::max(high, along);
    }
    return {low, high};
  }

  /// Calls visit(stripe index, surface offset, unit radial direction) for the stripe points in the
  /// grid cells that the cylinder's trace, grown by `reach`, touches.
  template <typename Visit>
  void visitNear(const CylinderFit& fit, double reach, Visit&& visit) const {
    // The trace in the plane: the cross-section slides along the projected axis over the stripe's
    // axial range (it stays put when the axis is the direction itself).
    const Eigen::Vector3d& axis = stripe_.axis;
    const double cosTilt = std::abs(fit.direction.dot(axis));
    const Eigen::Vector3d direction = fit.direction.dot(axis) >= 0.0 ? fit.direction : Eigen::Vector3d(-fit.direction);
    const double extent = fit.radius / cosTilt + reach;
    Eigen::Vector2d low = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector2d high = -low;
    for (const double along : {double(stripe_.alongMin), double(stripe_.alongMax)}) {
      const Eigen::Vector3d center = fit.point + (along - fit.point.dot(axis)) / cosTilt * direction;
      const Eigen::Vector2d projected(center.dot(stripe_.u), center.dot(stripe_.v));
      low = low.cwiseMin(projected);
      high = high.cwiseMax(projected);
    }
    const std::int64_t x0 = cellCoordinate(low.x() - extent, kGatherCell), x1 = cellCoordinate(high.x() + extent, kGatherCell);
    const std::int64_t y0 = cellCoordinate(low.y() - extent, kGatherCell), y1 = cellCoordinate(high.y() + extent, kGatherCell);
    for (std::int64_t x = x0; x <= x1; ++x) {
      for (std::int64_t y = y0; y <= y1; ++y) {
        for (const std::uint32_t i : grid_.find(cellKey(x, y, 0))) {
          const auto [offset, radial] = surfaceOffset(fit, cloud_.positions[stripe_.points[i]].cast<double>());
          if (std::abs(offset) <= reach) visit(i, offset, radial);
        }
      }
    }
  }

  static std::vector<std::uint64_t> gridKeys(const StripeProjection& stripe) {
    std::vector<std::uint64_t> keys(stripe.points.size());
    for (std::size_t i = 0; i < keys.size(); ++i) {
      keys[i] = cellKey(cellCoordinate(stripe.positions[i].x(), kGatherCell), cellCoordinate(stripe.positions[i].y(), kGatherCell), 0);
    }
    return keys;
  }

  const PointCloud& cloud_;
  const StripeProjection& stripe_;
  const PlacementParams& params_;
  double minNormalCos_;
  CellIndex grid_;
};

/// refineCylinderFit() on the stripe points `inliers` (indices into the stripe).
bool refineFit(CylinderFit& fit, const PointCloud& cloud, const StripeProjection& stripe, const std::vector<std::uint32_t>& inliers,
               int iterations) {
  std::vector<Eigen::Vector3d> points(inliers.size());
  for (std::size_t k = 0; k < inliers.size(); ++k) points[k] = cloud.positions[stripe.points[inliers[k]]].cast<double>();
  return refineCylinderFit(points, fit.point, fit.direction, fit.radius, iterations);
}

/// Standard deviation of the inliers' surface offsets, from their median absolute value (robust to the
/// few points of other surfaces that pass the inlier test).
double robustNoise(const CylinderFit& fit, const PointCloud& cloud, const StripeProjection& stripe,
                   const std::vector<std::uint32_t>& inliers) {
  if (inliers.empty()) return 0.0;
  std::vector<double> offsets(inliers.size());
  for (std::size_t k = 0; k < inliers.size(); ++k) {
    offsets[k] = std::abs(surfaceOffset(fit, cloud.positions[stripe.points[inliers[k]]].cast<double>()).first);
  }
  const auto middle = offsets.begin() + static_cast<std::ptrdiff_t>(offsets.size() / 2);
  std::nth_element(offsets.begin(), middle, offsets.end());
  return 1.4826 * *middle;  // the median absolute deviation of a normal distribution is 0.6745 σ
}

/// How far the inliers' surface offsets vary systematically around the axis (m): the RMS of the
/// mean offsets in the 10° sectors holding `minSectorPoints` (the worst sector left out), less what
/// the noise alone would give.
/// A circle fitted to a square post or beam leaves its corners outside and its faces inside
/// (2–4 mm for a 5 cm post with 2 mm noise in generated scenes); a pipe leaves only noise (below
/// 0.4 mm for 95 % of them).
double outOfRoundness(const CylinderFit& fit, const PointCloud& cloud, const StripeProjection& stripe,
                      const std::vector<std::uint32_t>& inliers, int minSectorPoints) {
  const Eigen::Vector3d b1 = anyPerpendicular(fit.direction);
  const Eigen::Vector3d b2 = fit.direction.cross(b1);
  SectorOffsets offsets;
  for (const std::uint32_t i : inliers) {
    const Eigen::Vector3d q = cloud.positions[stripe.points[i]].cast<double>() - fit.point;
    const Eigen::Vector3d radial = q - q.dot(fit.direction) * fit.direction;
    offsets.add(std::atan2(radial.dot(b2), radial.dot(b1)), radial.norm() - fit.radius);
  }
  return offsets.outOfRoundness(minSectorPoints);
}

std::size_t sharedCount(const std::vector<std::uint32_t>& a, const std::vector<std::uint32_t>& b) {
  std::size_t shared = 0;
  for (auto i = a.begin(), j = b.begin(); i != a.end() && j != b.end();) {
    if (*i < *j) {
      ++i;
    } else if (*j < *i) {
      ++j;
    } else {
      ++shared, ++i, ++j;
    }
  }
  return shared;
}

// ---------------------------------------------------------------------------------------------
// One direction.

struct DirectionOutcome {
  PlacementResult::Projection projection;
  std::vector<int> candidateMode;  // per candidate: index into the modes, -1 for none
  std::vector<Cylinder> fits;      // refined, inliers as cloud indices (ascending)
  std::vector<Eigen::Vector3d> fitCircles;  // per fit: its mode's (cx, cy, r) in the plane
  std::vector<char> fitPooled;     // per fit: taken from pooled short modes (see pooledShortModes)
  std::vector<int> modeFit;        // per mode: index into fits, -1 when its fit failed
  std::size_t projectedPoints = 0;
  std::size_t circles = 0;
};

/// Whether a circle's candidates (`support`) make a cylinder of `inliers`: a weakly supported
/// circle is taken only on a clean scan (an unwidened band), and where its candidates are dense for
/// its inliers: noise, outliers and the faces of posts make modes of their own, their candidates
/// spread thin over many points.
bool wellSupported(int support, bool widened, std::size_t inliers, const PlacementParams& params) {
  return support >= params.minCandidates ||
         (!widened && support >= kJoinedShareFactor * params.minCandidateShare * static_cast<double>(inliers));
}

/// A fit whose mode alone held too few candidates (see wellSupported).
struct ShortFit {
  Cylinder cylinder;
  bool widened = false;
};

/// Where a pipe's normals are poor for its curvature (a wide pipe seen as a few scan columns), its
/// pairs' normal lines meet along a ridge of circles through the true one, and mean-shift splits
/// the ridge into several modes, each short of the candidates asked, whose fits converge on the
/// same cylinder. Such fits that share most inliers pool their candidates, and the best supported
/// of them is taken (into `fitted`, at its mode) when the pool makes it well supported and no fit
/// already taken along the direction holds most of its inliers. Returns, per mode, the mode whose
/// fit took its candidates so (itself for that mode; -1 for none).
std::vector<int> pooledShortModes(std::vector<std::optional<ShortFit>>& shortFits, const PlacementParams& params,
                                  std::vector<std::optional<Cylinder>>& fitted) {
  std::vector<std::size_t> order;
  for (std::size_t m = 0; m < shortFits.size(); ++m) {
    if (shortFits[m]) order.push_back(m);
  }
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return shortFits[a]->cylinder.candidates > shortFits[b]->cylinder.candidates;
  });
  const auto copies = [](const Cylinder& a, const Cylinder& b) {
    return sharedCount(a.inliers, b.inliers) >= kDuplicateShare * static_cast<double>(std::min(a.inliers.size(), b.inliers.size()));
  };
  std::vector<std::size_t> leaders;
  std::vector<std::size_t> leaderOf(shortFits.size(), 0);
  std::vector<int> pooled(shortFits.size(), 0);
  for (const std::size_t m : order) {
    const Cylinder& fit = shortFits[m]->cylinder;
    const auto leader = std::find_if(leaders.begin(), leaders.end(),
                                     [&](std::size_t l) { return copies(shortFits[l]->cylinder, fit); });
    leaderOf[m] = leader == leaders.end() ? m : *leader;
    if (leaderOf[m] == m) leaders.push_back(m);
    pooled[leaderOf[m]] += fit.candidates;
  }
  std::vector<char> taken(shortFits.size(), 0);
  for (const std::size_t l : leaders) {
    if (pooled[l] == shortFits[l]->cylinder.candidates) continue;  // no mode of its own pooled with it
    Cylinder& fit = shortFits[l]->cylinder;
    if (!wellSupported(pooled[l], shortFits[l]->widened, fit.inliers.size(), params)) continue;
    if (std::any_of(fitted.begin(), fitted.end(), [&](const std::optional<Cylinder>& other) {
          return other && copies(*other, fit);
        })) {
      continue;
    }
    fit.candidates = pooled[l];
    fitted[l] = std::move(fit);
    taken[l] = 1;
  }
  std::vector<int> pooledInto(shortFits.size(), -1);
  for (const std::size_t m : order) {
    if (taken[leaderOf[m]]) pooledInto[m] = static_cast<int>(leaderOf[m]);
  }
  return pooledInto;
}

DirectionOutcome placeAlongDirection(const PointCloud& cloud, const PrincipalDirection& direction, std::size_t directionIndex,
                                     const PlacementParams& params, std::uint64_t seed, Progress& progress) {
  DirectionOutcome outcome;
  StripeProjection stripe = projectStripe(cloud, direction);
  outcome.projection.axis = stripe.axis;
  outcome.projection.u = stripe.u;
  outcome.projection.v = stripe.v;
  outcome.projectedPoints = stripe.points.size();

  const CandidateLimits limits{params.minRadius, params.maxRadius, params.radiusAgreement,
                               std::sin(params.minPairAngleDeg * kDegree)};
  std::vector<Candidate> candidates;
  stripe.scales = pairScales(params);
  for (std::size_t s = 0; s < stripe.scales.size(); ++s) {
    stripe.scaleNormals.push_back(drawCandidates(stripe, s, stripe.scales[s], params, limits, seed, directionIndex, candidates));
  }
  progress.checkCancelled();

  const ModeSearch modes = findModes(candidates, params);
  outcome.circles = modes.circles.size();
  progress.checkCancelled();

  const InlierSearch search(cloud, stripe, params);
  std::vector<std::optional<Cylinder>> fitted(modes.circles.size());
  std::vector<std::optional<ShortFit>> shortFits(modes.circles.size());
  tbb::parallel_for(std::size_t{0}, modes.circles.size(), [&](std::size_t m) {
    const Mode& mode = modes.circles[m];
    CylinderFit fit;
    fit.direction = stripe.axis;
    fit.point = mode.at.x() * stripe.u + mode.at.y() * stripe.v + 0.5 * double(stripe.alongMin + stripe.alongMax) * stripe.axis;
    fit.radius = mode.at.z();
    double band = params.inlierDistance;
    std::size_t acrossColumns = 0;  // inliers taken for their normal across scan columns alone
    std::vector<std::uint32_t> inliers = search.gather(fit, band, acrossColumns);
    // A mode far short of the candidate share (checked on the final inliers below) is not worth
    // refining: the fits of such ridge modes are most of the refinement work.
    if (mode.support < 0.5 * params.minCandidateShare * static_cast<double>(inliers.size())) return;
    // Refines the fit on its inliers and gathers them again; false when it is no pipe along the direction.
    const auto refineAndGather = [&] {
      if (static_cast<int>(inliers.size()) < minCylinderInliers(params)) return false;
      if (!refineFit(fit, cloud, stripe, inliers, params.refineIterations)) return false;
      if (std::abs(fit.direction.dot(stripe.axis)) < std::cos(kMaxAxisTilt)) return false;
      if (fit.radius < kRadiusSlack * params.minRadius || fit.radius > params.maxRadius / kRadiusSlack) return false;
      inliers = search.gather(fit, band, acrossColumns);
      return true;
    };
    for (int pass = 0; pass < 2; ++pass) {
      if (!refineAndGather()) return;
    }
    // On a noisy scan the band cuts off the tails of the surface's noise: widen it to the noise the
    // inliers show (measured within the band, so an estimate that grows as the band does).
    for (int widening = 0; widening < kMaxWidenings; ++widening) {
      const double noise = robustNoise(fit, cloud, stripe, inliers);
      const double noiseBand = std::min(kMaxBandFactor * params.inlierDistance, kNoiseBands * noise);
      if (noiseBand <= kMinWidening * band) break;
      band = noiseBand;
      inliers = search.gather(fit, band, acrossColumns);
      if (!refineAndGather()) return;
    }
    if (static_cast<int>(inliers.size()) < minCylinderInliers(params)) return;
    // A mode too weakly supported alone may still be one of several that a pipe's candidates split
    // into (see pooledShortModes): its fit is kept aside.
    const bool widened = band > params.inlierDistance;
    const bool supported = wellSupported(mode.support, widened, inliers.size(), params);
    const InlierSearch::Surroundings around = search.surroundings(fit, inliers, band);
    if (static_cast<double>(around.shell) > params.maxShellShare * static_cast<double>(inliers.size())) return;
    // A fit that needs normals across scan columns has its shape from those few columns, which are
    // what a square post shows as well: it gets no allowance for noise on few points (gather takes
    // no such normals in a band widened for a noisy scan, whose columns are blobs that need it).
    const double maxOutOfRound = std::max(acrossColumns > 0 ? 0.0 : kMinOutOfRound, params.maxOutOfRound * fit.radius);
    if (outOfRoundness(fit, cloud, stripe, inliers, kMinSectorPoints) > maxOutOfRound) return;
    // The inliers' normals agree with the circle, and over two scan columns a chord's normal does
    // at a box's corner or a square post's as well: over every point in the band, a corner sticks
    // out and the faces fall in.
    if (outOfRoundness(fit, cloud, stripe, around.inBand, kMinBandSectorPoints) > kBandOutOfRoundFactor * maxOutOfRound) {
      return;
    }
    Cylinder cylinder;
    cylinder.point = fit.point;
    cylinder.direction = fit.direction.dot(stripe.axis) >= 0.0 ? fit.direction : Eigen::Vector3d(-fit.direction);
    cylinder.radius = fit.radius;
    cylinder.candidates = mode.support;
    cylinder.directionIndex = static_cast<int>(directionIndex);
    cylinder.inliers.reserve(inliers.size());
    for (const std::uint32_t i : inliers) cylinder.inliers.push_back(stripe.points[i]);
    std::sort(cylinder.inliers.begin(), cylinder.inliers.end());
    if (supported) {
      fitted[m] = std::move(cylinder);
    } else {
      shortFits[m] = ShortFit{std::move(cylinder), widened};
    }
  });
  const std::vector<int> pooledInto = pooledShortModes(shortFits, params, fitted);

  outcome.modeFit.assign(modes.circles.size(), -1);
  for (std::size_t m = 0; m < fitted.size(); ++m) {
    if (!fitted[m]) continue;
    outcome.modeFit[m] = static_cast<int>(outcome.fits.size());
    outcome.fits.push_back(std::move(*fitted[m]));
    outcome.fitCircles.push_back(modes.circles[m].at);
    outcome.fitPooled.push_back(pooledInto[m] >= 0);
  }
  // A pooled mode's candidates went to its leader's fit.
  for (std::size_t m = 0; m < fitted.size(); ++m) {
    if (pooledInto[m] >= 0) outcome.modeFit[m] = outcome.modeFit[static_cast<std::size_t>(pooledInto[m])];
  }
  outcome.projection.candidates.resize(candidates.size());
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    outcome.projection.candidates[i] = CircleCandidate{candidates[i].center, candidates[i].radius, -1};
  }
  outcome.candidateMode = modes.candidateMode;
  return outcome;
}

double axisDistance(const Cylinder& a, const Eigen::Vector3d& p) {
  const Eigen::Vector3d q = p - a.point;
  return (q - q.dot(a.direction) * a.direction).norm();
}

}  // namespace

// Gauss-Newton on the surface distances |(p − c) × a| − r, over the axis direction (2 angles),
// the axis point (2 offsets across the axis) and the radius.
bool refineCylinderFit(const std::vector<Eigen::Vector3d>& points, Eigen::Vector3d& point, Eigen::Vector3d& direction,
                       double& radius, int iterations) {
  using Vector5d = Eigen::Matrix<double, 5, 1>;
  using Matrix5d = Eigen::Matrix<double, 5, 5>;
  if (points.empty()) return false;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) centroid += p;
  centroid /= static_cast<double>(points.size());
  for (int iteration = 0; iteration < iterations; ++iteration) {
    // Keep the axis point level with the centroid so that tilting the axis barely moves it near the data.
    point += (centroid - point).dot(direction) * direction;
    const Eigen::Vector3d b1 = anyPerpendicular(direction);
    const Eigen::Vector3d b2 = direction.cross(b1);
    Matrix5d normal = Matrix5d::Zero();
    Vector5d gradient = Vector5d::Zero();
    for (const Eigen::Vector3d& p : points) {
      const Eigen::Vector3d q = p - point;
      const double along = q.dot(direction);
      const Eigen::Vector3d radial = q - along * direction;
      const double distance = radial.norm();
      if (distance <= 0.0) continue;
      const Eigen::Vector3d g = radial / distance;
      const double g1 = g.dot(b1), g2 = g.dot(b2);
      Vector5d jacobian;
      jacobian << -along * g1, -along * g2, -g1, -g2, -1.0;
      normal.noalias() += jacobian * jacobian.transpose();
      gradient += jacobian * (distance - radius);
    }
    // A little Levenberg damping keeps a thin arc (radius and centre nearly degenerate) from jumping.
    normal.diagonal() += 1e-9 * (normal.diagonal().array() + 1.0).matrix();
    const Eigen::LDLT<Matrix5d> solver(normal);
    if (solver.info() != Eigen::Success) return false;
    const Vector5d step = solver.solve(-gradient);
    if (!step.allFinite()) return false;
    direction = (direction + step[0] * b1 + step[1] * b2).normalized();
    point += step[2] * b1 + step[3] * b2;
    radius += step[4];
    if (step.norm() < 1e-8) break;
  }
  point += (centroid - point).dot(direction) * direction;
  return radius > 0.0 && point.allFinite() && direction.allFinite();
}

PlacementResult placeCylinders(const PlacementInput& input, const PlacementParams& params, Progress& progress) {
  const auto started = std::chrono::steady_clock::now();
  PlacementResult result;
  const PointCloud& cloud = input.cloud;
  const auto& directions = input.directions.directions;
  if (!cloud.hasNormals() && !cloud.empty()) throw std::invalid_argument("placeCylinders needs a cloud with normals");
  progress.report("placement", 0.0);

  std::vector<DirectionOutcome> outcomes(directions.size());
  std::atomic<std::size_t> finished{0};
  tbb::parallel_for(std::size_t{0}, directions.size(), [&](std::size_t d) {
    progress.checkCancelled();
    outcomes[d] = placeAlongDirection(cloud, directions[d], d, params, input.seed, progress);
    progress.report("placement", 0.9 * static_cast<double>(++finished) / static_cast<double>(directions.size()));
  });

  // All fits in a fixed order; owner[f] is the fit that f's support went to (itself when kept,
  // -1 when dropped).
  std::vector<Cylinder> fits;
  std::vector<char> pooled;
  std::vector<std::size_t> firstFit(directions.size() + 1, 0);
  for (std::size_t d = 0; d < outcomes.size(); ++d) {
    firstFit[d] = fits.size();
    for (Cylinder& fit : outcomes[d].fits) fits.push_back(std::move(fit));
    pooled.insert(pooled.end(), outcomes[d].fitPooled.begin(), outcomes[d].fitPooled.end());
    result.diagnostics.projectedPoints += outcomes[d].projectedPoints;
    result.diagnostics.circles += outcomes[d].circles;
  }
  firstFit[outcomes.size()] = fits.size();

  // A real circle gathers the candidates of most pairs of its points; a ridge of candidates (the
  // two faces of a box edge agree on a circle of any radius) spreads them thin.
  std::vector<std::size_t> bySupport;
  for (std::size_t f = 0; f < fits.size(); ++f) {
    if (fits[f].candidates >= params.minCandidateShare * static_cast<double>(fits[f].inliers.size())) bySupport.push_back(f);
  }
  // Copies: a fit sharing most of its inliers with a better supported one. Fits from pooled modes
  // come last: a circle their pipe's pairs agree on is better evidence than a pool.
  std::stable_sort(bySupport.begin(), bySupport.end(), [&](std::size_t a, std::size_t b) {
    return std::make_pair(pooled[a], -fits[a].candidates) < std::make_pair(pooled[b], -fits[b].candidates);
  });
  std::vector<int> owner(fits.size(), -1);
  std::vector<std::size_t> kept;
  for (const std::size_t f : bySupport) {
    for (const std::size_t k : kept) {
      const Cylinder& better = fits[k];
      if (std::abs(better.direction.dot(fits[f].direction)) < std::cos(kMaxAxisTilt)) continue;
      if (axisDistance(better, fits[f].point) > better.radius + fits[f].radius) continue;
      if (sharedCount(better.inliers, fits[f].inliers) >= kDuplicateShare * fits[f].inliers.size()) {
        owner[f] = static_cast<int>(k);
        break;
      }
    }
    if (owner[f] < 0) {
      owner[f] = static_cast<int>(f);
      kept.push_back(f);
    }
  }
  for (const std::size_t f : bySupport) {
    if (owner[f] != static_cast<int>(f) && !pooled[f]) fits[owner[f]].candidates += fits[f].candidates;
  }
  result.diagnostics.duplicates = bySupport.size() - kept.size();
  progress.checkCancelled();

  // A point belongs to the cylinder whose surface is closest.
  struct Claim {
    std::uint32_t point;
    float offset;
    std::uint32_t fit;
  };
  std::vector<Claim> claims;
  for (const std::size_t f : kept) {
    const CylinderFit fit{fits[f].point, fits[f].direction, fits[f].radius};
    for (const std::uint32_t i : fits[f].inliers) {
      claims.push_back({i, static_cast<float>(std::abs(surfaceOffset(fit, cloud.positions[i].cast<double>()).first)),
                        static_cast<std::uint32_t>(f)});
    }
  }
  std::sort(claims.begin(), claims.end(), [](const Claim& a, const Claim& b) {
    return std::tie(a.point, a.offset, a.fit) < std::tie(b.point, b.offset, b.fit);
  });
  std::vector<std::vector<std::uint32_t>> exclusive(fits.size());
  for (std::size_t c = 0; c < claims.size(); ++c) {
    if (c == 0 || claims[c].point != claims[c - 1].point) exclusive[claims[c].fit].push_back(claims[c].point);
  }

  // Final cylinders, ordered by direction and then by support.
  std::sort(kept.begin(), kept.end(), [&](std::size_t a, std::size_t b) {
    if (fits[a].directionIndex != fits[b].directionIndex) return fits[a].directionIndex < fits[b].directionIndex;
    if (exclusive[a].size() != exclusive[b].size()) return exclusive[a].size() > exclusive[b].size();
    return a < b;
  });
  std::vector<int> finalIndex(fits.size(), -1);
  for (const std::size_t f : kept) {
    Cylinder& cylinder = fits[f];
    cylinder.inliers = std::move(exclusive[f]);
    if (static_cast<int>(cylinder.inliers.size()) < minCylinderInliers(params)) continue;
    const CylinderFit fit{cylinder.point, cylinder.direction, cylinder.radius};
    double sum2 = 0.0;
    for (const std::uint32_t i : cylinder.inliers) {
      const double offset = surfaceOffset(fit, cloud.positions[i].cast<double>()).first;
      sum2 += offset * offset;
    }
    cylinder.rms = std::sqrt(sum2 / static_cast<double>(cylinder.inliers.size()));
    cylinder.mustJoin =
        cylinder.candidates < params.minCandidates || static_cast<int>(cylinder.inliers.size()) < params.minInliers;
    finalIndex[f] = static_cast<int>(result.cylinders.size());
    result.cylinders.push_back(std::move(cylinder));
  }

  // Candidates point at the cylinder their mode became, or was merged into when that cylinder's
  // circle in the plane is the mode's (a fit may also drift onto a neighbouring pipe).
  result.projections.resize(outcomes.size());
  for (std::size_t d = 0; d < outcomes.size(); ++d) {
    DirectionOutcome& outcome = outcomes[d];
    const PlacementResult::Projection& plane = outcome.projection;
    std::vector<int> fitCylinder(outcome.fits.size(), -1);
    for (std::size_t f = 0; f < fitCylinder.size(); ++f) {
      const int target = owner[firstFit[d] + f];
      if (target < 0 || finalIndex[target] < 0) continue;
      const Cylinder& cylinder = result.cylinders[finalIndex[target]];
      const Eigen::Vector3d& circle = outcome.fitCircles[f];
      const Eigen::Vector2d center(cylinder.point.dot(plane.u), cylinder.point.dot(plane.v));
      const double tolerance = 0.5 * cylinder.radius;
      if ((center - circle.head<2>()).norm() <= tolerance && std::abs(cylinder.radius - circle.z()) <= tolerance) {
        fitCylinder[f] = finalIndex[target];
      }
    }
    for (std::size_t i = 0; i < outcome.candidateMode.size(); ++i) {
      const int mode = outcome.candidateMode[i];
      const int fit = mode >= 0 ? outcome.modeFit[mode] : -1;
      if (fit >= 0) outcome.projection.candidates[i].circle = fitCylinder[fit];
    }
    result.diagnostics.candidates += outcome.projection.candidates.size();
    result.projections[d] = std::move(outcome.projection);
  }

  result.diagnostics.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  progress.report("placement", 1.0);
  return result;
}

}  // namespace piperun
