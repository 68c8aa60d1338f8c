#include "piperun/edit/runs.h"

#include "union_find.h"

#include <algorithm>
#include <unordered_map>
#include <unordered_set>

namespace piperun {

void assignRuns(PipeNetwork& network) {
  std::unordered_map<int, std::size_t> indexOf;
  for (std::size_t i = 0; i < network.pipes.size(); ++i) {
    if (network.pipes[i].status != PipeStatus::Deleted) indexOf.emplace(network.pipes[i].id, i);
  }
  // The smaller index becomes the root, so a run's root is its first pipe.
  UnionFind components(network.pipes.size());
  const auto connects = [&](const Joint& joint) {
    if (joint.status != JointStatus::Accepted || joint.pipeIds.empty()) return false;
    for (int id : joint.pipeIds) {
      if (!indexOf.count(id)) return false;
    }
    return true;
  };
  for (const Joint& joint : network.joints) {
    if (!connects(joint)) continue;
    for (std::size_t k = 1; k < joint.pipeIds.size(); ++k) {
      components.unite(indexOf.at(joint.pipeIds.front()), indexOf.at(joint.pipeIds[k]));
    }
  }

  network.runs.clear();
  std::vector<int> runOfRoot(network.pipes.size(), -1);
  for (std::size_t i = 0; i < network.pipes.size(); ++i) {
    Pipe& pipe = network.pipes[i];
    if (pipe.status == PipeStatus::Deleted) {
      pipe.runId = -1;
      continue;
    }
    const std::size_t root = components.find(i);
    if (runOfRoot[root] < 0) {
      runOfRoot[root] = static_cast<int>(network.runs.size());
      network.runs.push_back(Run{static_cast<int>(network.runs.size()) + 1, {}, {}});
    }
    Run& run = network.runs[static_cast<std::size_t>(runOfRoot[root])];
    run.pipeIds.push_back(pipe.id);
    pipe.runId = run.id;
  }
  for (const Joint& joint : network.joints) {
    if (!connects(joint)) continue;
    const std::size_t root = components.find(indexOf.at(joint.pipeIds.front()));
    network.runs[static_cast<std::size_t>(runOfRoot[root])].jointIds.push_back(joint.id);
  }
}

PipeNetwork acceptedPart(const PipeNetwork& network) {
  PipeNetwork accepted = network;
  std::unordered_set<int> deleted;
  for (Pipe& pipe : accepted.pipes) {
    if (pipe.status == PipeStatus::Proposed) pipe.status = PipeStatus::Deleted;
    if (pipe.status == PipeStatus::Deleted) deleted.insert(pipe.id);
  }
  for (Joint& joint : accepted.joints) {
    const bool onDeletedPipe =
        std::any_of(joint.pipeIds.begin(), joint.pipeIds.end(), [&](int id) { return deleted.count(id) > 0; });
    if (joint.status == JointStatus::Proposed || onDeletedPipe) joint.status = JointStatus::Rejected;
  }
  assignRuns(accepted);
  return accepted;
}

}  // namespace piperun
