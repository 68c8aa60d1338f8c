#pragma once
// Triangle meshes of network elements for the OBJ and PLY exports: a closed tube (capped at both
// ends) swept along each element's centre line, so a pipe becomes a cylinder and an elbow's arc a
// torus section.

#include "io/export_elements.h"

#include <array>
#include <vector>

namespace piperun::io {

struct NetworkMesh {
  /// The vertices and triangles of one element, as ranges of the shared arrays.
  struct Part {
    std::size_t firstVertex = 0;
    std::size_t vertexCount = 0;
    std::size_t firstTriangle = 0;
    std::size_t triangleCount = 0;
  };

  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<int, 3>> triangles;  ///< Counter-clockwise seen from outside.
  std::vector<Part> parts;                    ///< One per element, in the elements' order.
};

/// Meshes every element. An element whose centre line has no length gets an empty part.
NetworkMesh meshElements(const std::vector<ExportElement>& elements, const ExportOptions& options);

}  // namespace piperun::io
