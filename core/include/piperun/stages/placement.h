#pragma once
// Stage 3 — cylinder placement (paper §5.1): per principal direction, project its stripe onto the
// orthogonal plane, turn pairs of nearby points with their normals into circle candidates, find
// the candidates' modes by mean-shift in (cx, cy, r), gather inliers, refine by least squares and
// keep the fits that look like pipes.
//
// Coordinates are relative to the cloud's origin (PointCloud::positions), like the cloud's own.

#include "piperun/point_cloud.h"
#include "piperun/progress.h"
#include "piperun/stages/directions.h"

#include <cstdint>
#include <vector>

namespace piperun {

struct PlacementParams {
  double minRadius = 0.012;         ///< Smallest pipe radius searched (m).
  double maxRadius = 0.35;          ///< Largest pipe radius searched (m); the pair-selection scales run up to it.
  int pairsPerPoint = 1;            ///< Partners each stripe point draws at each neighbourhood scale (scales step
                                    ///< ×3 from minRadius to maxRadius), so the work is linear in the stripe.
  double minPairAngleDeg = 15.0;    ///< Pairs whose projected normals are closer than this to parallel are skipped.
  double radiusAgreement = 0.1;     ///< A pair gives a candidate when its two distances to the centre differ by
                                    ///< less than max(2 mm, this × radius).
  double centerBandwidth = 0.01;    ///< Mean-shift kernel width for the centre (m)...
  double radiusBandwidth = 0.006;   ///< ...and for the radius (m).
  int minCandidates = 25;           ///< A circle needs at least this many candidates in its mode...
  int minJoinedCandidates = 15;     ///< ...or this many (up to minCandidates; 0: none) when its pipe takes a joint:
                                    ///< a thin pipe seen in a few columns gathers few, and so does clutter, but
                                    ///< clutter seldom meets a pipe's end as an elbow or tee does. Such a circle
                                    ///< also needs three times minCandidateShare, and a fit in the standard band
                                    ///< (none on a scan noisy enough to widen it).
  double inlierDistance = 0.012;    ///< A point is an inlier when within this of the cylinder surface (m; widened to
                                    ///< 2.5 robust standard deviations of a noisier fit's offsets, up to 3 × this)...
  double inlierNormalAngleDeg = 30; ///< ...and its normal in the plane (re-estimated there from its neighbours) within
                                    ///< this angle of the radial direction. A point of a scan column seen end-on (a
                                    ///< tight cluster in the plane) may instead take the normal over the columns beside
                                    ///< it, where they curve like a pipe: a thin pipe seen in a few columns has no other
                                    ///< (not once the band is widened for a noisy scan).
  int minInliers = 40;              ///< Cylinders with fewer inliers are dropped...
  int minJoinedInliers = 25;        ///< ...or this many (up to minInliers; 0: none) when their pipe takes a joint: a
                                    ///< short leg between two elbows, or a thin one seen in a few columns, holds a few
                                    ///< dozen points, and so does a piece of clutter, which seldom meets a pipe's end.
  double minCandidateShare = 0.1;   ///< A cylinder's mode must hold this many candidates per inlier: pairs of a real
                                    ///< pipe's points agree on its circle, the faces of a box edge on a ridge of circles.
  double maxShellShare = 0.15;      ///< Dropped when the stripe points just outside the inlier band (up to 2.5 ×
                                    ///< inlierDistance off the surface, along the inliers) exceed this share of the
                                    ///< inliers: the faces beyond a box edge do, a pipe's surroundings do not.
  double maxOutOfRound = 0.02;      ///< Dropped when the inliers' mean surface offset varies around the axis by more
                                    ///< than this share of the radius (at least 1 mm, unless the fit needs normals
                                    ///< across scan columns, as a square post's would; RMS over 10° sectors, the worst
                                    ///< one left out, noise discounted): square posts and beams do, pipes do not.
                                    ///< All points in the inlier band, whatever their normals, may vary twice as much
                                    ///< (a post's corner seen in a few scan columns passes on its inliers alone).
  int refineIterations = 8;         ///< Gauss-Newton iterations of each least-squares refinement (two are run).
};

struct CircleCandidate {
  Eigen::Vector2f center = Eigen::Vector2f::Zero();  ///< In the direction's plane basis (u, v).
  float radius = 0.0f;
  int circle = -1;  ///< Index of the cylinder whose mode it converged to, -1 for none.
};

struct Cylinder {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();      ///< A point on the axis (relative to the cloud origin),
                                                        ///< level with the inliers' centroid.
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ(); ///< Unit axis direction.
  double radius = 0.0;
  double rms = 0.0;                                     ///< RMS surface distance of the inliers (m).
  int candidates = 0;                                   ///< Circle candidates in its mode (and in its duplicates').
  bool mustJoin = false;  ///< Fewer candidates than minCandidates or inliers than minInliers: a pipe only if it
                          ///< takes a joint.
  int directionIndex = -1;                              ///< Index into DirectionsResult::directions.
  std::vector<std::uint32_t> inliers;                   ///< Ascending; a point is an inlier of one cylinder at most.
};

struct PlacementInput {
  const PointCloud& cloud;            ///< Points with normals.
  const DirectionsResult& directions; ///< Directions with their stripes.
  std::uint64_t seed = 1;
};

struct PlacementResult {
  /// What each direction's projection plane shows.
  struct Projection {
    Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();
    Eigen::Vector3d u = Eigen::Vector3d::UnitX();  ///< Plane basis: a point p (relative to the cloud origin)
    Eigen::Vector3d v = Eigen::Vector3d::UnitY();  ///< projects to ((p·u), (p·v)).
    std::vector<CircleCandidate> candidates;
  };
  std::vector<Projection> projections;  ///< One per direction, same order.
  std::vector<Cylinder> cylinders;      ///< Ordered by direction, then by inlier count (most first).

  struct Diagnostics {
    std::size_t projectedPoints = 0;  ///< Stripe points, summed over the directions.
    std::size_t candidates = 0;
    std::size_t circles = 0;          ///< Modes with at least minCandidates candidates.
    std::size_t duplicates = 0;       ///< Refined cylinders dropped as copies of better supported ones.
    double seconds = 0.0;
  } diagnostics;
};

PlacementResult placeCylinders(const PlacementInput& input, const PlacementParams& params,
                               Progress& progress = Progress::none());

/// The least-squares refinement placement runs on each cylinder: Gauss-Newton on the surface
/// distances |(p − c) × a| − r over the axis direction, the axis point and the radius. `point`,
/// the unit `direction` and `radius` hold the start on entry and the fit on return (the point level
/// with the points' centroid). Returns false when the fit degenerates.
bool refineCylinderFit(const std::vector<Eigen::Vector3d>& points, Eigen::Vector3d& point, Eigen::Vector3d& direction,
                       double& radius, int iterations);

}  // namespace piperun
