#pragma once
// A network counted by nominal pipe size (the table's nearest to each element's radius): what
// `piperun info NETWORK` lists, per size and per run.

#include "piperun/edit/nominal_sizes.h"
#include "piperun/pipe_network.h"

#include <vector>

namespace piperun {

/// What a network holds of one nominal size (a tee's size is its branch's), leaving out deleted
/// pipes and rejected joints.
struct SizeTally {
  NominalSize size;
  int pipes = 0;
  double pipeLength = 0.0;  ///< Metres.
  int elbows = 0;
  int elbows90 = 0;  ///< Of the elbows, those turning 90° and 45° (elbowAngleOf, piperun/pipe_measures.h).
  int elbows45 = 0;
  int tees = 0;
  int boundaries = 0;
  int proposed = 0;  ///< Of those pipes and joints, the ones still to review.
};

/// The sizes present, smallest first.
std::vector<SizeTally> tallyBySize(const PipeNetwork& network, const NominalSizes& table);

/// One run: its length (runLength), the nominal size that most of its length has (its reducers
/// and branches aside), its pipes, elbows and tees, and how many of those are proposed.
struct RunSummary {
  int id = 0;
  double length = 0.0;  ///< Metres.
  NominalSize size;
  int pipes = 0;
  int elbows = 0;
  int tees = 0;
  int proposed = 0;
};

/// The network's runs, in its order.
std::vector<RunSummary> summarizeRuns(const PipeNetwork& network, const NominalSizes& table);

}  // namespace piperun
