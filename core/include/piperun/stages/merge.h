#pragma once
// Stage 5 — merging across sub-volumes and rounds: collinear pieces of the same radius that
// overlap or abut become one pipe; duplicates from the tiles' overlaps go.

#include "piperun/point_cloud.h"
#include "piperun/progress.h"
#include "piperun/stages/extents.h"

#include <vector>

namespace piperun {

struct MergeParams {
  double maxAngleDeg = 3.0;          ///< Axes at most this far from parallel...
  double maxAxisDistance = 0.3;      ///< ...the shorter piece's ends at most this × the smaller radius off the longer
                                     ///< one's axis (min 1 cm)...
  double maxRadiusDifference = 0.15; ///< ...radii within this share of the larger one (min 3 mm)...
  double maxGap = 0.05;              ///< ...and overlapping or separated by at most this (m) are merged.
  double maxExtension = 2.0;         ///< Merged pipes' ends carry on along the axis over points of the surface
                                     ///< this far at a time (m; 0: off), again from where they stopped while
                                     ///< they carry the whole way: a pipe's far, sparse end whose normals
                                     ///< stray too far from radial for placement's inliers...
  double extensionNormalAngleDeg = 45.0;  ///< ...over points whose normals are this close to radial (deg).
  int extensionBridgeSections = 20;  ///< ...across gaps up to this many 4 cm sections when the run beyond is as long.
};

struct MergeResult {
  std::vector<PipeSegment> segments;  ///< Merged pipes in a deterministic order (longest first).
  struct Diagnostics {
    std::size_t inputSegments = 0;
    std::size_t mergedSegments = 0;
    std::size_t retractedEnds = 0;    ///< Ends mergeAndExtend moved back off a crossing pipe's points...
    std::size_t extendedEnds = 0;     ///< ...and ends it carried on.
    double seconds = 0.0;
  } diagnostics;
};

MergeResult mergeSegments(const std::vector<PipeSegment>& segments, const MergeParams& params,
                          Progress& progress = Progress::none());

/// mergeSegments, then each end whose last stretch (a section or more) holds only points on the
/// surface of a pipe crossing it (30° or more off its axis) moved back to its last inlier of its
/// own, then each merged pipe's ends extended over `cloud` (the points the segments' inliers
/// index): 4 cm sections along the axis past the end that hold a point of the surface not
/// explained by any pipe (within the band of its noise, normal near radial), with gaps of at most
/// three sections (up to extensionBridgeSections when the run beyond is as long), and no more
/// points inside the tube or in a shell around it than on its surface; maxExtension at a time, an
/// end whose surface points run on to within three sections of that reach carried on again.
/// An end stops where its axis enters another pipe's tube (a main's wall, or the cap of a pipe on
/// its line); the extended pipes are merged again, a section's gap allowed (an end that stopped at
/// a cap meets that pipe).
MergeResult mergeAndExtend(const PointCloud& cloud, const std::vector<PipeSegment>& segments, const MergeParams& params,
                           Progress& progress = Progress::none());

}  // namespace piperun
