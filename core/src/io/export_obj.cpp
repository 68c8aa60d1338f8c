// Wavefront OBJ: the elements' closed tubes as triangles, each element its own object and group
// ("o pipe-12" and "g pipe-12"; some tools select by object, others by group).

#include "io/export_elements.h"
#include "io/export_mesh.h"

namespace piperun::io {

std::string objDocument(const std::vector<ExportElement>& elements, const ExportOptions& options) {
  const NetworkMesh mesh = meshElements(elements, options);
  std::string text;
  text += "# PipeRun " PIPERUN_VERSION " network export: " + std::to_string(elements.size()) +
          " elements (closed tubes), units: metres\n";
  for (std::size_t e = 0; e < elements.size(); ++e) {
    const auto& part = mesh.parts[e];
    text += "o " + elements[e].name + "\ng " + elements[e].name + "\n";
    for (std::size_t i = part.firstVertex; i < part.firstVertex + part.vertexCount; ++i) {
      const auto& v = mesh.vertices[i];
      text += "v " + shortestNumber(v.x()) + " " + shortestNumber(v.y()) + " " + shortestNumber(v.z()) + "\n";
    }
    for (std::size_t t = part.firstTriangle; t < part.firstTriangle + part.triangleCount; ++t) {
      // OBJ counts vertices from 1.
      const auto& triangle = mesh.triangles[t];
      text += "f " + std::to_string(triangle[0] + 1) + " " + std::to_string(triangle[1] + 1) + " " +
              std::to_string(triangle[2] + 1) + "\n";
    }
  }
  return text;
}

}  // namespace piperun::io
