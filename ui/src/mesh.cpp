#include "mesh.h"

#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkFloatArray.h>
#include <vtkIdTypeArray.h>
#include <vtkTypeInt32Array.h>
#include <vtkIntArray.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkUnsignedCharArray.h>

#include <Eigen/Geometry>

#include <cmath>

namespace piperun::ui {

namespace {

vtkSmartPointer<vtkUnsignedCharArray> colorArray(const std::vector<Rgb>& colors) {
  auto array = vtkSmartPointer<vtkUnsignedCharArray>::New();
  array->SetName("colors");
  array->SetNumberOfComponents(3);
  array->SetNumberOfTuples(static_cast<vtkIdType>(colors.size()));
  std::copy(colors.front().data(), colors.front().data() + 3 * colors.size(), array->GetPointer(0));
  return array;
}

/// Points as vertices with an RGB array: the point at `i` is positions[index(i)].
template <typename Index>
vtkSmartPointer<vtkPolyData> pointSet(const std::vector<Eigen::Vector3f>& positions, const std::vector<Rgb>& colors,
                                      vtkIdType count, Index index) {
  auto coordinates = vtkSmartPointer<vtkFloatArray>::New();
  coordinates->SetNumberOfComponents(3);
  coordinates->SetNumberOfTuples(count);
  float* xyz = coordinates->GetPointer(0);
  for (vtkIdType i = 0; i < count; ++i) std::copy_n(positions[index(i)].data(), 3, xyz + 3 * i);
  auto points = vtkSmartPointer<vtkPoints>::New();
  points->SetData(coordinates);

  // One vertex cell per point, built as flat offset/connectivity arrays (fast for millions), in
  // 32-bit storage: 8 bytes a point instead of 16 on site-sized scans.
  auto offsets = vtkSmartPointer<vtkTypeInt32Array>::New();
  auto connectivity = vtkSmartPointer<vtkTypeInt32Array>::New();
  offsets->SetNumberOfValues(count + 1);
  connectivity->SetNumberOfValues(count);
  for (vtkIdType i = 0; i <= count; ++i) offsets->SetValue(i, static_cast<vtkTypeInt32>(i));
  for (vtkIdType i = 0; i < count; ++i) connectivity->SetValue(i, static_cast<vtkTypeInt32>(i));
  auto vertices = vtkSmartPointer<vtkCellArray>::New();
  vertices->SetData(offsets, connectivity);

  auto polyData = vtkSmartPointer<vtkPolyData>::New();
  polyData->SetPoints(points);
  polyData->SetVerts(vertices);
  if (!colors.empty() && count > 0) {
    auto array = vtkSmartPointer<vtkUnsignedCharArray>::New();
    array->SetName("colors");
    array->SetNumberOfComponents(3);
    array->SetNumberOfTuples(count);
    unsigned char* rgb = array->GetPointer(0);
    for (vtkIdType i = 0; i < count; ++i) std::copy_n(colors[index(i)].data(), 3, rgb + 3 * i);
    polyData->GetPointData()->SetScalars(array);
  }
  return polyData;
}

}  // namespace

vtkSmartPointer<vtkPolyData> makePointSet(const std::vector<Eigen::Vector3f>& positions,
                                          const std::vector<Rgb>& colors) {
  return pointSet(positions, colors, static_cast<vtkIdType>(positions.size()),
                  [](vtkIdType i) { return static_cast<std::size_t>(i); });
}

vtkSmartPointer<vtkPolyData> makePointSet(const std::vector<Eigen::Vector3f>& positions, const std::vector<Rgb>& colors,
                                          const std::vector<std::uint32_t>& indices) {
  return pointSet(positions, colors, static_cast<vtkIdType>(indices.size()),
                  [&](vtkIdType i) { return static_cast<std::size_t>(indices[static_cast<std::size_t>(i)]); });
}

MeshBuilder::MeshBuilder()
    : points_(vtkSmartPointer<vtkPoints>::New()),
      triangles_(vtkSmartPointer<vtkCellArray>::New()),
      lines_(vtkSmartPointer<vtkCellArray>::New()) {}

vtkIdType MeshBuilder::addPoint(const Eigen::Vector3d& point) { return points_->InsertNextPoint(point.data()); }

void MeshBuilder::addTriangle(vtkIdType a, vtkIdType b, vtkIdType c, Rgb color, int element) {
  const vtkIdType ids[3] = {a, b, c};
  triangles_->InsertNextCell(3, ids);
  triangleColors_.push_back(color);
  triangleElements_.push_back(element);
}

void orthonormalBasis(const Eigen::Vector3d& axis, Eigen::Vector3d& u, Eigen::Vector3d& v) {
  const Eigen::Vector3d helper = std::abs(axis.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
  u = axis.cross(helper).normalized();
  v = axis.cross(u).normalized();
}

void MeshBuilder::addTube(const std::vector<Eigen::Vector3d>& axis, double radius, Rgb color, int element, int sides) {
  if (axis.size() < 2) return;
  // Rings perpendicular to the local tangent; the ring frame is carried along the polyline by
  // rotating it with the tangent (parallel transport), so elbows do not twist.
  Eigen::Vector3d tangent = (axis[1] - axis[0]).normalized();
  Eigen::Vector3d u, v;
  orthonormalBasis(tangent, u, v);
  std::vector<vtkIdType> previousRing, ring(static_cast<std::size_t>(sides));
  for (std::size_t k = 0; k < axis.size(); ++k) {
    const Eigen::Vector3d next =
        k + 1 < axis.size() ? (axis[k + 1] - axis[k]).normalized() : (axis[k] - axis[k - 1]).normalized();
    const Eigen::Vector3d ringNormal = k == 0 || k + 1 == axis.size() ? next : (tangent + next).normalized();
    const Eigen::Quaterniond turn = Eigen::Quaterniond::FromTwoVectors(tangent, ringNormal);
    u = (turn * u).normalized();
    v = ringNormal.cross(u).normalized();
    tangent = ringNormal;
    for (int s = 0; s < sides; ++s) {
      const double angle = 2.0 * M_PI * s / sides;
      ring[static_cast<std::size_t>(s)] = addPoint(axis[k] + radius * (std::cos(angle) * u + std::sin(angle) * v));
    }
    if (!previousRing.empty()) {
      for (int s = 0; s < sides; ++s) {
        const auto a = previousRing[static_cast<std::size_t>(s)];
        const auto b = previousRing[static_cast<std::size_t>((s + 1) % sides)];
        const auto c = ring[static_cast<std::size_t>((s + 1) % sides)];
        const auto d = ring[static_cast<std::size_t>(s)];
        addTriangle(a, b, c, color, element);
        addTriangle(a, c, d, color, element);
      }
    } else {
      const vtkIdType center = addPoint(axis[k]);
      for (int s = 0; s < sides; ++s)
        addTriangle(center, ring[static_cast<std::size_t>((s + 1) % sides)], ring[static_cast<std::size_t>(s)], color,
                    element);
    }
    previousRing = ring;
    if (k + 1 == axis.size()) {
      const vtkIdType center = addPoint(axis[k]);
      for (int s = 0; s < sides; ++s)
        addTriangle(center, ring[static_cast<std::size_t>(s)], ring[static_cast<std::size_t>((s + 1) % sides)], color,
                    element);
    }
  }
}

void MeshBuilder::addPolyline(const std::vector<Eigen::Vector3d>& points, Rgb color, int element, bool closed) {
  if (points.size() < 2) return;
  std::vector<vtkIdType> ids;
  for (const auto& point : points) ids.push_back(addPoint(point));
  if (closed) ids.push_back(ids.front());
  lines_->InsertNextCell(static_cast<vtkIdType>(ids.size()), ids.data());
  lineColors_.push_back(color);
  lineElements_.push_back(element);
}

void MeshBuilder::addArrow(const Eigen::Vector3d& from, const Eigen::Vector3d& direction, double length,
                           double shaftRadius, Rgb color, int element) {
  const double headLength = std::min(0.25 * length, 8.0 * shaftRadius);
  const Eigen::Vector3d headBase = from + (length - headLength) * direction;
  addTube({from, headBase}, shaftRadius, color, element, 16);
  Eigen::Vector3d u, v;
  orthonormalBasis(direction, u, v);
  const int sides = 24;
  const vtkIdType tip = addPoint(from + length * direction);
  const vtkIdType baseCenter = addPoint(headBase);
  std::vector<vtkIdType> ring;
  for (int s = 0; s < sides; ++s) {
    const double angle = 2.0 * M_PI * s / sides;
    ring.push_back(addPoint(headBase + 2.5 * shaftRadius * (std::cos(angle) * u + std::sin(angle) * v)));
  }
  for (int s = 0; s < sides; ++s) {
    addTriangle(ring[static_cast<std::size_t>(s)], ring[static_cast<std::size_t>((s + 1) % sides)], tip, color,
                element);
    addTriangle(baseCenter, ring[static_cast<std::size_t>((s + 1) % sides)], ring[static_cast<std::size_t>(s)], color,
                element);
  }
}

bool MeshBuilder::empty() const { return triangleColors_.empty() && lineColors_.empty(); }

vtkSmartPointer<vtkPolyData> MeshBuilder::build() {
  auto polyData = vtkSmartPointer<vtkPolyData>::New();
  polyData->SetPoints(points_);
  polyData->SetPolys(triangles_);
  polyData->SetLines(lines_);
  // VTK orders cell data verts, lines, polys, strips: lines come before triangles.
  std::vector<Rgb> colors = lineColors_;
  colors.insert(colors.end(), triangleColors_.begin(), triangleColors_.end());
  std::vector<int> elements = lineElements_;
  elements.insert(elements.end(), triangleElements_.begin(), triangleElements_.end());
  if (!colors.empty()) {
    polyData->GetCellData()->SetScalars(colorArray(colors));
    auto elementArray = vtkSmartPointer<vtkIntArray>::New();
    elementArray->SetName(kElementArray);
    elementArray->SetNumberOfValues(static_cast<vtkIdType>(elements.size()));
    std::copy(elements.begin(), elements.end(), elementArray->GetPointer(0));
    polyData->GetCellData()->AddArray(elementArray);
  }
  return polyData;
}

std::vector<Eigen::Vector3d> circlePoints(const Eigen::Vector3d& center, const Eigen::Vector3d& axis, double radius,
                                          int segments) {
  Eigen::Vector3d u, v;
  orthonormalBasis(axis.normalized(), u, v);
  std::vector<Eigen::Vector3d> points;
  for (int s = 0; s < segments; ++s) {
    const double angle = 2.0 * M_PI * s / segments;
    points.push_back(center + radius * (std::cos(angle) * u + std::sin(angle) * v));
  }
  return points;
}

}  // namespace piperun::ui
