#pragma once
// The review queue: what the studio steps through with N / P and counts on screen.

#include "piperun/pipe_network.h"

#include <vector>

namespace piperun {

/// A joint or pipe of the review queue.
struct ReviewItem {
  enum class Kind { Joint, Pipe };
  Kind kind = Kind::Joint;
  int id = 0;
  double confidence = 0.0;

  bool operator==(const ReviewItem& other) const { return kind == other.kind && id == other.id; }
};

/// The queue's order: lowest confidence first, then joints before pipes, then by id. Decided
/// elements sort by it too, so that a step from one finds its neighbours.
bool reviewsBefore(const ReviewItem& a, const ReviewItem& b);

/// The joints and live pipes still to review (status proposed), in the queue's order.
std::vector<ReviewItem> reviewQueue(const PipeNetwork& network);

struct ReviewCounts {
  int accepted = 0;
  int rejected = 0;  ///< Joints rejected; pipes deleted.
  int left = 0;      ///< Proposed.
};
ReviewCounts countJointReview(const PipeNetwork& network);
ReviewCounts countPipeReview(const PipeNetwork& network);

}  // namespace piperun
