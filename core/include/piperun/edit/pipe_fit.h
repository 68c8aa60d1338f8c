#pragma once
// Fitting a pipe by hand: a cylinder fitted to the points in a box, or around a picked point, with
// the placement stage's least-squares refinement and inlier rule.

#include "piperun/pipe_network.h"
#include "piperun/point_cloud.h"
#include "piperun/stages/placement.h"

#include <Eigen/Core>

namespace piperun {

/// The cylinder through the points (with normals) of `cloud` inside the world-space box
/// [boxMin, boxMax]. The best-supported cylinders through random pairs of points with their
/// normals (fixed seed) are refined, best first, until one gives a pipe: two rounds of
/// refineCylinderFit() on the inliers (within params.inlierDistance of the surface, normal within
/// params.inlierNormalAngleDeg of the radial direction). The pipe spans its inliers. Returns a
/// pipe in world coordinates with id 0, confidence 1 and status accepted; throws EditError saying
/// why when no pipe fits (fewer than 15 inliers, a radius outside the placement limits).
Pipe fitPipeInBox(const PointCloud& cloud, const Eigen::Vector3d& boxMin, const Eigen::Vector3d& boxMax,
                  const PlacementParams& params);

/// The same fit on the points within `reach` of `center`, a picked world point on the pipe's
/// surface that the cylinder must pass by; then grown along its axis over the inliers anywhere in
/// the cloud while they continue without a gap longer than a diameter (at least 5 cm), so that one
/// click on a pipe fits the whole pipe.
Pipe fitPipeAround(const PointCloud& cloud, const Eigen::Vector3d& center, double reach, const PlacementParams& params);

}  // namespace piperun
