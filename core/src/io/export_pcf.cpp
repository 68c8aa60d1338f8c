// Piping Component File (PCF), the input of ISOGEN and other piping isometric tools.
//
// Units header (bore and co-ordinates in millimetres), then one PIPELINE-REFERENCE per pipeline:
// a run ("RUN-<id>"), or for elements in no run each group connected through joints
// ("GROUP-<n>", numbered in network order). Components:
//   PIPE   two END-POINTs (x y z bore). A pipe that hosts tees is cut around them; boundary joints
//          are PIPEs too (they are straight pipe pieces), or REDUCER-CONCENTRICs (SKEY RCBW) where
//          the bore changes across them.
//   ELBOW  two END-POINTs, CENTRE-POINT (where the tangent lines at the two ends meet), SKEY ELBW.
//          An arc of more than 95° is written as equal elbows of at most 90° (a 90° fitting fitted
//          a few degrees wide stays one elbow).
//   TEE    two END-POINTs on the main pipe, CENTRE-POINT on the main axis, BRANCH1-POINT (x y z
//          bore) at the branch pipe's end, SKEY TEBW. Its arms are all as long as the branch arm.
// Tools connect components by matching END-POINT co-ordinates. A bore is, by PcfBore, the nominal
// size (DN) nearest the fitted diameter, each joint's END-POINTs taking the bores of the pipes they
// meet (so connected END-POINTs agree), or the fitted outside diameter of each element.

#include "angles.h"
#include "piperun/pipe_measures.h"
#include "io/export_elements.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numeric>
#include <optional>

namespace piperun::io {

namespace {

// Pipe pieces shorter than this (m), as left between close tees, are not written.
constexpr double kShortestPiece = 1e-4;
// How far past 90° a fitted bend may reach and still be one ELBOW: the fitted axes' directions err
// by a few degrees, so a 90.7° bend is a 90° fitting, not two 45° ones.
constexpr double kElbowAngleSlack = 5.0 * kDegree;

std::string millimetres(double metres) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f", metres * 1000.0);
  return std::string(text) == "-0.0" ? "0.0" : text;
}

std::string boreText(double mm) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1f", mm);
  return text;
}

std::string coordinates(const Eigen::Vector3d& p) {
  return millimetres(p.x()) + " " + millimetres(p.y()) + " " + millimetres(p.z());
}

/// The bores written (mm): nominal sizes, or fitted outside diameters.
class Bores {
 public:
  /// `sizes`: the nominal sizes' table; nullptr: outside diameters.
  Bores(const NominalSizes* sizes, const std::map<int, const ExportElement*>& pipes) : pipes_(pipes), sizes_(sizes) {}

  /// A pipe of `radius` (m).
  double of(double radius) const {
    return sizes_ ? static_cast<double>(sizes_->nearest(radius).dn) : 2.0 * radius * 1000.0;
  }
  /// At `point` on `joint`: nominal, the bore of the joint's exported pipe whose end is nearest
  /// (the joint's own where it has none), so the joint's END-POINT agrees with the pipe's; the
  /// joint's own outside diameter otherwise.
  double atEnd(const ExportElement& joint, const Eigen::Vector3d& point) const {
    if (!sizes_) return of(joint.radius);
    const ExportElement* nearest = nullptr;
    double nearestDistance = 0.0;
    for (int id : joint.joint->pipeIds) {
      const auto found = pipes_.find(id);
      if (found == pipes_.end()) continue;
      const auto& axis = found->second->axis;
      const double distance = std::min((axis.front() - point).norm(), (axis.back() - point).norm());
      if (!nearest || distance < nearestDistance) {
        nearest = found->second;
        nearestDistance = distance;
      }
    }
    return of(nearest ? nearest->radius : joint.radius);
  }
  /// A tee's branch: its branch pipe's bore (the second pipe it joins), when nominal.
  double branch(const ExportElement& tee) const {
    const auto& ids = tee.joint->pipeIds;
    const auto found = sizes_ && ids.size() > 1 ? pipes_.find(ids[1]) : pipes_.end();
    return of(found == pipes_.end() ? tee.radius : found->second->radius);
  }

 private:
  const std::map<int, const ExportElement*>& pipes_;
  const NominalSizes* sizes_;
};

class PcfText {
 public:
  void line(const std::string& text) { text_ += text + "\r\n"; }
  void endPoint(const Eigen::Vector3d& p, double bore) {
    line("    END-POINT " + coordinates(p) + " " + boreText(bore));
  }
  void pipe(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double bore) { straight(a, bore, b, bore); }
  /// A straight piece from `a` to `b`: a PIPE, or a concentric reducer where the bores differ.
  void straight(const Eigen::Vector3d& a, double boreA, const Eigen::Vector3d& b, double boreB) {
    line(boreA == boreB ? "PIPE" : "REDUCER-CONCENTRIC");
    endPoint(a, boreA);
    endPoint(b, boreB);
    if (boreA != boreB) line("    SKEY RCBW");
  }
  std::string& text() { return text_; }

 private:
  std::string text_;
};

struct Pipeline {
  std::string reference;
  std::vector<const ExportElement*> elements;
};

// Union-find over element indices.
int findRoot(std::vector<int>& parent, int i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

std::vector<Pipeline> pipelines(const std::vector<ExportElement>& elements) {
  std::map<int, Pipeline> runs;
  for (const auto& element : elements) {
    if (element.runId < 0) continue;
    Pipeline& pipeline = runs[element.runId];
    pipeline.reference = "RUN-" + std::to_string(element.runId);
    pipeline.elements.push_back(&element);
  }
  std::vector<Pipeline> result;
  for (auto& [id, pipeline] : runs) result.push_back(std::move(pipeline));

  // Elements in no run: connect each joint to its pipes.
  std::map<int, int> pipeIndex;
  for (std::size_t i = 0; i < elements.size(); ++i) {
    if (elements[i].kind == ElementKind::Pipe && elements[i].runId < 0) pipeIndex[elements[i].id] = static_cast<int>(i);
  }
  std::vector<int> parent(elements.size());
  std::iota(parent.begin(), parent.end(), 0);
  for (std::size_t i = 0; i < elements.size(); ++i) {
    if (!elements[i].joint || elements[i].runId >= 0) continue;
    for (int pipeId : elements[i].joint->pipeIds) {
      if (const auto found = pipeIndex.find(pipeId); found != pipeIndex.end()) {
        parent[findRoot(parent, static_cast<int>(i))] = findRoot(parent, found->second);
      }
    }
  }
  std::map<int, std::size_t> groupOfRoot;
  for (std::size_t i = 0; i < elements.size(); ++i) {
    if (elements[i].runId >= 0) continue;
    const int root = findRoot(parent, static_cast<int>(i));
    auto [group, added] = groupOfRoot.emplace(root, result.size());
    if (added) result.push_back({"GROUP-" + std::to_string(groupOfRoot.size()), {}});
    result[group->second].elements.push_back(&elements[i]);
  }
  return result;
}

// The tee geometry on its main pipe: centre on the main axis, arm length, main direction.
struct TeeLayout {
  const ExportElement* main = nullptr;
  Eigen::Vector3d direction = Eigen::Vector3d::Zero();
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double along = 0.0;  // centre's distance from the main pipe's start
  double arm = 0.0;
};

std::optional<TeeLayout> teeLayout(const ExportElement& tee, const std::map<int, const ExportElement*>& pipes) {
  const auto& ids = tee.joint->pipeIds;
  const auto found = ids.empty() ? pipes.end() : pipes.find(ids.front());
  if (found == pipes.end() || found->second->length() <= 0.0) return std::nullopt;
  TeeLayout layout;
  layout.main = found->second;
  const Eigen::Vector3d& start = layout.main->axis.front();
  layout.direction = (layout.main->axis.back() - start).normalized();
  layout.along = (tee.axis.front() - start).dot(layout.direction);
  layout.centre = start + layout.along * layout.direction;
  layout.arm = std::max((tee.axis.back() - layout.centre).norm(), layout.main->radius);
  return layout;
}

// Writes an elbow's arc as one ELBOW, as equal ELBOWs of at most 90° each when it bends more than
// 90° and the slack, or as a straight piece when it is straight; the bores at the arc's first and
// last points are `boreFirst` and `boreLast` (a reducing elbow split in pieces reduces in its first).
void writeElbow(const ExportElement& elbow, double boreFirst, double boreLast, PcfText& pcf) {
  const Eigen::Vector3d& a = elbow.axis.front();
  const Eigen::Vector3d& b = elbow.axis.back();
  const std::optional<Bend> bend = bendOf(elbow.axis);
  if (!bend) {
    pcf.straight(a, boreFirst, b, boreLast);
    return;
  }
  const Eigen::Vector3d& centre = bend->centre;
  const Eigen::Vector3d fromCentre = a - centre;
  const Eigen::Vector3d& axis = bend->axis;
  const double angle = bend->angle;
  const int pieces = std::max(1, static_cast<int>(std::ceil((angle - kElbowAngleSlack) / (0.5 * kPi) - 1e-6)));
  const double step = angle / pieces;
  const double bendRadius = fromCentre.norm();
  for (int j = 0; j < pieces; ++j) {
    const Eigen::Vector3d first = centre + Eigen::AngleAxisd(j * step, axis) * fromCentre;
    const Eigen::Vector3d last = j + 1 == pieces ? b : Eigen::Vector3d(centre + Eigen::AngleAxisd((j + 1) * step, axis) * fromCentre);
    // The tangents at both ends meet on the bisector, R / cos(step / 2) from the bend centre.
    const Eigen::Vector3d bisector = ((first - centre) + (last - centre)).normalized();
    pcf.line("ELBOW");
    pcf.endPoint(first, j == 0 ? boreFirst : boreLast);
    pcf.endPoint(last, boreLast);
    pcf.line("    CENTRE-POINT " + coordinates(centre + bendRadius / std::cos(0.5 * step) * bisector));
    pcf.line("    SKEY ELBW");
  }
}

}  // namespace

std::string pcfDocument(const std::vector<ExportElement>& elements, const NominalSizes* nominal) {
  std::map<int, const ExportElement*> pipes;
  for (const auto& element : elements) {
    if (element.kind == ElementKind::Pipe) pipes.emplace(element.id, &element);
  }
  const Bores bores(nominal, pipes);
  // Where tees sit on their main pipes: the pipes are cut around them.
  std::map<const ExportElement*, TeeLayout> tees;
  std::map<const ExportElement*, std::vector<std::pair<double, double>>> teeSpans;
  for (const auto& element : elements) {
    if (element.kind != ElementKind::Tee) continue;
    if (const auto layout = teeLayout(element, pipes)) {
      tees.emplace(&element, *layout);
      teeSpans[layout->main].emplace_back(layout->along - layout->arm, layout->along + layout->arm);
    }
  }

  PcfText pcf;
  pcf.line("ISOGEN-FILES ISOGEN.FLS");
  pcf.line("UNITS-BORE MM");
  pcf.line("UNITS-CO-ORDS MM");
  pcf.line("UNITS-WEIGHT KGS");
  pcf.line("UNITS-BOLT-DIA MM");
  pcf.line("UNITS-BOLT-LENGTH MM");
  for (const auto& pipeline : pipelines(elements)) {
    pcf.line("PIPELINE-REFERENCE " + pipeline.reference);
    for (const ExportElement* element : pipeline.elements) {
      const Eigen::Vector3d& start = element->axis.front();
      const Eigen::Vector3d& end = element->axis.back();
      switch (element->kind) {
        case ElementKind::Pipe: {
          auto spans = teeSpans[element];
          std::sort(spans.begin(), spans.end());
          const double length = element->length();
          const Eigen::Vector3d direction = length > 0.0 ? Eigen::Vector3d((end - start) / length) : Eigen::Vector3d::Zero();
          double cursor = 0.0;
          for (const auto& [from, to] : spans) {
            if (from > cursor + kShortestPiece) {
              pcf.pipe(start + cursor * direction, start + std::min(from, length) * direction, bores.of(element->radius));
            }
            cursor = std::max(cursor, to);
          }
          if (length > cursor + kShortestPiece) pcf.pipe(start + cursor * direction, end, bores.of(element->radius));
          break;
        }
        case ElementKind::Boundary:
          pcf.straight(start, bores.atEnd(*element, start), end, bores.atEnd(*element, end));
          break;
        case ElementKind::Elbow:
          writeElbow(*element, bores.atEnd(*element, start), bores.atEnd(*element, end), pcf);
          break;
        case ElementKind::Tee: {
          const auto found = tees.find(element);
          if (found == tees.end()) {
            // Its main pipe is not exported (deleted) or has no length: the tee is written as a plain
            // pipe piece from the main axis to the branch.
            pcf.pipe(start, end, bores.branch(*element));
            break;
          }
          const TeeLayout& tee = found->second;
          pcf.line("TEE");
          pcf.endPoint(tee.centre - tee.arm * tee.direction, bores.of(tee.main->radius));
          pcf.endPoint(tee.centre + tee.arm * tee.direction, bores.of(tee.main->radius));
          pcf.line("    CENTRE-POINT " + coordinates(tee.centre));
          pcf.line("    BRANCH1-POINT " + coordinates(end) + " " + boreText(bores.branch(*element)));
          pcf.line("    SKEY TEBW");
          break;
        }
      }
    }
  }
  return std::move(pcf.text());
}

}  // namespace piperun::io
