#pragma once
// Building VTK poly data for the layers: point sets, tubes around axes, circles, arrows.
// Everything is in the display frame (world minus the document's display origin), so float
// vertex coordinates keep millimetres far from (0, 0, 0).

#include "palette.h"

#include <Eigen/Core>
#include <vtkSmartPointer.h>

#include <cstdint>
#include <vector>

class vtkPolyData;
class vtkUnsignedCharArray;
class vtkIntArray;
class vtkPoints;
class vtkCellArray;

namespace piperun::ui {

/// Name of the cell (or point) array holding the element id (pipe, joint, circle, direction).
constexpr const char* kElementArray = "element";

/// Points as vertices with an RGB array; `colors` empty for a uniform colour set on the actor.
vtkSmartPointer<vtkPolyData> makePointSet(const std::vector<Eigen::Vector3f>& positions,
                                          const std::vector<Rgb>& colors);

/// The points `indices` of `positions` (and of `colors`, unless empty) as vertices.
vtkSmartPointer<vtkPolyData> makePointSet(const std::vector<Eigen::Vector3f>& positions, const std::vector<Rgb>& colors,
                                          const std::vector<std::uint32_t>& indices);


/// Triangles, lines and their per-cell colour and element id, filled piece by piece.
class MeshBuilder {
 public:
  MeshBuilder();

  /// A closed tube of `radius` along a polyline (at least two points), with `sides` facets and
  /// flat end caps.
  void addTube(const std::vector<Eigen::Vector3d>& axis, double radius, Rgb color, int element, int sides = 20);
  /// A polyline (drawn as lines).
  void addPolyline(const std::vector<Eigen::Vector3d>& points, Rgb color, int element, bool closed = false);
  /// An arrow from `from` along `direction` (unit) of `length`: a shaft tube and a cone head.
  void addArrow(const Eigen::Vector3d& from, const Eigen::Vector3d& direction, double length, double shaftRadius,
                Rgb color, int element);

  bool empty() const;
  vtkSmartPointer<vtkPolyData> build();

 private:
  vtkIdType addPoint(const Eigen::Vector3d& point);
  void addTriangle(vtkIdType a, vtkIdType b, vtkIdType c, Rgb color, int element);

  vtkSmartPointer<vtkPoints> points_;
  vtkSmartPointer<vtkCellArray> triangles_;
  vtkSmartPointer<vtkCellArray> lines_;
  std::vector<Rgb> triangleColors_, lineColors_;
  std::vector<int> triangleElements_, lineElements_;
};

/// Two unit vectors completing `axis` (unit) to an orthonormal basis.
void orthonormalBasis(const Eigen::Vector3d& axis, Eigen::Vector3d& u, Eigen::Vector3d& v);

/// A circle of `radius` around `center` in the plane orthogonal to `axis`, as `segments` points.
std::vector<Eigen::Vector3d> circlePoints(const Eigen::Vector3d& center, const Eigen::Vector3d& axis, double radius,
                                          int segments = 96);

}  // namespace piperun::ui
