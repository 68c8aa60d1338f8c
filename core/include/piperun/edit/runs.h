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

}  // namespace piperun
