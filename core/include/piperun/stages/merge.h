#pragma once
// Stage 5 — merging across sub-volumes and rounds: collinear pieces of the same radius that
// overlap or abut become one pipe; duplicates from the tiles' overlaps go.

#include "piperun/progress.h"
#include "piperun/stages/extents.h"

#include <vector>

namespace piperun {

struct MergeParams {
  double maxAngleDeg = 3.0;          ///< Axes at most this far from parallel...
  double maxAxisDistance = 0.3;      ///< ...at most this × the smaller radius apart (min 1 cm)...
  double maxRadiusDifference = 0.15; ///< ...radii within this share of the larger one (min 3 mm)...
  double maxGap = 0.05;              ///< ...and overlapping or separated by at most this (m) are merged.
};

struct MergeResult {
  std::vector<PipeSegment> segments;  ///< Merged pipes in a deterministic order (longest first).
  struct Diagnostics {
    std::size_t inputSegments = 0;
    std::size_t mergedSegments = 0;
    double seconds = 0.0;
  } diagnostics;
};

MergeResult mergeSegments(const std::vector<PipeSegment>& segments, const MergeParams& params,
                          Progress& progress = Progress::none());

}  // namespace piperun
