// Binary little-endian PLY mesh: the elements' closed tubes as triangles; every face carries the
// id and type of its element (`element_id`, `element_type`) so viewers can select by element.

#include "io/export_elements.h"
#include "io/export_mesh.h"

#include <cstring>

namespace piperun::io {

namespace {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "the PLY export stores values in host byte order");

// Beyond this distance from the origin (m) float coordinates lose more than ~0.1 mm, and the
// vertices are written as doubles instead.
constexpr double kFloatRange = 1000.0;

template <class T>
void appendValue(std::string& bytes, T value) {
  char raw[sizeof(T)];
  std::memcpy(raw, &value, sizeof(T));
  bytes.append(raw, sizeof(T));
}

}  // namespace

std::string plyDocument(const std::vector<ExportElement>& elements, const ExportOptions& options) {
  const NetworkMesh mesh = meshElements(elements, options);
  bool doublePositions = false;
  for (const auto& v : mesh.vertices) doublePositions = doublePositions || v.cwiseAbs().maxCoeff() > kFloatRange;
  const char* positionType = doublePositions ? "double" : "float";

  std::string bytes = "ply\nformat binary_little_endian 1.0\n";
  bytes += "comment PipeRun " PIPERUN_VERSION " network export, units: metres\n";
  bytes += "comment element_type: 0 pipe, 1 elbow, 2 tee, 3 boundary; element_id: the pipe or joint id\n";
  bytes += "element vertex " + std::to_string(mesh.vertices.size()) + "\n";
  for (const char* axis : {"x", "y", "z"}) bytes += std::string("property ") + positionType + " " + axis + "\n";
  bytes += "element face " + std::to_string(mesh.triangles.size()) + "\n";
  bytes += "property list uchar int vertex_indices\nproperty int element_id\nproperty uchar element_type\n";
  bytes += "end_header\n";

  for (const auto& v : mesh.vertices) {
    for (int c = 0; c < 3; ++c) {
      if (doublePositions) {
        appendValue(bytes, v[c]);
      } else {
        appendValue(bytes, static_cast<float>(v[c]));
      }
    }
  }
  for (std::size_t e = 0; e < elements.size(); ++e) {
    const auto& part = mesh.parts[e];
    for (std::size_t t = part.firstTriangle; t < part.firstTriangle + part.triangleCount; ++t) {
      appendValue(bytes, std::uint8_t{3});
      for (int index : mesh.triangles[t]) appendValue(bytes, std::int32_t{index});
      appendValue(bytes, std::int32_t{elements[e].id});
      appendValue(bytes, static_cast<std::uint8_t>(elements[e].kind));
    }
  }
  return bytes;
}

}  // namespace piperun::io
