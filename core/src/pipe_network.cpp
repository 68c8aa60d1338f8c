#include "piperun/pipe_network.h"

#include <Eigen/Geometry>

#include <cmath>
#include <set>
#include <stdexcept>

namespace piperun {

Eigen::Vector3d Pipe::direction() const {
  const Eigen::Vector3d d = end - start;
  const double length = d.norm();
  return length > 0.0 ? Eigen::Vector3d(d / length) : Eigen::Vector3d::Zero();
}

double Joint::length() const {
  double total = 0.0;
  for (std::size_t i = 1; i < axis.size(); ++i) total += (axis[i] - axis[i - 1]).norm();
  return total;
}

void PipeNetwork::turn(const Eigen::Matrix3d& turn) {
  for (Pipe& pipe : pipes) {
    pipe.start = turn * pipe.start;
    pipe.end = turn * pipe.end;
  }
  for (Joint& joint : joints) {
    for (Eigen::Vector3d& point : joint.axis) point = turn * point;
  }
}

Eigen::Vector3d Joint::position() const {
  if (axis.empty()) return Eigen::Vector3d::Zero();
  if (type == JointType::Tee) return axis.front();
  // Point halfway along the polyline.
  const double half = 0.5 * length();
  double walked = 0.0;
  for (std::size_t i = 1; i < axis.size(); ++i) {
    const double step = (axis[i] - axis[i - 1]).norm();
    if (walked + step >= half && step > 0.0) {
      return axis[i - 1] + (half - walked) / step * (axis[i] - axis[i - 1]);
    }
    walked += step;
  }
  return axis.back();
}

namespace {
template <class Element>
Element* findById(std::vector<Element>& elements, int id) {
  for (auto& element : elements) {
    if (element.id == id) return &element;
  }
  return nullptr;
}
}  // namespace

const Pipe* PipeNetwork::findPipe(int id) const { return findById(const_cast<std::vector<Pipe>&>(pipes), id); }
const Joint* PipeNetwork::findJoint(int id) const { return findById(const_cast<std::vector<Joint>&>(joints), id); }
Pipe* PipeNetwork::findPipe(int id) { return findById(pipes, id); }
Joint* PipeNetwork::findJoint(int id) { return findById(joints, id); }

void PipeNetwork::validate() const {
  const auto fail = [](const std::string& message) { throw std::invalid_argument(message); };
  std::set<int> pipeIds;
  for (const auto& pipe : pipes) {
    const std::string name = "pipe " + std::to_string(pipe.id);
    if (!pipeIds.insert(pipe.id).second) fail("duplicate pipe id " + std::to_string(pipe.id));
    if (!(pipe.radius > 0.0) || !std::isfinite(pipe.radius)) fail(name + ": radius must be positive");
    if (!pipe.start.allFinite() || !pipe.end.allFinite()) fail(name + ": axis has a non-finite coordinate");
  }
  std::set<int> jointIds;
  for (const auto& joint : joints) {
    const std::string name = "joint " + std::to_string(joint.id);
    if (!jointIds.insert(joint.id).second) fail("duplicate joint id " + std::to_string(joint.id));
    if (!(joint.radius > 0.0) || !std::isfinite(joint.radius)) fail(name + ": radius must be positive");
    if (joint.axis.size() < 2) fail(name + ": axis needs at least two points");
    for (const auto& point : joint.axis) {
      if (!point.allFinite()) fail(name + ": axis has a non-finite coordinate");
    }
    for (int pipeId : joint.pipeIds) {
      if (!pipeIds.count(pipeId)) fail(name + " refers to unknown pipe " + std::to_string(pipeId));
    }
  }
  std::set<int> runIds;
  for (const auto& run : runs) {
    const std::string name = "run " + std::to_string(run.id);
    if (!runIds.insert(run.id).second) fail("duplicate run id " + std::to_string(run.id));
    for (int pipeId : run.pipeIds) {
      if (!pipeIds.count(pipeId)) fail(name + " refers to unknown pipe " + std::to_string(pipeId));
    }
    for (int jointId : run.jointIds) {
      if (!jointIds.count(jointId)) fail(name + " refers to unknown joint " + std::to_string(jointId));
    }
  }
}

std::string toString(PipeStatus status) {
  switch (status) {
    case PipeStatus::Accepted: return "accepted";
    case PipeStatus::Proposed: return "proposed";
    case PipeStatus::Deleted: return "deleted";
  }
  return "accepted";
}

std::string toString(JointType type) {
  switch (type) {
    case JointType::Elbow: return "elbow";
    case JointType::Tee: return "tee";
    case JointType::Boundary: return "boundary";
  }
  return "elbow";
}

std::string toString(JointStatus status) {
  switch (status) {
    case JointStatus::Proposed: return "proposed";
    case JointStatus::Accepted: return "accepted";
    case JointStatus::Rejected: return "rejected";
  }
  return "proposed";
}

std::optional<PipeStatus> pipeStatusFromString(const std::string& text) {
  if (text == "accepted") return PipeStatus::Accepted;
  if (text == "proposed") return PipeStatus::Proposed;
  if (text == "deleted") return PipeStatus::Deleted;
  return std::nullopt;
}

std::optional<JointType> jointTypeFromString(const std::string& text) {
  if (text == "elbow") return JointType::Elbow;
  if (text == "tee") return JointType::Tee;
  if (text == "boundary") return JointType::Boundary;
  return std::nullopt;
}

std::optional<JointStatus> jointStatusFromString(const std::string& text) {
  if (text == "proposed") return JointStatus::Proposed;
  if (text == "accepted") return JointStatus::Accepted;
  if (text == "rejected") return JointStatus::Rejected;
  return std::nullopt;
}

std::vector<Eigen::Vector3d> samplePolyline(const std::vector<Eigen::Vector3d>& polyline, double step) {
  if (!(step > 0.0)) throw std::invalid_argument("samplePolyline: step must be positive");
  std::vector<Eigen::Vector3d> samples;
  if (polyline.empty()) return samples;
  samples.push_back(polyline.front());
  for (std::size_t i = 1; i < polyline.size(); ++i) {
    const Eigen::Vector3d& a = polyline[i - 1];
    const Eigen::Vector3d& b = polyline[i];
    const double length = (b - a).norm();
    const auto pieces = static_cast<std::size_t>(std::ceil(length / step));
    for (std::size_t k = 1; k <= pieces; ++k) {
      samples.push_back(a + (b - a) * (static_cast<double>(k) / static_cast<double>(pieces)));
    }
  }
  return samples;
}

std::vector<Eigen::Vector3d> sampleArc(const Eigen::Vector3d& center, const Eigen::Vector3d& start,
                                       const Eigen::Vector3d& end, double step) {
  if (!(step > 0.0)) throw std::invalid_argument("sampleArc: step must be positive");
  const Eigen::Vector3d from = start - center;
  const Eigen::Vector3d to = end - center;
  const double radius = from.norm();
  if (!(radius > 0.0)) return {start, end};
  const Eigen::Vector3d normal = from.cross(to);
  const double angle = std::atan2(normal.norm(), from.dot(to));
  if (normal.norm() < 1e-12 * radius * radius) {
    // Degenerate plane (0° or 180°): a straight polyline is the only sensible answer.
    return samplePolyline({start, end}, step);
  }
  const Eigen::Vector3d axis = normal.normalized();
  // The chord between samples is at most step; each arc piece subtends at most step / radius.
  const auto pieces = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(angle * radius / step)));
  std::vector<Eigen::Vector3d> samples;
  samples.reserve(pieces + 1);
  for (std::size_t k = 0; k <= pieces; ++k) {
    const double t = angle * static_cast<double>(k) / static_cast<double>(pieces);
    samples.push_back(center + Eigen::AngleAxisd(t, axis) * from);
  }
  samples.back() = end;
  return samples;
}

}  // namespace piperun
