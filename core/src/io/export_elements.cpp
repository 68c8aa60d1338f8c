#include "io/export_elements.h"

#include <charconv>
#include <map>

namespace piperun::io {

namespace {

ElementKind kindOf(JointType type) {
  switch (type) {
    case JointType::Elbow: return ElementKind::Elbow;
    case JointType::Tee: return ElementKind::Tee;
    case JointType::Boundary: return ElementKind::Boundary;
  }
  return ElementKind::Boundary;
}

}  // namespace

const char* kindName(ElementKind kind) {
  switch (kind) {
    case ElementKind::Pipe: return "pipe";
    case ElementKind::Elbow: return "elbow";
    case ElementKind::Tee: return "tee";
    case ElementKind::Boundary: return "boundary";
  }
  return "pipe";
}

double ExportElement::length() const {
  double total = 0.0;
  for (std::size_t i = 1; i < axis.size(); ++i) total += (axis[i] - axis[i - 1]).norm();
  return total;
}

std::vector<ExportElement> exportedElements(const PipeNetwork& network) {
  std::map<int, int> runOfPipe;
  std::map<int, int> runOfJoint;
  for (const auto& run : network.runs) {
    for (int id : run.pipeIds) runOfPipe.emplace(id, run.id);
    for (int id : run.jointIds) runOfJoint.emplace(id, run.id);
  }

  std::vector<ExportElement> elements;
  for (const auto& pipe : network.pipes) {
    if (pipe.status == PipeStatus::Deleted) continue;
    ExportElement element;
    element.kind = ElementKind::Pipe;
    element.id = pipe.id;
    element.name = "pipe-" + std::to_string(pipe.id);
    element.radius = pipe.radius;
    element.axis = {pipe.start, pipe.end};
    element.confidence = pipe.confidence;
    element.status = toString(pipe.status);
    const auto run = runOfPipe.find(pipe.id);
    element.runId = run != runOfPipe.end() ? run->second : pipe.runId;
    elements.push_back(std::move(element));
  }
  for (const auto& joint : network.joints) {
    if (joint.status == JointStatus::Rejected) continue;
    ExportElement element;
    element.kind = kindOf(joint.type);
    element.id = joint.id;
    element.name = std::string(kindName(element.kind)) + "-" + std::to_string(joint.id);
    element.radius = joint.radius;
    element.axis = joint.axis;
    element.bendRadius = joint.type == JointType::Elbow ? joint.bendRadius : 0.0;
    element.confidence = joint.confidence;
    element.status = toString(joint.status);
    const auto run = runOfJoint.find(joint.id);
    element.runId = run != runOfJoint.end() ? run->second : -1;
    element.joint = &joint;
    elements.push_back(std::move(element));
  }
  return elements;
}

std::string shortestNumber(double value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, result.ptr);
}

}  // namespace piperun::io
