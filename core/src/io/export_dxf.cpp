// ASCII DXF, release 12 (AC1009), which every CAD tool reads: each element's centre line as a 3-D
// POLYLINE on the layer of its type (PIPE, ELBOW, TEE, BOUNDARY), coordinates in metres, and the
// element's properties as extended data of the registered application PIPERUN.

#include "io/export_elements.h"

#include <cstdio>
#include <iterator>

namespace piperun::io {

namespace {

constexpr const char* kApplication = "PIPERUN";

struct Layer {
  ElementKind kind;
  const char* name;
  int colour;  // AutoCAD colour index
};

constexpr Layer kLayers[] = {{ElementKind::Pipe, "PIPE", 7},
                             {ElementKind::Elbow, "ELBOW", 1},
                             {ElementKind::Tee, "TEE", 3},
                             {ElementKind::Boundary, "BOUNDARY", 5}};

const char* layerName(ElementKind kind) {
  for (const auto& layer : kLayers) {
    if (layer.kind == kind) return layer.name;
  }
  return kLayers[0].name;
}

// A DXF file is a sequence of (group code, value) pairs, one line each.
class DxfText {
 public:
  void group(int code, const std::string& value) {
    char line[8];
    std::snprintf(line, sizeof line, "%3d\n", code);
    text_ += line;
    text_ += value;
    text_ += '\n';
  }
  void group(int code, int value) { group(code, std::to_string(value)); }
  void real(int code, double value) { group(code, shortestNumber(value)); }
  void point(int firstCode, const Eigen::Vector3d& p) {
    real(firstCode, p.x());
    real(firstCode + 10, p.y());
    real(firstCode + 20, p.z());
  }
  std::string& text() { return text_; }

 private:
  std::string text_;
};

}  // namespace

std::string dxfDocument(const std::vector<ExportElement>& elements) {
  DxfText dxf;
  Eigen::Vector3d low = Eigen::Vector3d::Zero();
  Eigen::Vector3d high = Eigen::Vector3d::Zero();
  bool first = true;
  for (const auto& element : elements) {
    for (const auto& p : element.axis) {
      low = first ? p : low.cwiseMin(p);
      high = first ? p : high.cwiseMax(p);
      first = false;
    }
  }

  dxf.group(999, "PipeRun " PIPERUN_VERSION " network export, units: metres");
  dxf.group(0, "SECTION");
  dxf.group(2, "HEADER");
  dxf.group(9, "$ACADVER");
  dxf.group(1, "AC1009");
  // Release 12 has no drawing units: without them a CAD tool takes the coordinates in its own
  // default (millimetres or inches). Later releases' units variables say metres to those that read
  // them; the others skip them.
  dxf.group(9, "$INSUNITS");
  dxf.group(70, 6);  // metres
  dxf.group(9, "$MEASUREMENT");
  dxf.group(70, 1);  // metric
  dxf.group(9, "$EXTMIN");
  dxf.point(10, low);
  dxf.group(9, "$EXTMAX");
  dxf.point(10, high);
  dxf.group(0, "ENDSEC");

  dxf.group(0, "SECTION");
  dxf.group(2, "TABLES");
  dxf.group(0, "TABLE");
  dxf.group(2, "LTYPE");
  dxf.group(70, 1);
  dxf.group(0, "LTYPE");
  dxf.group(2, "CONTINUOUS");
  dxf.group(70, 0);
  dxf.group(3, "Solid line");
  dxf.group(72, 65);
  dxf.group(73, 0);
  dxf.real(40, 0.0);
  dxf.group(0, "ENDTAB");
  dxf.group(0, "TABLE");
  dxf.group(2, "LAYER");
  dxf.group(70, static_cast<int>(std::size(kLayers)));
  for (const auto& layer : kLayers) {
    dxf.group(0, "LAYER");
    dxf.group(2, layer.name);
    dxf.group(70, 0);
    dxf.group(62, layer.colour);
    dxf.group(6, "CONTINUOUS");
  }
  dxf.group(0, "ENDTAB");
  dxf.group(0, "TABLE");
  dxf.group(2, "APPID");
  dxf.group(70, 1);
  dxf.group(0, "APPID");
  dxf.group(2, kApplication);
  dxf.group(70, 0);
  dxf.group(0, "ENDTAB");
  dxf.group(0, "ENDSEC");

  dxf.group(0, "SECTION");
  dxf.group(2, "ENTITIES");
  for (const auto& element : elements) {
    const char* layer = layerName(element.kind);
    dxf.group(0, "POLYLINE");
    dxf.group(8, layer);
    dxf.group(66, 1);  // vertices follow
    dxf.point(10, Eigen::Vector3d::Zero());
    dxf.group(70, 8);  // 3-D polyline
    dxf.group(1001, kApplication);
    dxf.group(1000, element.name);
    dxf.real(1040, element.radius);
    dxf.group(1071, element.runId);
    dxf.real(1040, element.bendRadius);
    dxf.real(1040, element.confidence);
    dxf.group(1000, element.status);
    for (const auto& p : element.axis) {
      dxf.group(0, "VERTEX");
      dxf.group(8, layer);
      dxf.point(10, p);
      dxf.group(70, 32);  // vertex of a 3-D polyline
    }
    dxf.group(0, "SEQEND");
    dxf.group(8, layer);
  }
  dxf.group(0, "ENDSEC");
  dxf.group(0, "EOF");
  return std::move(dxf.text());
}

}  // namespace piperun::io
