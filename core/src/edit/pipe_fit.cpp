#include "piperun/edit/pipe_fit.h"

#include "piperun/edit/edit.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <string>

namespace piperun {

namespace {

constexpr double kDegree = 3.14159265358979323846 / 180.0;
constexpr double kMinGap = 0.05;  // shortest gap that ends the growth of a fit around a point (m)

struct Cylinder3 {
  Eigen::Vector3d point, direction;  // relative to the cloud origin; unit direction
  double radius = 0.0;

  double offset(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d q = p - point;
    return (q - q.dot(direction) * direction).norm() - radius;
  }
};

std::vector<std::uint32_t> pointsWhere(const PointCloud& cloud, const std::function<bool(const Eigen::Vector3d&)>& inside) {
  std::vector<std::uint32_t> selected;
  for (std::size_t i = 0; i < cloud.positions.size(); ++i) {
    if (inside(cloud.positions[i].cast<double>())) selected.push_back(static_cast<std::uint32_t>(i));
  }
  return selected;
}

void requireNormals(const PointCloud& cloud) {
  if (cloud.normals.size() != cloud.positions.size()) throw EditError("fitting a pipe needs the preprocessed points with normals");
}

/// Axis from the normals, circle across it by the algebraic (Kåsa) fit.
Cylinder3 initialCylinder(const PointCloud& cloud, const std::vector<std::uint32_t>& points) {
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const std::uint32_t i : points) {
    const Eigen::Vector3d n = cloud.normals[i].cast<double>();
    scatter += n * n.transpose();
    centroid += cloud.positions[i].cast<double>();
  }
  centroid /= static_cast<double>(points.size());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);
  Cylinder3 cylinder;
  cylinder.direction = solver.eigenvectors().col(0).normalized();
  const Eigen::Vector3d u = cylinder.direction.unitOrthogonal();
  const Eigen::Vector3d v = cylinder.direction.cross(u);
  Eigen::MatrixX3d system(points.size(), 3);
  Eigen::VectorXd right(points.size());
  for (std::size_t k = 0; k < points.size(); ++k) {
    const Eigen::Vector3d q = cloud.positions[points[k]].cast<double>() - centroid;
    const double x = q.dot(u), y = q.dot(v);
    system.row(static_cast<Eigen::Index>(k)) << x, y, 1.0;
    right[static_cast<Eigen::Index>(k)] = -(x * x + y * y);
  }
  const Eigen::Vector3d solution = system.colPivHouseholderQr().solve(right);
  const Eigen::Vector2d center(-0.5 * solution[0], -0.5 * solution[1]);
  cylinder.point = centroid + center.x() * u + center.y() * v;
  cylinder.radius = std::sqrt(std::max(0.0, center.squaredNorm() - solution[2]));
  return cylinder;
}

/// Points of `candidates` near the surface whose normal, across the axis, points radially.
std::vector<std::uint32_t> inliersOf(const PointCloud& cloud, const Cylinder3& cylinder, const std::vector<std::uint32_t>& candidates,
                                     const PlacementParams& params) {
  const double minCos = std::cos(params.inlierNormalAngleDeg * kDegree);
  std::vector<std::uint32_t> inliers;
  for (const std::uint32_t i : candidates) {
    const Eigen::Vector3d q = cloud.positions[i].cast<double>() - cylinder.point;
    const Eigen::Vector3d radial = q - q.dot(cylinder.direction) * cylinder.direction;
    const double distance = radial.norm();
    if (distance <= 0.0 || std::abs(distance - cylinder.radius) >= params.inlierDistance) continue;
    const Eigen::Vector3d n = cloud.normals[i].cast<double>();
    const Eigen::Vector3d across = n - n.dot(cylinder.direction) * cylinder.direction;
    const double acrossNorm = across.norm();
    if (acrossNorm > 0.0 && std::abs(across.dot(radial)) >= minCos * acrossNorm * distance) inliers.push_back(i);
  }
  return inliers;
}

std::vector<Eigen::Vector3d> positionsOf(const PointCloud& cloud, const std::vector<std::uint32_t>& indices) {
  std::vector<Eigen::Vector3d> points;
  points.reserve(indices.size());
  for (const std::uint32_t i : indices) points.push_back(cloud.positions[i].cast<double>());
  return points;
}

std::string tooFew(std::size_t found, const PlacementParams& params, const char* where) {
  return "only " + std::to_string(found) + " points fit a cylinder " + where + " (placement.minInliers is " +
         std::to_string(params.minInliers) + ")";
}

/// The seed's cylinder refined twice on its inliers among `candidates`, as the placement stage does.
Cylinder3 refine(const PointCloud& cloud, const std::vector<std::uint32_t>& seed, const std::vector<std::uint32_t>& candidates,
                 const PlacementParams& params, const char* where) {
  if (static_cast<int>(seed.size()) < params.minInliers) throw EditError(tooFew(seed.size(), params, where));
  Cylinder3 cylinder = initialCylinder(cloud, seed);
  std::vector<std::uint32_t> inliers = inliersOf(cloud, cylinder, seed, params);
  for (int pass = 0; pass < 2; ++pass) {
    if (static_cast<int>(inliers.size()) < params.minInliers) throw EditError(tooFew(inliers.size(), params, where));
    if (!refineCylinderFit(positionsOf(cloud, inliers), cylinder.point, cylinder.direction, cylinder.radius,
                           params.refineIterations)) {
      throw EditError(std::string("the cylinder fit ") + where + " degenerates");
    }
    inliers = inliersOf(cloud, cylinder, pass == 0 ? seed : candidates, params);
  }
  if (static_cast<int>(inliers.size()) < params.minInliers) throw EditError(tooFew(inliers.size(), params, where));
  return cylinder;
}

/// The pipe along `cylinder` spanning `inliers` (world coordinates).
Pipe pipeOver(const PointCloud& cloud, const Cylinder3& cylinder, const std::vector<std::uint32_t>& inliers) {
  double low = std::numeric_limits<double>::infinity(), high = -low, squares = 0.0;
  for (const std::uint32_t i : inliers) {
    const Eigen::Vector3d p = cloud.positions[i].cast<double>();
    const double along = (p - cylinder.point).dot(cylinder.direction);
    low = std::min(low, along);
    high = std::max(high, along);
    squares += cylinder.offset(p) * cylinder.offset(p);
  }
  Pipe pipe;
  pipe.radius = cylinder.radius;
  pipe.start = cloud.origin + cylinder.point + low * cylinder.direction;
  pipe.end = cloud.origin + cylinder.point + high * cylinder.direction;
  pipe.fitRms = std::sqrt(squares / static_cast<double>(inliers.size()));
  pipe.inlierCount = static_cast<std::int64_t>(inliers.size());
  pipe.confidence = 1.0;
  pipe.status = PipeStatus::Accepted;
  return pipe;
}

}  // namespace

Pipe fitPipeInBox(const PointCloud& cloud, const Eigen::Vector3d& boxMin, const Eigen::Vector3d& boxMax,
                  const PlacementParams& params) {
  requireNormals(cloud);
  const Eigen::Vector3d low = boxMin.cwiseMin(boxMax) - cloud.origin, high = boxMin.cwiseMax(boxMax) - cloud.origin;
  const std::vector<std::uint32_t> inside = pointsWhere(cloud, [&](const Eigen::Vector3d& p) {
    return (p.array() >= low.array()).all() && (p.array() <= high.array()).all();
  });
  const Cylinder3 cylinder = refine(cloud, inside, inside, params, "in the box");
  return pipeOver(cloud, cylinder, inliersOf(cloud, cylinder, inside, params));
}

Pipe fitPipeAround(const PointCloud& cloud, const Eigen::Vector3d& center, double reach, const PlacementParams& params) {
  requireNormals(cloud);
  const Eigen::Vector3d local = center - cloud.origin;
  const std::vector<std::uint32_t> near =
      pointsWhere(cloud, [&](const Eigen::Vector3d& p) { return (p - local).squaredNorm() <= reach * reach; });
  const Cylinder3 cylinder = refine(cloud, near, near, params, "around the point");

  // Grow along the axis: the inliers anywhere, sorted along it, kept while they continue from the
  // picked point without a long gap.
  const double band = cylinder.radius + params.inlierDistance;
  std::vector<std::uint32_t> alongAxis = pointsWhere(cloud, [&](const Eigen::Vector3d& p) {
    const Eigen::Vector3d q = p - cylinder.point;
    return (q - q.dot(cylinder.direction) * cylinder.direction).squaredNorm() <= band * band;
  });
  std::vector<std::pair<double, std::uint32_t>> sorted;
  for (const std::uint32_t i : inliersOf(cloud, cylinder, alongAxis, params)) {
    sorted.emplace_back((cloud.positions[i].cast<double>() - cylinder.point).dot(cylinder.direction), i);
  }
  std::sort(sorted.begin(), sorted.end());
  const double picked = (local - cylinder.point).dot(cylinder.direction);
  const double maxGap = std::max(kMinGap, 2.0 * cylinder.radius);
  std::size_t first = 0;
  while (first < sorted.size() && sorted[first].first < picked) ++first;
  std::size_t last = first;
  if (first == sorted.size()) first = last = sorted.size() - 1;
  while (first > 0 && sorted[first].first - sorted[first - 1].first <= maxGap) --first;
  while (last + 1 < sorted.size() && sorted[last + 1].first - sorted[last].first <= maxGap) ++last;
  std::vector<std::uint32_t> inliers;
  for (std::size_t k = first; k <= last; ++k) inliers.push_back(sorted[k].second);
  return pipeOver(cloud, cylinder, inliers);
}

}  // namespace piperun
