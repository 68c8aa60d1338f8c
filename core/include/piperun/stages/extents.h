#pragma once
// Stage 4 — extents (paper §5.2): along each cylinder's axis, keep the sections with enough points
// (axis coverage) spread over enough of the circumference (cross-section coverage), close then
// open the 1-D mask, and split it into contiguous pipes.

#include "piperun/pipe_network.h"
#include "piperun/point_cloud.h"
#include "piperun/progress.h"
#include "piperun/stages/placement.h"

#include <cstdint>
#include <vector>

namespace piperun {

struct ExtentsParams {
  double sectionLength = 0.04;       ///< Axial section length (m).
  double minPointsPerMetre = 0.0;    ///< Axis coverage: a section needs this many points per metre; 0 = automatic
                                     ///< (a fraction `minDensityRatio` of the median section density)...
  double minDensityRatio = 0.2;      ///< Used when minPointsPerMetre is 0...
  double densityWindow = 0.5;        ///< ...against the median density within this distance (m) along the axis when
                                     ///< lower than the whole cylinder's (a long pipe thins out far from the scanner).
  double minArcDeg = 45.0;           ///< Cross-section coverage: a section's points (pooled with its neighbours' up to
                                     ///< six points) must span this angle around the axis (360° minus their largest
                                     ///< gap). The paper's 180° needs several stations; one station sees at most half a
                                     ///< pipe (measurements in extents.cpp).
  int closingSections = 10;          ///< 1-D closing fills gaps up to this many sections (occlusions behind other pipes)...
  int bridgeSections = 20;           ///< ...and gaps up to this many between two runs each at least as long as the gap
                                     ///< (when the joined run keeps minConfidence)...
  int openingSections = 2;           ///< ...then opening drops pieces shorter than this many sections.
  double minConfidence = 0.6;        ///< Pieces where fewer than this share of the sections passed both coverage tests
                                     ///< (the closing filled the rest) are dropped, and a bridge must leave this share.
                                     ///< (0.7 drops the pump room's short piece between two elbows.) A closed run
                                     ///< below this share is opened again at its longest gaps until its parts keep it,
                                     ///< and the part with most inliers stays when it holds over half the run's...
  int minPartPoints = 40;            ///< ...and at least this many (placement's minInliers).
  double minLength = 0.1;            ///< Pipes shorter than this (m) are dropped.
};

/// A straight pipe found by the extents stage, before merging across tiles.
struct PipeSegment {
  Eigen::Vector3d start = Eigen::Vector3d::Zero();  ///< Axis end points, relative to the cloud origin; the extreme
  Eigen::Vector3d end = Eigen::Vector3d::Zero();    ///< inlier projections, start before end along the cylinder axis.
  double radius = 0.0;
  double rms = 0.0;
  double confidence = 0.0;            ///< Share of the segment's sections that passed both coverage tests
                                      ///< (before the closing filled gaps).
  int cylinderIndex = -1;             ///< Index into PlacementResult::cylinders.
  bool mustJoin = false;              ///< From a weakly supported circle or a cylinder of few inliers
                                      ///< (Cylinder::mustJoin): dropped by the joints stage unless it takes a joint.
  std::vector<std::uint32_t> inliers; ///< Points of the cylinder's inliers within the segment.
};

struct ExtentsInput {
  const PointCloud& cloud;
  const PlacementResult& placement;
};

struct ExtentsResult {
  std::vector<PipeSegment> segments;
  struct Diagnostics {
    std::size_t sections = 0;         ///< Sections over all cylinders.
    std::size_t keptSections = 0;     ///< Sections inside a run after the closing and opening.
    double seconds = 0.0;
  } diagnostics;
};

ExtentsResult computeExtents(const ExtentsInput& input, const ExtentsParams& params,
                             Progress& progress = Progress::none());

}  // namespace piperun
