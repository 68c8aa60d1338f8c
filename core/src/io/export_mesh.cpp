#include "io/export_mesh.h"

#include "angles.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

namespace piperun::io {

namespace {

// Points closer than this (m) are one point of a centre line.
constexpr double kSamePoint = 1e-9;

std::vector<Eigen::Vector3d> distinctPoints(const std::vector<Eigen::Vector3d>& polyline) {
  std::vector<Eigen::Vector3d> points;
  for (const auto& p : polyline) {
    if (points.empty() || (p - points.back()).norm() > kSamePoint) points.push_back(p);
  }
  return points;
}

// A unit vector perpendicular to `direction`, built from the coordinate axis least aligned with it
// so that an axis-aligned tube gets an axis-aligned frame.
Eigen::Vector3d perpendicular(const Eigen::Vector3d& direction) {
  Eigen::Index least = 0;
  direction.cwiseAbs().minCoeff(&least);
  const Eigen::Vector3d axis = Eigen::Vector3d::Unit(least);
  return (axis - axis.dot(direction) * direction).normalized();
}

// Tangents at the polyline's points. Inside, the mean of the two adjacent segment directions, which
// for a sampled arc is the arc's own tangent. At an end of a curved polyline, the neighbour's
// tangent mirrored in the end segment: exact for an arc, so an elbow's end ring lies square to
// the pipe it meets.
std::vector<Eigen::Vector3d> tangents(const std::vector<Eigen::Vector3d>& points) {
  const std::size_t n = points.size();
  std::vector<Eigen::Vector3d> result(n);
  const auto segment = [&](std::size_t i) { return Eigen::Vector3d((points[i + 1] - points[i]).normalized()); };
  result.front() = segment(0);
  result.back() = segment(n - 2);
  for (std::size_t i = 1; i + 1 < n; ++i) {
    const Eigen::Vector3d mean = segment(i - 1) + segment(i);
    result[i] = mean.norm() > 1e-12 ? mean.normalized() : segment(i);
  }
  if (n > 2) {
    const auto mirror = [](const Eigen::Vector3d& tangent, const Eigen::Vector3d& across) {
      return Eigen::Vector3d(2.0 * tangent.dot(across) * across - tangent);
    };
    result.front() = mirror(result[1], segment(0));
    result.back() = mirror(result[n - 2], segment(n - 2));
  }
  return result;
}

void appendTube(const std::vector<Eigen::Vector3d>& points, double radius, int segments, NetworkMesh& mesh) {
  const auto tangent = tangents(points);
  const int base = static_cast<int>(mesh.vertices.size());
  const int rings = static_cast<int>(points.size());

  // Rings of vertices around the centre line. The frame is carried along by the smallest rotation
  // from one tangent to the next (parallel transport), so the tube does not twist.
  Eigen::Vector3d u = perpendicular(tangent[0]);
  for (int i = 0; i < rings; ++i) {
    if (i > 0) {
      u = Eigen::Quaterniond::FromTwoVectors(tangent[i - 1], tangent[i]) * u;
      u = (u - u.dot(tangent[i]) * tangent[i]).normalized();
    }
    const Eigen::Vector3d v = tangent[i].cross(u);
    for (int k = 0; k < segments; ++k) {
      const double angle = 2.0 * kPi * k / segments;
      mesh.vertices.push_back(points[i] + radius * (std::cos(angle) * u + std::sin(angle) * v));
    }
  }
  const int startCentre = base + rings * segments;
  const int endCentre = startCentre + 1;
  mesh.vertices.push_back(points.front());
  mesh.vertices.push_back(points.back());

  const auto ring = [&](int i, int k) { return base + i * segments + (k % segments); };
  for (int i = 0; i + 1 < rings; ++i) {
    for (int k = 0; k < segments; ++k) {
      mesh.triangles.push_back({ring(i, k), ring(i, k + 1), ring(i + 1, k + 1)});
      mesh.triangles.push_back({ring(i, k), ring(i + 1, k + 1), ring(i + 1, k)});
    }
  }
  for (int k = 0; k < segments; ++k) {
    mesh.triangles.push_back({startCentre, ring(0, k + 1), ring(0, k)});
    mesh.triangles.push_back({endCentre, ring(rings - 1, k), ring(rings - 1, k + 1)});
  }
}

}  // namespace

NetworkMesh meshElements(const std::vector<ExportElement>& elements, const ExportOptions& options) {
  NetworkMesh mesh;
  for (const auto& element : elements) {
    NetworkMesh::Part part;
    part.firstVertex = mesh.vertices.size();
    part.firstTriangle = mesh.triangles.size();
    const auto points = distinctPoints(element.axis);
    if (points.size() >= 2) appendTube(points, element.radius, meshSegments(element.radius, options), mesh);
    part.vertexCount = mesh.vertices.size() - part.firstVertex;
    part.triangleCount = mesh.triangles.size() - part.firstTriangle;
    mesh.parts.push_back(part);
  }
  return mesh;
}

}  // namespace piperun::io
