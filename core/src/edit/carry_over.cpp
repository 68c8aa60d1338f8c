// Carry-over: the old history replayed step by step with translated ids. The old network is
// walked forward alongside (applying each old step's diff) so that every edit is read against
// the network it was made on.

#include "piperun/edit/carry_over.h"

#include "piperun/edit/pipe_fit.h"

#include "angles.h"
#include "cell_table.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <tuple>
#include <unordered_map>

namespace piperun {

namespace {

constexpr double kMatchRadiusRatio = 0.8;
constexpr double kMatchAngleDeg = 10.0;
constexpr double kMatchMinOffset = 0.02;  // m
constexpr double kMatchMinOverlapShare = 0.5;
constexpr double kMatchCell = 1.0;  // smallest cell of the candidate grid (m)

std::set<int> pipeSet(const Joint& joint) { return {joint.pipeIds.begin(), joint.pipeIds.end()}; }

class IdTranslation {
 public:
  explicit IdTranslation(std::map<int, int> pipes) : pipes_(std::move(pipes)) {}

  /// The new id of old pipe `id`; throws EditError naming it when it has no counterpart.
  int pipe(int id) const {
    const auto found = pipes_.find(id);
    if (found == pipes_.end()) throw EditError("pipe " + std::to_string(id) + " has no counterpart in the new network");
    return found->second;
  }
  /// The new joint joining the counterparts of the pipes old joint `id` joins.
  int joint(int id, const PipeNetwork& oldNetwork, const PipeNetwork& newNetwork) const {
    const Joint* old = oldNetwork.findJoint(id);
    if (!old) throw EditError("there is no joint " + std::to_string(id));
    std::set<int> wanted;
    for (int pipeId : old->pipeIds) {
      const auto found = pipes_.find(pipeId);
      if (found == pipes_.end()) {
        throw EditError("joint " + std::to_string(id) + " has no counterpart: its pipe " + std::to_string(pipeId) + " has none");
      }
      wanted.insert(found->second);
    }
    for (const Joint& joint : newNetwork.joints) {
      if (pipeSet(joint) == wanted) return joint.id;
    }
    throw EditError("joint " + std::to_string(id) + " has no counterpart: the new network does not join its pipes");
  }
  void mapPipe(int oldId, int newId) { pipes_[oldId] = newId; }
  void forgetPipe(int oldId) { pipes_.erase(oldId); }

 private:
  std::map<int, int> pipes_;
};

/// The edit with its ids translated; a moved end follows a pipe whose direction flipped.
Edit translate(const Edit& edit, const IdTranslation& ids, const PipeNetwork& oldNetwork, const PipeNetwork& newNetwork) {
  Edit translated = edit;
  switch (edit.kind) {
    case EditKind::AcceptJoint:
    case EditKind::RejectJoint:
    case EditKind::ProposeJoint: translated.id = ids.joint(edit.id, oldNetwork, newNetwork); break;
    case EditKind::AddJoint:
    case EditKind::MergePipes:
      translated.id = ids.pipe(edit.id);
      translated.otherId = ids.pipe(edit.otherId);
      break;
    case EditKind::MoveEnd: {
      translated.id = ids.pipe(edit.id);
      const Pipe* before = oldNetwork.findPipe(edit.id);
      const Pipe* after = newNetwork.findPipe(translated.id);
      if (before && after && before->direction().dot(after->direction()) < 0.0) translated.side = 1 - edit.side;
      break;
    }
    case EditKind::DeletePipe:
    case EditKind::RestorePipe:
    case EditKind::AcceptPipe:
    case EditKind::SplitPipe:
    case EditKind::SetRadius:
    case EditKind::SnapRadius: translated.id = ids.pipe(edit.id); break;
    case EditKind::FitInBox:
    case EditKind::FitAround: break;
  }
  return translated;
}

/// The live pipe of `network` that a fitted pipe duplicates, if any.
const Pipe* existingPipe(const PipeNetwork& network, const Edit& fit, const EditContext& context) {
  if (!context.cloud) return nullptr;
  const Pipe fitted = fit.kind == EditKind::FitInBox ? fitPipeInBox(*context.cloud, fit.point, fit.point2, context.placement)
                                                     : fitPipeAround(*context.cloud, fit.point, fit.value, context.placement);
  for (const Pipe& pipe : network.pipes) {
    if (pipe.status != PipeStatus::Deleted && pipeMatchOverlap(fitted, pipe) > 0.0) return &pipe;
  }
  return nullptr;
}

}  // namespace

double pipeMatchOverlap(const Pipe& a, const Pipe& b) {
  const double lengthA = a.length(), lengthB = b.length();
  if (lengthA <= 0.0 || lengthB <= 0.0) return 0.0;
  if (std::min(a.radius, b.radius) < kMatchRadiusRatio * std::max(a.radius, b.radius)) return 0.0;
  const Eigen::Vector3d axis = a.direction();
  if (std::abs(axis.dot(b.direction())) < std::cos(kMatchAngleDeg * kDegree)) return 0.0;
  const double s0 = (b.start - a.start).dot(axis), s1 = (b.end - a.start).dot(axis);
  const double low = std::max(0.0, std::min(s0, s1)), high = std::min(lengthA, std::max(s0, s1));
  const double overlap = high - low;
  if (overlap < kMatchMinOverlapShare * std::min(lengthA, lengthB)) return 0.0;
  // b's centre line at the middle of the overlap, against a's.
  const double middle = 0.5 * (low + high);
  const double t = std::abs(s1 - s0) > 0.0 ? (middle - s0) / (s1 - s0) : 0.0;
  const Eigen::Vector3d onB = b.start + t * (b.end - b.start);
  const Eigen::Vector3d onA = a.start + middle * axis;
  if ((onB - onA).norm() > std::max(a.radius, kMatchMinOffset)) return 0.0;
  return overlap;
}

std::map<int, int> matchPipes(const PipeNetwork& from, const PipeNetwork& to) {
  // Candidates through a hash grid over axis samples: two matching pipes overlap, so a sample of
  // each lies within (a step + the allowed offset) of the other's, at most a cell: neighbouring cells.
  double largestRadius = 0.0;
  for (const PipeNetwork* network : {&from, &to}) {
    for (const Pipe& pipe : network->pipes) largestRadius = std::max(largestRadius, pipe.radius);
  }
  const double cell = std::max(kMatchCell, 2.0 * (largestRadius + kMatchMinOffset));
  const double step = 0.5 * cell;
  const auto forEachSampleCell = [&](const Pipe& pipe, auto&& visit) {
    const int samples = 1 + static_cast<int>(std::ceil(pipe.length() / step));
    for (int k = 0; k <= samples; ++k) {
      const Eigen::Vector3d p = pipe.start + (static_cast<double>(k) / samples) * (pipe.end - pipe.start);
      visit(Eigen::Vector3i((p / cell).array().floor().cast<int>()));
    }
  };
  std::unordered_map<std::uint64_t, std::vector<std::size_t>> grid;
  for (std::size_t i = 0; i < to.pipes.size(); ++i) {
    if (to.pipes[i].status == PipeStatus::Deleted) continue;
    forEachSampleCell(to.pipes[i], [&](const Eigen::Vector3i& c) {
      auto& bucket = grid[cellKey(c)];
      if (bucket.empty() || bucket.back() != i) bucket.push_back(i);
    });
  }

  std::vector<std::tuple<double, int, int>> candidates;  // overlap, from id, to id
  std::vector<std::size_t> near;
  for (const Pipe& a : from.pipes) {
    near.clear();
    forEachSampleCell(a, [&](const Eigen::Vector3i& c) {
      for (int dx = -1; dx <= 1; ++dx) {
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dz = -1; dz <= 1; ++dz) {
            const auto found = grid.find(cellKey(c + Eigen::Vector3i(dx, dy, dz)));
            if (found != grid.end()) near.insert(near.end(), found->second.begin(), found->second.end());
          }
        }
      }
    });
    std::sort(near.begin(), near.end());
    near.erase(std::unique(near.begin(), near.end()), near.end());
    for (const std::size_t i : near) {
      const Pipe& b = to.pipes[i];
      if (const double overlap = pipeMatchOverlap(a, b); overlap > 0.0) candidates.emplace_back(overlap, a.id, b.id);
    }
  }
  // Largest overlap first; ties by ids so that the pairing never depends on the container order.
  std::sort(candidates.begin(), candidates.end(), [](const auto& x, const auto& y) {
    if (std::get<0>(x) != std::get<0>(y)) return std::get<0>(x) > std::get<0>(y);
    return std::make_pair(std::get<1>(x), std::get<2>(x)) < std::make_pair(std::get<1>(y), std::get<2>(y));
  });
  std::map<int, int> matched;
  std::set<int> taken;
  for (const auto& [overlap, fromId, toId] : candidates) {
    if (matched.count(fromId) || taken.count(toId)) continue;
    matched.emplace(fromId, toId);
    taken.insert(toId);
  }
  return matched;
}

CarryOver carryOver(const EditSession& session, const PipeNetwork& newBase, const EditContext& context) {
  CarryOver result{EditSession(newBase), {}};
  IdTranslation ids(matchPipes(session.base(), result.session.network()));
  PipeNetwork old = session.base();
  for (std::size_t k = 0; k < session.position(); ++k) {
    const EditStep& step = session.steps()[k];
    try {
      const Edit edit = translate(step.edit, ids, old, result.session.network());
      const Pipe* existing = edit.kind == EditKind::FitInBox || edit.kind == EditKind::FitAround
                                 ? existingPipe(result.session.network(), edit, context)
                                 : nullptr;
      if (existing) {
        for (const auto& added : step.diff.pipes.added) ids.mapPipe(added.element.id, existing->id);
        result.dropped.push_back({toCommand(step.edit), "the new network has this pipe already: pipe " + std::to_string(existing->id)});
      } else {
        const EditStep& carried = result.session.apply(edit, context);
        // Pipes the edit created map to the ones it creates now, in order; pipes it removed are gone.
        const auto& before = step.diff.pipes.added;
        const auto& now = carried.diff.pipes.added;
        for (std::size_t i = 0; i < before.size() && i < now.size(); ++i) ids.mapPipe(before[i].element.id, now[i].element.id);
        for (const auto& removed : step.diff.pipes.removed) ids.forgetPipe(removed.element.id);
      }
    } catch (const EditError& error) {
      result.dropped.push_back({toCommand(step.edit), error.what()});
      for (const auto& added : step.diff.pipes.added) ids.forgetPipe(added.element.id);
    }
    applyDiff(old, step.diff);
  }
  return result;
}

}  // namespace piperun
