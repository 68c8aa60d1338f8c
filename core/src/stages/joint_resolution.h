#pragma once
// The joints stage's choice among hypotheses (see joints.cpp): each end takes at most one joint.

#include "stages/joint_builder.h"
#include "points_near.h"

#include <cstddef>
#include <vector>

namespace piperun::joints {

/// The joints chosen among the hypotheses between a set of pipes.
struct Resolution {
  std::vector<Hypothesis> hypotheses;
  std::vector<std::size_t> chosen;  // Into hypotheses, in the order they took their ends.
  std::vector<int> takenBy;         // By PipeEnd::key(): the chosen hypothesis that took the end, -1 for none.
  std::vector<char> arcPieces;      // By pipe: a piece of an elbow's arc, replaced by the elbow (it goes).
  JointsResult::Diagnostics diagnostics;
};

/// Whether `pipe` is a piece of the arc of `elbow` (reconstructed) fitted as a cylinder: both its
/// ends lie within its radius of the arc, or it was fitted across the bend.
bool liesOnArc(const PipeSegment& pipe, const Hypothesis& elbow);

/// Hypotheses between `input.pipes`, reconstructed with their points, and the conflicts resolved.
/// `explained` flags the points that are inliers of some pipe; pipes from `completionsFrom` on are
/// completions of free ends.
Resolution resolveJoints(const JointsInput& input, const JointsParams& params, const std::vector<char>& explained,
                         std::size_t completionsFrom, const PointCells& cells, Progress& progress);

/// The ends no chosen joint took, of the pipes that take joints (no fragment, no piece of an
/// elbow's arc), in key order.
std::vector<PipeEnd> freeEnds(const std::vector<PipeSegment>& pipes, const JointsParams& params,
                              const Resolution& resolution);

}  // namespace piperun::joints
