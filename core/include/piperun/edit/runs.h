#pragma once
// Pipe-runs of an edited network: connected components of the pipes over accepted joints.

#include "piperun/pipe_network.h"

namespace piperun {

/// Rebuilds `network.runs` and every pipe's `runId` with the joints stage's rule: the runs are the
/// connected components of the pipes over accepted joints, numbered from 1 in the order of their
/// first pipe, every pipe in exactly one run. Deleted pipes belong to no run (runId -1), and a
/// joint counts only while it is accepted and none of its pipes is deleted; so a rejected joint or
/// a deleted pipe leaves the runs at once.
void assignRuns(PipeNetwork& network);

/// The network as far as it is accepted, for exports that must hold no element still to review:
/// proposed pipes deleted, proposed joints rejected, and so are accepted joints on a pipe deleted
/// (here or before: a joint does not stand without its pipes); the runs assigned again. Ids and
/// order are kept, so the elements left are named as in `network`.
PipeNetwork acceptedPart(const PipeNetwork& network);

}  // namespace piperun
