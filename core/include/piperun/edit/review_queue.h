#pragma once
// The joint review queue: what the studio steps through with N / P and counts on screen.

#include "piperun/pipe_network.h"

#include <vector>

namespace piperun {

/// Ids of the joints still to review (status proposed), lowest confidence first (ties by id).
std::vector<int> jointReviewQueue(const PipeNetwork& network);

struct ReviewCounts {
  int accepted = 0;
  int rejected = 0;
  int left = 0;  ///< Proposed.
};
ReviewCounts countJointReview(const PipeNetwork& network);

}  // namespace piperun
