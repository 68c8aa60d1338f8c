#include "piperun/edit/bill_of_materials.h"

#include "piperun/io/network_io.h"
#include "piperun/pipe_measures.h"

#include <map>
#include <utility>

namespace piperun {

std::vector<RunSummary> summarizeRuns(const PipeNetwork& network, const NominalSizes& table) {
  std::vector<RunSummary> summaries;
  for (const Run& run : network.runs) {
    RunSummary& summary = summaries.emplace_back();
    summary.id = run.id;
    summary.length = runLength(network, run);
    std::map<int, std::pair<double, NominalSize>> lengthBySize;  // by DN
    const auto addLength = [&](double radius, double length) {
      const NominalSize& size = table.nearest(radius);
      auto& entry = lengthBySize.try_emplace(size.dn, 0.0, size).first->second;
      entry.first += length;
    };
    for (int id : run.pipeIds) {
      const Pipe* pipe = network.findPipe(id);
      if (!pipe) continue;
      ++summary.pipes;
      summary.proposed += pipe->status == PipeStatus::Proposed;
      addLength(pipe->radius, pipe->length());
    }
    for (int id : run.jointIds) {
      const Joint* joint = network.findJoint(id);
      if (!joint) continue;
      summary.elbows += joint->type == JointType::Elbow;
      summary.tees += joint->type == JointType::Tee;
      summary.proposed += joint->status == JointStatus::Proposed;
      addLength(joint->radius, joint->length());
    }
    double longest = -1.0;
    for (const auto& [dn, entry] : lengthBySize) {
      if (entry.first > longest) {
        longest = entry.first;
        summary.size = entry.second;
      }
    }
  }
  return summaries;
}

std::vector<SizeTally> tallyBySize(const PipeNetwork& network, const NominalSizes& table) {
  std::map<int, SizeTally> byDn;
  const auto tallyOf = [&](double radius) -> SizeTally& {
    const NominalSize& size = table.nearest(radius);
    SizeTally& tally = byDn[size.dn];
    tally.size = size;
    return tally;
  };
  for (const auto& pipe : network.pipes) {
    if (pipe.status == PipeStatus::Deleted) continue;
    SizeTally& tally = tallyOf(pipe.radius);
    ++tally.pipes;
    tally.pipeLength += pipe.length();
    tally.proposed += pipe.status == PipeStatus::Proposed;
  }
  for (const auto& joint : network.joints) {
    if (joint.status == JointStatus::Rejected) continue;
    SizeTally& tally = tallyOf(joint.radius);
    ++(joint.type == JointType::Elbow ? tally.elbows : joint.type == JointType::Tee ? tally.tees : tally.boundaries);
    tally.proposed += joint.status == JointStatus::Proposed;
    if (joint.type != JointType::Elbow) continue;
    if (const auto bend = bendOf(joint.axis)) {
      const ElbowAngle angle = elbowAngleOf(bend->angleDegrees());
      tally.elbows90 += angle == ElbowAngle::Ninety;
      tally.elbows45 += angle == ElbowAngle::FortyFive;
    }
  }
  std::vector<SizeTally> tallies;
  for (const auto& [dn, tally] : byDn) tallies.push_back(tally);
  return tallies;
}

}  // namespace piperun
