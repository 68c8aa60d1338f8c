// CSV (RFC 4180: CRLF line ends, a header row): one row per element, with the nominal size nearest
// its radius (NPS and DN), the lowest and highest heights its tube reaches along the up axis (a
// level pipe's bottom and top of pipe), a straight piece's slope and an elbow's angle. No field
// ever holds a comma, quote or line break, so none is quoted.

#include "io/export_elements.h"

#include "piperun/pipe_measures.h"

namespace piperun::io {

std::string csvDocument(const std::vector<ExportElement>& elements, const NominalSizes& sizes, UpAxis up) {
  std::string text =
      "id,type,run,radius_m,length_m,start_x,start_y,start_z,end_x,end_y,end_z,bend_radius_m,confidence,status,nps,dn,"
      "lowest_m,highest_m,slope_deg,bend_angle_deg\r\n";
  for (const auto& element : elements) {
    const Eigen::Vector3d& start = element.axis.front();
    const Eigen::Vector3d& end = element.axis.back();
    text += std::to_string(element.id) + "," + kindName(element.kind) + ",";
    if (element.runId >= 0) text += std::to_string(element.runId);
    text += "," + shortestNumber(element.radius) + "," + shortestNumber(element.length());
    for (const auto* point : {&start, &end}) {
      for (int c = 0; c < 3; ++c) text += "," + shortestNumber((*point)[c]);
    }
    text += ",";
    if (element.kind == ElementKind::Elbow) text += shortestNumber(element.bendRadius);
    const NominalSize& size = sizes.nearest(element.radius);
    text += "," + shortestNumber(element.confidence) + "," + element.status + "," + size.nps + "," +
            std::to_string(size.dn);
    const TubeHeights heights = tubeHeights(element.axis, element.radius, up);
    text += "," + shortestNumber(heights.lowest) + "," + shortestNumber(heights.highest) + ",";
    if (element.kind == ElementKind::Pipe || element.kind == ElementKind::Boundary) {
      text += shortestNumber(pipeLie(start, end, up).slopeDegrees);
    }
    text += ",";
    if (element.kind == ElementKind::Elbow) {
      if (const auto bend = bendOf(element.axis)) text += shortestNumber(bend->angleDegrees());
    }
    text += "\r\n";
  }
  return text;
}

}  // namespace piperun::io
