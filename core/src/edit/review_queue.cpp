#include "piperun/edit/review_queue.h"

#include <algorithm>
#include <tuple>

namespace piperun {

bool reviewsBefore(const ReviewItem& a, const ReviewItem& b) {
  return std::tuple(a.confidence, a.kind, a.id) < std::tuple(b.confidence, b.kind, b.id);
}

std::vector<ReviewItem> reviewQueue(const PipeNetwork& network) {
  std::vector<ReviewItem> queue;
  for (const Joint& joint : network.joints) {
    if (joint.status == JointStatus::Proposed) queue.push_back({ReviewItem::Kind::Joint, joint.id, joint.confidence});
  }
  for (const Pipe& pipe : network.pipes) {
    if (pipe.status == PipeStatus::Proposed) queue.push_back({ReviewItem::Kind::Pipe, pipe.id, pipe.confidence});
  }
  std::sort(queue.begin(), queue.end(), reviewsBefore);
  return queue;
}

ReviewCounts countJointReview(const PipeNetwork& network) {
  ReviewCounts counts;
  for (const Joint& joint : network.joints) {
    switch (joint.status) {
      case JointStatus::Accepted: ++counts.accepted; break;
      case JointStatus::Rejected: ++counts.rejected; break;
      case JointStatus::Proposed: ++counts.left; break;
    }
  }
  return counts;
}

ReviewCounts countPipeReview(const PipeNetwork& network) {
  ReviewCounts counts;
  for (const Pipe& pipe : network.pipes) {
    switch (pipe.status) {
      case PipeStatus::Accepted: ++counts.accepted; break;
      case PipeStatus::Deleted: ++counts.rejected; break;
      case PipeStatus::Proposed: ++counts.left; break;
    }
  }
  return counts;
}

}  // namespace piperun
