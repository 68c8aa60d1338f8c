#include "piperun/edit/review_queue.h"

#include <algorithm>

namespace piperun {

std::vector<int> jointReviewQueue(const PipeNetwork& network) {
  std::vector<const Joint*> proposed;
  for (const Joint& joint : network.joints) {
    if (joint.status == JointStatus::Proposed) proposed.push_back(&joint);
  }
  std::sort(proposed.begin(), proposed.end(), [](const Joint* a, const Joint* b) {
    return a->confidence != b->confidence ? a->confidence < b->confidence : a->id < b->id;
  });
  std::vector<int> ids;
  ids.reserve(proposed.size());
  for (const Joint* joint : proposed) ids.push_back(joint->id);
  return ids;
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

}  // namespace piperun
