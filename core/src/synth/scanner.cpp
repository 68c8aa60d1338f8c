#include "synth/scanner.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>
#include <utility>

#include "angles.h"
#include "random.h"

namespace piperun::synth {
namespace {

// Pieces are kept small so that their bounding spheres are tight seen from a station.
constexpr double kMaxCylinderPiece = 1.0;  // m
constexpr double kMaxBoxPiece = 2.0;       // m
constexpr double kMaxTorusPiece = 30.0 * kDegree;

// Leaves of the bounding-box hierarchy hold at most this many pieces.
constexpr int kLeafPieces = 4;

// A strip holds about this many rays, and is at most this wide in azimuth.
constexpr int kRaysPerStrip = 16384;
constexpr double kMaxStripWidth = 2.0 * kDegree;
// Candidates of a strip are binned by elevation rows spanning about this angle.
constexpr double kBinHeight = 0.5 * kDegree;

// ---------------------------------------------------------------------------------------------
// Real roots of polynomials of degree <= 4 in an interval.

/// Evaluates c[0] + c[1] x + ... + c[degree] x^degree.
double evaluate(const double* c, int degree, double x) {
  double value = c[degree];
  for (int k = degree - 1; k >= 0; --k) value = value * x + c[k];
  return value;
}

/// The root of a polynomial that changes sign once on [low, high] (monotone there): Newton steps
/// kept inside a shrinking bracket, falling back to bisection.
double bracketedRoot(const double* c, const double* derivative, int degree, double low, double high, double valueLow) {
  double x = 0.5 * (low + high);
  for (int iteration = 0; iteration < 100; ++iteration) {
    const double value = evaluate(c, degree, x);
    if (value == 0.0) return x;
    if ((value < 0.0) == (valueLow < 0.0)) {
      low = x;
    } else {
      high = x;
    }
    if (high - low <= 1e-15 * std::max(1.0, std::abs(x))) break;
    const double slope = evaluate(derivative, degree - 1, x);
    const double newton = slope != 0.0 ? x - value / slope : high;  // high lies outside the open bracket
    x = (newton > low && newton < high) ? newton : 0.5 * (low + high);
  }
  return x;
}

/// The distinct real roots of the polynomial c (degree 1..4, c[degree] != 0) in [low, high], in
/// ascending order. Roots of the derivative split the interval into monotone pieces, each holding
/// at most one root; this is robust where closed-form quartic solutions lose precision.
int rootsInInterval(const double* c, int degree, double low, double high, double* roots) {
  if (degree == 1) {
    const double x = -c[0] / c[1];
    if (x < low || x > high) return 0;
    roots[0] = x;
    return 1;
  }
  std::array<double, 4> derivative{};
  for (int k = 1; k <= degree; ++k) derivative[k - 1] = k * c[k];
  std::array<double, 5> splits{};
  int splitCount = 0;
  splits[splitCount++] = low;
  std::array<double, 3> criticalPoints{};
  const int critical = rootsInInterval(derivative.data(), degree - 1, low, high, criticalPoints.data());
  for (int k = 0; k < critical; ++k) splits[splitCount++] = criticalPoints[k];
  splits[splitCount++] = high;

  int count = 0;
  double valueLow = evaluate(c, degree, splits[0]);
  if (valueLow == 0.0) roots[count++] = splits[0];
  for (int k = 1; k < splitCount; ++k) {
    const double a = splits[k - 1];
    const double b = splits[k];
    const double valueHigh = evaluate(c, degree, b);
    if (valueHigh == 0.0) {
      if (count == 0 || roots[count - 1] != b) roots[count++] = b;
    } else if (valueLow != 0.0 && (valueLow < 0.0) != (valueHigh < 0.0)) {
      roots[count++] = bracketedRoot(c, derivative.data(), degree, a, b, valueLow);
    }
    valueLow = valueHigh;
  }
  return count;
}

// ---------------------------------------------------------------------------------------------
// Ray–shape intersections.

std::optional<RayHit> intersectCylinder(const Cylinder& cylinder, const Ray& ray, double minDistance,
                                        double maxDistance) {
  const Eigen::Vector3d offset = ray.origin - cylinder.start;
  const double directionAlong = ray.direction.dot(cylinder.axis);
  const double offsetAlong = offset.dot(cylinder.axis);
  const Eigen::Vector3d directionAcross = ray.direction - directionAlong * cylinder.axis;
  const Eigen::Vector3d offsetAcross = offset - offsetAlong * cylinder.axis;
  const double a = directionAcross.squaredNorm();
  if (a < 1e-18) return std::nullopt;  // parallel to the axis: never meets the lateral surface
  const double halfB = directionAcross.dot(offsetAcross);
  const double c = offsetAcross.squaredNorm() - cylinder.radius * cylinder.radius;
  const double discriminant = halfB * halfB - a * c;
  if (discriminant < 0.0) return std::nullopt;
  // Stable quadratic roots (no cancellation between -halfB and the square root).
  const double q = -(halfB + std::copysign(std::sqrt(discriminant), halfB));
  double near = q / a;
  double far = q != 0.0 ? c / q : near;
  if (near > far) std::swap(near, far);
  for (const double t : {near, far}) {
    if (t <= minDistance || t >= maxDistance) continue;
    const double along = offsetAlong + t * directionAlong;
    if (along < 0.0 || along > cylinder.length) continue;
    return RayHit{t, (offsetAcross + t * directionAcross) / cylinder.radius};
  }
  return std::nullopt;
}

std::optional<RayHit> intersectTorus(const TorusSection& torus, const Ray& ray, double minDistance,
                                     double maxDistance) {
  // Parametrise the ray from its point closest to the torus centre, scaled by the bounding sphere
  // radius: the quartic then has no cubic term and coefficients of order one.
  const double R = torus.bendRadius;
  const double r = torus.radius;
  const double bound = R + r;
  const double closest = -(ray.origin - torus.center).dot(ray.direction);
  const Eigen::Vector3d q = ray.origin + closest * ray.direction - torus.center;
  const double q2 = q.squaredNorm();
  if (q2 >= bound * bound) return std::nullopt;
  const double halfChord = std::sqrt(bound * bound - q2);
  const double low = std::max(-halfChord, minDistance - closest);
  const double high = std::min(halfChord, maxDistance - closest);
  if (low >= high) return std::nullopt;

  const double qu = q.dot(torus.u), qv = q.dot(torus.v);
  const double du = ray.direction.dot(torus.u), dv = ray.direction.dot(torus.v);
  const double a = du * du + dv * dv;
  const double b = qu * du + qv * dv;
  const double c = qu * qu + qv * qv;
  const double k = q2 + R * R - r * r;
  // (s² + k)² − 4R² (a s² + 2 b s + c) = 0, written in x = s / bound.
  const double b2 = bound * bound;
  const std::array<double, 5> coefficients{(k * k - 4.0 * R * R * c) / (b2 * b2), -8.0 * R * R * b / (b2 * bound),
                                           (2.0 * k - 4.0 * R * R * a) / b2, 0.0, 1.0};
  std::array<double, 4> roots{};
  const int count = rootsInInterval(coefficients.data(), 4, low / bound, high / bound, roots.data());
  for (int i = 0; i < count; ++i) {
    const double t = closest + roots[i] * bound;
    if (t <= minDistance || t >= maxDistance) continue;
    const Eigen::Vector3d local = ray.origin + t * ray.direction - torus.center;
    const double x = local.dot(torus.u), y = local.dot(torus.v);
    const double angle = std::atan2(y, x);
    if (angle < 0.0 || angle > torus.sweep) continue;
    const Eigen::Vector3d inPlane = x * torus.u + y * torus.v;
    const double inPlaneNorm = inPlane.norm();
    if (inPlaneNorm == 0.0) continue;
    const Eigen::Vector3d ringPoint = inPlane * (R / inPlaneNorm);
    return RayHit{t, (local - ringPoint).normalized()};
  }
  return std::nullopt;
}

std::optional<RayHit> intersectBox(const OrientedBox& box, const Ray& ray, double minDistance, double maxDistance) {
  const Eigen::Vector3d origin = box.toLocal(ray.origin);
  const Eigen::Vector3d direction = box.axes.transpose() * ray.direction;
  double enter = -std::numeric_limits<double>::infinity();
  double leave = std::numeric_limits<double>::infinity();
  int enterAxis = -1;
  double enterSign = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double h = box.halfExtents[k];
    if (std::abs(direction[k]) < 1e-300) {
      if (std::abs(origin[k]) > h) return std::nullopt;
      continue;
    }
    double t0 = (-h - origin[k]) / direction[k];
    double t1 = (h - origin[k]) / direction[k];
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > enter) {
      enter = t0;
      enterAxis = k;
      enterSign = direction[k] > 0.0 ? -1.0 : 1.0;
    }
    leave = std::min(leave, t1);
  }
  // Hits from inside a box are not surface hits of a solid seen from outside.
  if (enterAxis < 0 || enter > leave || enter <= minDistance || enter >= maxDistance) return std::nullopt;
  return RayHit{enter, enterSign * box.axes.col(enterAxis)};
}

std::optional<RayHit> intersectDisc(const Disc& disc, const Ray& ray, double minDistance, double maxDistance) {
  const double facing = ray.direction.dot(disc.normal);
  if (std::abs(facing) < 1e-12) return std::nullopt;
  const double t = (disc.center - ray.origin).dot(disc.normal) / facing;
  if (t <= minDistance || t >= maxDistance) return std::nullopt;
  if ((ray.origin + t * ray.direction - disc.center).squaredNorm() > disc.radius * disc.radius) return std::nullopt;
  return RayHit{t, disc.normal};
}

// ---------------------------------------------------------------------------------------------
// Cutting surfaces into pieces with bounding spheres.

struct Bound {
  Eigen::Vector3d center;
  double radius;
};

Bound boundOf(const Shape& shape) {
  if (const auto* cylinder = std::get_if<Cylinder>(&shape)) {
    return {cylinder->start + 0.5 * cylinder->length * cylinder->axis,
            std::hypot(0.5 * cylinder->length, cylinder->radius)};
  }
  if (const auto* torus = std::get_if<TorusSection>(&shape)) {
    // Sphere through the arc's ends and midpoint, centred on the bisector; grown by the tube radius.
    const double half = 0.5 * torus->sweep;
    const Eigen::Vector3d mid = std::cos(half) * torus->u + std::sin(half) * torus->v;
    const double R = torus->bendRadius;
    const double offset = 0.5 * R * (1.0 + std::cos(half));
    const double arcRadius = std::hypot(0.5 * R * (1.0 - std::cos(half)), R * std::sin(half));
    return {torus->center + offset * mid, arcRadius + torus->radius};
  }
  if (const auto* box = std::get_if<OrientedBox>(&shape)) return {box->center, box->halfExtents.norm()};
  const auto& disc = std::get<Disc>(shape);
  return {disc.center, disc.radius};
}

/// The centre and half-widths of a shape's axis-aligned bounds.
std::pair<Eigen::Vector3d, Eigen::Vector3d> axisAlignedBoundsOf(const Shape& shape) {
  // A circle of radius r in the plane with unit normal n reaches r sqrt(1 - n_k²) along axis k.
  auto circleReach = [](const Eigen::Vector3d& normal, double radius) -> Eigen::Vector3d {
    return radius * (Eigen::Vector3d::Ones() - normal.cwiseAbs2()).cwiseMax(0.0).cwiseSqrt();
  };
  if (const auto* cylinder = std::get_if<Cylinder>(&shape)) {
    const Eigen::Vector3d half = 0.5 * cylinder->length * cylinder->axis;
    return {cylinder->start + half, half.cwiseAbs() + circleReach(cylinder->axis, cylinder->radius)};
  }
  if (const auto* box = std::get_if<OrientedBox>(&shape)) {
    return {box->center, box->axes.cwiseAbs() * box->halfExtents};
  }
  if (const auto* disc = std::get_if<Disc>(&shape)) return {disc->center, circleReach(disc->normal, disc->radius)};
  const Bound bound = boundOf(shape);
  return {bound.center, Eigen::Vector3d::Constant(bound.radius)};
}

std::vector<Shape> cutIntoPieces(const Shape& shape) {
  std::vector<Shape> pieces;
  if (const auto* cylinder = std::get_if<Cylinder>(&shape)) {
    const int count = std::max(1, static_cast<int>(std::ceil(cylinder->length / kMaxCylinderPiece)));
    const double length = cylinder->length / count;
    for (int i = 0; i < count; ++i) {
      Cylinder piece = *cylinder;
      piece.start = cylinder->start + (i * length) * cylinder->axis;
      piece.length = length;
      pieces.emplace_back(piece);
    }
  } else if (const auto* torus = std::get_if<TorusSection>(&shape)) {
    const int count = std::max(1, static_cast<int>(std::ceil(torus->sweep / kMaxTorusPiece)));
    const double sweep = torus->sweep / count;
    for (int i = 0; i < count; ++i) {
      TorusSection piece = *torus;
      const double angle = i * sweep;
      piece.u = std::cos(angle) * torus->u + std::sin(angle) * torus->v;
      piece.v = -std::sin(angle) * torus->u + std::cos(angle) * torus->v;
      piece.sweep = sweep;
      pieces.emplace_back(piece);
    }
  } else if (const auto* box = std::get_if<OrientedBox>(&shape)) {
    Eigen::Vector3i counts;
    for (int k = 0; k < 3; ++k) {
      counts[k] = std::max(1, static_cast<int>(std::ceil(2.0 * box->halfExtents[k] / kMaxBoxPiece)));
    }
    const Eigen::Vector3d half = box->halfExtents.cwiseQuotient(counts.cast<double>());
    for (int i = 0; i < counts[0]; ++i) {
      for (int j = 0; j < counts[1]; ++j) {
        for (int k = 0; k < counts[2]; ++k) {
          const Eigen::Vector3d local =
              -box->halfExtents + half.cwiseProduct(Eigen::Vector3d(2 * i + 1, 2 * j + 1, 2 * k + 1));
          pieces.emplace_back(OrientedBox{box->toWorld(local), box->axes, half});
        }
      }
    }
  } else {
    pieces.push_back(shape);
  }
  return pieces;
}

}  // namespace

std::optional<RayHit> intersect(const Shape& shape, const Ray& ray, double minDistance, double maxDistance) {
  switch (shape.index()) {
    case 0:
      return intersectCylinder(std::get<Cylinder>(shape), ray, minDistance, maxDistance);
    case 1:
      return intersectTorus(std::get<TorusSection>(shape), ray, minDistance, maxDistance);
    case 2:
      return intersectBox(std::get<OrientedBox>(shape), ray, minDistance, maxDistance);
    default:
      return intersectDisc(std::get<Disc>(shape), ray, minDistance, maxDistance);
  }
}

// ---------------------------------------------------------------------------------------------
// The scanner.

/// The ray grid of one station and, for each azimuth strip, the pieces that can be hit in it.
struct Scanner::StationGrid {
  /// The rows and (possibly wrapping) columns of rays that can reach a piece.
  struct Reach {
    int piece = 0;
    int firstColumn = 0;
    int columnCount = 0;
    int firstRow = 0;
    int lastRow = 0;
    double nearest = 0.0;  ///< No hit on the piece is closer than this.
  };

  Eigen::Vector3d station = Eigen::Vector3d::Zero();
  int stationIndex = 0;
  int columns = 0;
  int rows = 0;
  int stripColumns = 0;
  int strips = 0;
  int rowsPerBin = 0;
  std::vector<double> cosAzimuth, sinAzimuth, cosElevation, sinElevation;
  std::vector<Reach> reaches;
  std::vector<int> stripBegin;  ///< Strip s holds reaches stripReaches[stripBegin[s] .. stripBegin[s + 1]).
  std::vector<int> stripReaches;

  bool reachesColumn(const Reach& reach, int column) const {
    int offset = column - reach.firstColumn;
    if (offset < 0) offset += columns;
    return offset < reach.columnCount;
  }
};

Scanner::Scanner(std::vector<Surface> surfaces) : surfaces_(std::move(surfaces)) {
  for (int s = 0; s < static_cast<int>(surfaces_.size()); ++s) {
    for (Shape& shape : cutIntoPieces(surfaces_[s].shape)) {
      const Bound bound = boundOf(shape);
      const auto [boxCenter, boxHalf] = axisAlignedBoundsOf(shape);
      pieces_.push_back(
          Piece{std::move(shape), s, bound.center, bound.radius, boxCenter - boxHalf, boxCenter + boxHalf});
    }
  }
  pieceOrder_.resize(pieces_.size());
  std::iota(pieceOrder_.begin(), pieceOrder_.end(), 0);
  nodes_.emplace_back();
  buildHierarchy(0, 0, static_cast<int>(pieces_.size()));
}

void Scanner::buildHierarchy(int node, int first, int count) {
  // The pieces' bounds, split at the median centre along the widest spread of centres.
  Eigen::Vector3d min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d max = -min, centerMin = min, centerMax = -min;
  for (int i = first; i < first + count; ++i) {
    const Piece& piece = pieces_[pieceOrder_[i]];
    min = min.cwiseMin(piece.boxMin);
    max = max.cwiseMax(piece.boxMax);
    centerMin = centerMin.cwiseMin(piece.boundCenter);
    centerMax = centerMax.cwiseMax(piece.boundCenter);
  }
  nodes_[node].min = min;
  nodes_[node].max = max;
  nodes_[node].first = first;
  nodes_[node].count = count;
  if (count <= kLeafPieces) return;
  int axis = 0;
  (centerMax - centerMin).maxCoeff(&axis);
  const int half = count / 2;
  std::nth_element(pieceOrder_.begin() + first, pieceOrder_.begin() + first + half, pieceOrder_.begin() + first + count,
                   [&](int a, int b) {
                     const double ca = pieces_[a].boundCenter[axis], cb = pieces_[b].boundCenter[axis];
                     return ca < cb || (ca == cb && a < b);
                   });
  const int children = static_cast<int>(nodes_.size());
  nodes_[node].children = children;
  nodes_.emplace_back();
  nodes_.emplace_back();
  buildHierarchy(children, first, half);
  buildHierarchy(children + 1, first + half, count - half);
}

Scanner::StationGrid Scanner::prepare(const Eigen::Vector3d& station, int stationIndex,
                                      const ScanSettings& settings) const {
  StationGrid grid;
  grid.station = station;
  grid.stationIndex = stationIndex;
  const double step = settings.angularStep;
  grid.columns = std::max(1, static_cast<int>(std::lround(2.0 * kPi / step)));
  grid.rows = static_cast<int>(std::floor((settings.maxElevation - settings.minElevation) / step + 1e-9)) + 1;
  const double azimuthStep = 2.0 * kPi / grid.columns;
  // Each station starts its sweep at its own azimuth, as a real scanner set up by hand does.
  const double azimuthOffset =
      Rng(settings.seed, {0x5ca9, static_cast<std::uint64_t>(stationIndex)}).uniform(-kPi, kPi);

  grid.stripColumns = std::clamp((kRaysPerStrip + grid.rows - 1) / grid.rows, 1,
                                 std::max(1, static_cast<int>(kMaxStripWidth / azimuthStep)));
  grid.strips = (grid.columns + grid.stripColumns - 1) / grid.stripColumns;
  grid.rowsPerBin = std::max(1, static_cast<int>(std::lround(kBinHeight / step)));

  grid.cosAzimuth.resize(grid.columns);
  grid.sinAzimuth.resize(grid.columns);
  for (int j = 0; j < grid.columns; ++j) {
    const double azimuth = azimuthOffset + j * azimuthStep;
    grid.cosAzimuth[j] = std::cos(azimuth);
    grid.sinAzimuth[j] = std::sin(azimuth);
  }
  grid.cosElevation.resize(grid.rows);
  grid.sinElevation.resize(grid.rows);
  for (int i = 0; i < grid.rows; ++i) {
    const double elevation = std::min(settings.minElevation + i * step, settings.maxElevation);
    grid.cosElevation[i] = std::cos(elevation);
    grid.sinElevation[i] = std::sin(elevation);
  }

  // Angular reach of each piece's bounding sphere (rounding margin 1e-9 rad).
  constexpr double kMargin = 1e-9;
  for (int p = 0; p < static_cast<int>(pieces_.size()); ++p) {
    const Piece& piece = pieces_[p];
    const Eigen::Vector3d toCenter = piece.boundCenter - station;
    const double distance = toCenter.norm();
    const double nearest = std::max(0.0, distance - piece.boundRadius);
    if (nearest >= settings.maxRange) continue;
    StationGrid::Reach reach;
    reach.piece = p;
    reach.nearest = nearest;
    if (distance <= piece.boundRadius) {  // the station is inside the bounding sphere
      reach.columnCount = grid.columns;
      reach.lastRow = grid.rows - 1;
    } else {
      const double angularRadius = std::asin(piece.boundRadius / distance);
      const double elevation = std::asin(std::clamp(toCenter.z() / distance, -1.0, 1.0));
      const double lowRow = (elevation - angularRadius - settings.minElevation) / step;
      const double highRow = (elevation + angularRadius - settings.minElevation) / step;
      reach.firstRow = std::max(0, static_cast<int>(std::ceil(lowRow - kMargin)));
      reach.lastRow = std::min(grid.rows - 1, static_cast<int>(std::floor(highRow + kMargin)));
      if (reach.firstRow > reach.lastRow) continue;
      const double horizontal = std::hypot(toCenter.x(), toCenter.y());
      if (horizontal <= piece.boundRadius) {
        reach.columnCount = grid.columns;
      } else {
        const double halfWidth = std::asin(piece.boundRadius / horizontal);
        double centre = std::atan2(toCenter.y(), toCenter.x()) - azimuthOffset;
        centre -= 2.0 * kPi * std::floor(centre / (2.0 * kPi));  // into [0, 2π)
        const long first = static_cast<long>(std::ceil((centre - halfWidth) / azimuthStep - kMargin));
        const long last = static_cast<long>(std::floor((centre + halfWidth) / azimuthStep + kMargin));
        if (last < first) continue;
        reach.columnCount = static_cast<int>(std::min<long>(last - first + 1, grid.columns));
        reach.firstColumn = static_cast<int>(((first % grid.columns) + grid.columns) % grid.columns);
      }
    }
    grid.reaches.push_back(reach);
  }

  // Strips reached by each piece, as a compressed table.
  auto forEachStrip = [&](const StationGrid::Reach& reach, auto&& visit) {
    if (reach.columnCount >= grid.columns) {
      for (int s = 0; s < grid.strips; ++s) visit(s);
      return;
    }
    const int firstStrip = reach.firstColumn / grid.stripColumns;
    const int lastColumn = reach.firstColumn + reach.columnCount - 1;
    if (lastColumn < grid.columns) {
      for (int s = firstStrip; s <= lastColumn / grid.stripColumns; ++s) visit(s);
    } else {
      for (int s = firstStrip; s < grid.strips; ++s) visit(s);
      for (int s = 0; s <= (lastColumn - grid.columns) / grid.stripColumns; ++s) visit(s);
    }
  };
  grid.stripBegin.assign(grid.strips + 1, 0);
  for (const auto& reach : grid.reaches) forEachStrip(reach, [&](int s) { ++grid.stripBegin[s + 1]; });
  for (int s = 0; s < grid.strips; ++s) grid.stripBegin[s + 1] += grid.stripBegin[s];
  grid.stripReaches.resize(grid.stripBegin.back());
  std::vector<int> fill(grid.stripBegin.begin(), grid.stripBegin.end() - 1);
  for (int r = 0; r < static_cast<int>(grid.reaches.size()); ++r) {
    forEachStrip(grid.reaches[r], [&](int s) { grid.stripReaches[fill[s]++] = r; });
  }
  return grid;
}

template <typename OnHit>
void Scanner::traceStrip(const StationGrid& grid, int strip, const ScanSettings& settings, OnHit&& onHit) const {
  // Bin the strip's candidates by elevation rows, nearest first within each bin, so that a ray
  // stops testing once the remaining candidates lie beyond its nearest hit.
  const int bins = (grid.rows + grid.rowsPerBin - 1) / grid.rowsPerBin;
  std::vector<int> binBegin(bins + 1, 0);
  const int* candidates = grid.stripReaches.data() + grid.stripBegin[strip];
  const int candidateCount = grid.stripBegin[strip + 1] - grid.stripBegin[strip];
  for (int c = 0; c < candidateCount; ++c) {
    const auto& reach = grid.reaches[candidates[c]];
    for (int b = reach.firstRow / grid.rowsPerBin; b <= reach.lastRow / grid.rowsPerBin; ++b) ++binBegin[b + 1];
  }
  for (int b = 0; b < bins; ++b) binBegin[b + 1] += binBegin[b];
  std::vector<int> binReaches(binBegin.back());
  {
    std::vector<int> fill(binBegin.begin(), binBegin.end() - 1);
    for (int c = 0; c < candidateCount; ++c) {
      const auto& reach = grid.reaches[candidates[c]];
      for (int b = reach.firstRow / grid.rowsPerBin; b <= reach.lastRow / grid.rowsPerBin; ++b) {
        binReaches[fill[b]++] = candidates[c];
      }
    }
  }
  for (int b = 0; b < bins; ++b) {
    std::sort(binReaches.begin() + binBegin[b], binReaches.begin() + binBegin[b + 1], [&](int x, int y) {
      const double nx = grid.reaches[x].nearest, ny = grid.reaches[y].nearest;
      return nx < ny || (nx == ny && x < y);
    });
  }

  const int firstColumn = strip * grid.stripColumns;
  const int endColumn = std::min(grid.columns, firstColumn + grid.stripColumns);
  Ray ray;
  ray.origin = grid.station;
  for (int column = firstColumn; column < endColumn; ++column) {
    for (int row = 0; row < grid.rows; ++row) {
      ray.direction = Eigen::Vector3d(grid.cosElevation[row] * grid.cosAzimuth[column],
                                      grid.cosElevation[row] * grid.sinAzimuth[column], grid.sinElevation[row]);
      const int bin = row / grid.rowsPerBin;
      double nearest = settings.maxRange;
      std::optional<RayHit> best;
      int bestPiece = -1;
      for (int k = binBegin[bin]; k < binBegin[bin + 1]; ++k) {
        const auto& reach = grid.reaches[binReaches[k]];
        if (reach.nearest >= nearest) break;
        if (row < reach.firstRow || row > reach.lastRow || !grid.reachesColumn(reach, column)) continue;
        if (auto hit = intersect(pieces_[reach.piece].shape, ray, settings.minRange, nearest)) {
          nearest = hit->distance;
          best = hit;
          bestPiece = reach.piece;
        }
      }
      if (best) onHit(ray, *best, pieces_[bestPiece].surface, column, row);
    }
  }
}

namespace {

/// The random stream of mixed pixels, apart from the scan's noise and outliers.
constexpr std::uint64_t kMixedPixelStream = 0x6d69786564ULL;

/// The ranges of a strip's rays as they are traced (column by column, each from the lowest row
/// up), to tell the rays next to a depth edge: a range jump of more than kMixedPixelJump from the
/// ray before in the column or in the row. The strip's first column has no column before it here.
class DepthEdges {
 public:
  explicit DepthEdges(int rows)
      : before_(static_cast<std::size_t>(rows), kNoRange), current_(static_cast<std::size_t>(rows), kNoRange) {}

  /// Records the ray's range; returns the range of the neighbour across the larger jump, or NaN.
  double across(int column, int row, double range) {
    if (column != column_) {
      if (column == column_ + 1) {
        std::swap(before_, current_);
      } else {
        std::fill(before_.begin(), before_.end(), kNoRange);
      }
      std::fill(current_.begin(), current_.end(), kNoRange);
      column_ = column;
    }
    const auto r = static_cast<std::size_t>(row);
    current_[r] = range;
    double across = kNoRange, largestJump = kMixedPixelJump;
    for (const double neighbour : {r > 0 ? current_[r - 1] : kNoRange, before_[r]}) {
      const double jump = std::fabs(neighbour - range);  // NaN, so no jump, where no ray hit
      if (jump > largestJump) {
        largestJump = jump;
        across = neighbour;
      }
    }
    return across;
  }

 private:
  static constexpr double kNoRange = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> before_, current_;
  int column_ = -1;
};

}  // namespace

void Scanner::scan(const Eigen::Vector3d& station, int stationIndex, const ScanSettings& settings,
                   const std::function<void(ScanStrip&&, double)>& emit) const {
  const StationGrid grid = prepare(station, stationIndex, settings);
  const Eigen::Vector3d outlierCorner = -settings.outlierBox.halfExtents;

  auto traceToPoints = [&](int strip) {
    Rng rng(settings.seed, {static_cast<std::uint64_t>(stationIndex), static_cast<std::uint64_t>(strip)});
    // Mixed pixels draw from a stream of their own, so every other point keeps its noise.
    Rng mixing(settings.seed, {kMixedPixelStream, static_cast<std::uint64_t>(stationIndex),
                               static_cast<std::uint64_t>(strip)});
    DepthEdges edges(grid.rows);
    ScanStrip points;
    traceStrip(grid, strip, settings, [&](const Ray& ray, const RayHit& hit, int surfaceIndex, int column, int row) {
      const Surface& surface = surfaces_[surfaceIndex];
      std::optional<Eigen::Vector3d> mixed;
      if (settings.mixedPixelShare > 0.0) {
        const double across = edges.across(column, row, hit.distance);
        if (!std::isnan(across) && mixing.chance(settings.mixedPixelShare)) {
          mixed = ray.origin + (hit.distance + mixing.uniform() * (across - hit.distance)) * ray.direction;
        }
      }
      // The noise is drawn for a mixed pixel's ray too, so the next rays draw what they would without it.
      Eigen::Vector3d position = ray.origin + hit.distance * ray.direction;
      if (settings.noiseSigma > 0.0) position += (settings.noiseSigma * rng.normal()) * hit.normal;
      if (mixed) {
        points.positions.push_back(*mixed);
        points.intensities.push_back(static_cast<float>(mixing.uniform(0.0, 0.5)));
        points.labels.push_back(-1);
        ++points.mixedPixels;
      } else {
        points.positions.push_back(position);
        points.intensities.push_back(
            static_cast<float>(std::min(1.0, std::abs(ray.direction.dot(hit.normal)) * surface.reflectance)));
        points.labels.push_back(surface.label);
      }
      if (settings.outlierFraction > 0.0 && rng.chance(settings.outlierFraction)) {
        const Eigen::Vector3d local =
            outlierCorner + 2.0 * settings.outlierBox.halfExtents.cwiseProduct(
                                      Eigen::Vector3d(rng.uniform(), rng.uniform(), rng.uniform()));
        points.positions.push_back(settings.outlierBox.toWorld(local));
        points.intensities.push_back(static_cast<float>(rng.uniform(0.0, 0.3)));
        points.labels.push_back(-1);
        ++points.outliers;
      }
    });
    return points;
  };

  struct Numbered {
    int strip = 0;
    ScanStrip points;
  };
  int nextStrip = 0;
  const auto tokens = static_cast<std::size_t>(4 * std::max(1, tbb::this_task_arena::max_concurrency()));
  tbb::parallel_pipeline(
      tokens, tbb::make_filter<void, int>(tbb::filter_mode::serial_in_order, [&](tbb::flow_control& control) {
                if (nextStrip >= grid.strips) {
                  control.stop();
                  return 0;
                }
                return nextStrip++;
              }) & tbb::make_filter<int, Numbered>(tbb::filter_mode::parallel, [&](int strip) {
                return Numbered{strip, traceToPoints(strip)};
              }) & tbb::make_filter<Numbered, void>(tbb::filter_mode::serial_in_order, [&](Numbered numbered) {
                emit(std::move(numbered.points), static_cast<double>(numbered.strip + 1) / grid.strips);
              }));
}

std::uint64_t Scanner::countHits(const Eigen::Vector3d& station, const ScanSettings& settings) const {
  const StationGrid grid = prepare(station, 0, settings);
  return tbb::parallel_reduce(
      tbb::blocked_range<int>(0, grid.strips), std::uint64_t{0},
      [&](const tbb::blocked_range<int>& range, std::uint64_t count) {
        for (int strip = range.begin(); strip < range.end(); ++strip) {
          traceStrip(grid, strip, settings, [&](const Ray&, const RayHit&, int, int, int) { ++count; });
        }
        return count;
      },
      [](std::uint64_t a, std::uint64_t b) { return a + b; });
}

bool Scanner::occluded(const Ray& ray, double minDistance, double maxDistance) const {
  if (pieces_.empty()) return false;
  // A huge finite inverse for zero components keeps the slab products free of 0 × ∞.
  Eigen::Vector3d inverse;
  for (int k = 0; k < 3; ++k) {
    inverse[k] = ray.direction[k] != 0.0 ? 1.0 / ray.direction[k] : std::numeric_limits<double>::max();
  }
  // The hierarchy is balanced, so its depth (and the stack) stays below log2(pieces) + 2.
  std::array<int, 64> stack{};
  int size = 0;
  stack[size++] = 0;
  while (size > 0) {
    const HierarchyNode& node = nodes_[stack[--size]];
    double enter = minDistance, leave = maxDistance;
    for (int k = 0; k < 3; ++k) {
      double t0 = (node.min[k] - ray.origin[k]) * inverse[k];
      double t1 = (node.max[k] - ray.origin[k]) * inverse[k];
      if (t0 > t1) std::swap(t0, t1);
      enter = std::max(enter, t0);
      leave = std::min(leave, t1);
    }
    if (enter > leave) continue;
    if (node.children >= 0) {
      stack[size++] = node.children;
      stack[size++] = node.children + 1;
      continue;
    }
    for (int i = node.first; i < node.first + node.count; ++i) {
      if (intersect(pieces_[pieceOrder_[i]].shape, ray, minDistance, maxDistance)) return true;
    }
  }
  return false;
}

std::optional<std::pair<RayHit, int>> Scanner::castRay(const Ray& ray, double minDistance, double maxDistance) const {
  std::optional<std::pair<RayHit, int>> nearest;
  for (int s = 0; s < static_cast<int>(surfaces_.size()); ++s) {
    if (auto hit = intersect(surfaces_[s].shape, ray, minDistance, maxDistance)) {
      maxDistance = hit->distance;
      nearest = std::make_pair(*hit, s);
    }
  }
  return nearest;
}

}  // namespace piperun::synth
