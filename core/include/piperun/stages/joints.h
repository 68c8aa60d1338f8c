#pragma once
// Stage 6 — joints and pipe-runs (paper §6): hypotheses between pipe ends found through a spatial
// index (never all pairs), typed by how the ends' extensions meet (elbow, T-junction, boundary
// joint), reconstructed (elbows by major-radius voting, tees by extending the branch to the main
// axis, boundary joints by bridging the gap), resolved so that an end takes at most one joint, and
// grouped with the pipes into runs.
//
// Coordinates are relative to the cloud's origin, like every stage's.

#include "piperun/pipe_network.h"
#include "piperun/point_cloud.h"
#include "piperun/progress.h"
#include "piperun/stages/extents.h"

#include <array>
#include <cstdint>
#include <vector>

namespace piperun {

/// Every distance limit scales with the pipes' radii so that one set of defaults serves 1" conduits
/// and 24" headers; each has an absolute floor for the thinnest pipes.
struct JointsParams {
  double searchDiameters = 4.0;        ///< An end looks for partners within this many diameters of the larger pipe
                                       ///< (at least minSearchDistance): elbow tangents run 1–1.5 diameters, the rest
                                       ///< is for ends cut short by occlusion.
  double minSearchDistance = 0.15;     ///< Floor of the search distance (m).
  double maxSkewRadii = 0.5;           ///< Centre lines may pass this many (smaller) radii apart, at least
                                       ///< minSkewDistance: how far from co-planar (elbow, tee) or collinear (boundary).
  double minSkewDistance = 0.01;       ///< Floor of the skew limit (m).
  double minRadiusRatio = 0.7;         ///< Elbows and boundary joints join pipes whose radii (smaller / larger) agree
                                       ///< at least this well (reducing elbows exist: 6" risers on an 8" header).
  double maxBranchRatio = 1.1;         ///< A tee's branch radius is at most this × its main pipe's radius.
  double maxBoundaryAngleDeg = 5.0;    ///< Ends whose axes continue each other within this angle are a boundary joint.
  double maxBoundaryGapDiameters = 8.0;  ///< A boundary joint bridges at most this many diameters (at least
                                       ///< minSearchDistance): gaps behind beams, valves, flanges.
  double minElbowAngleDeg = 5.0;       ///< Bend angles (between one pipe's direction and the next) from this (where
                                       ///< boundary joints stop: a sloped pipe leaves a level one by 3–20°)...
  double maxElbowAngleDeg = 135.0;     ///< ...to this make an elbow.
  double minTeeAngleDeg = 60.0;        ///< A branch meets its main pipe at least this far from parallel.
  double minBendRadii = 1.0;           ///< An elbow's major radius R is voted between this...
  double maxBendRadii = 5.0;           ///< ...and this many pipe radii (short elbows R = 2r, long R = 3r).
  double minPipeDiameters = 1.0;       ///< Pipes shorter than this many diameters are fragments (a bit of an elbow
                                       ///< or flange fitted as a cylinder): they take no joint, and those lying on a
                                       ///< found elbow's arc are absorbed by it. A longer pipe lying on the arc of a
                                       ///< confident elbow between two other pipes waits for it and goes with it.
                                       ///< A pipe that takes no joint has its confidence scaled by its length
                                       ///< under twice this (a jointless fragment falls below one half: proposed).
  double supportDistance = 0.01;       ///< Points within this of a joint's surface support it (m).
  double acceptConfidence = 0.5;       ///< Joints with at least this confidence are accepted, others proposed.
  double maxCompletionLength = 1.0;    ///< An end no accepted joint took looks for a pipe the earlier stages missed
                                       ///< beyond an elbow, along one of the network's directions, up to this long
                                       ///< (m; 0: off, and so are the branch search, the search for the leg beyond a
                                       ///< gentle bend one pipe was fitted across and the legs between two bends,
                                       ///< seen or hidden): short legs between elbows and tails into equipment have
                                       ///< too few points to stand out on the Gaussian sphere. Branches found off a
                                       ///< pipe's body are at most this long too.
  std::size_t minCompletionPoints = 12;  ///< Such a pipe needs this many points on its surface...
  double minCompletionCoverage = 0.5;  ///< ...in this share of its sections at least, and must take the elbow.
  double minCompletionBendDeg = 8.0;   ///< Such a pipe turns at least this far from the end's axis: normals scatter a
                                       ///< few degrees, so gentler directions are the end's own pipe carrying on.
  double minBranchRadius = 0.012;      ///< Every pipe also looks along its body for a branch the earlier stages missed
                                       ///< (a thin one seen in a few scan columns), of this radius (m) up to its own,
                                       ///< along one of the network's directions, checked as a completed pipe is and
                                       ///< kept when it takes the tee (0: off; see maxCompletionLength).
  double occludedSearchDiameters = 12.0;  ///< Two ends no joint took, after the completion, look for an elbow between
                                       ///< them this far (as searchDiameters; no farther than it: off), across a
                                       ///< corner hidden behind something: proposed, when the stretches it bridges
                                       ///< cross no other pipe and hold no points near their axes.
  double maxThinStretch = 10.0;        ///< An end no joint took makes an elbow with a pipe whose end faces its corner
                                       ///< from up to this far (m; 0: off), when that pipe was seen running on
                                       ///< thinly to the corner (far from the scanner): proposed.
};

struct JointsInput {
  const PointCloud& cloud;                 ///< The preprocessed cloud (positions and normals).
  const std::vector<PipeSegment>& pipes;   ///< The merged pipes.
  /// The points removed as large planes (PreprocessResult::planePoints: floors, walls, decks), when
  /// known: a pipe completed over points lying by them is the plane's residue (a floor's seam), and
  /// the lowest of the floors, with no point under it, is the ground no pipe reaches below.
  const PointCloud* planes = nullptr;
  /// The scan's unit up direction: the ground lies across it, and a gently sloping pipe turns off
  /// the level direction under it.
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
};

/// The joined network in the cloud's frame. The pipes keep their input order, less those reaching
/// below the ground, those over points running along removed planes, the fragments an elbow
/// absorbed, the pieces merged into a pipe on whose line they lay and the pipes that had to take a
/// joint and took none; followed by the legs found beyond
/// gentle bends that one pipe was fitted across, then the pipes completed beyond free ends or found
/// as branches (round by round), then the legs between two bends (seen or hidden), with ids from 1
/// in that order (elbows move their ends to the tangent points, and two pipes overlapping at a
/// gentle bend end at its corner, each axis refitted on its side); joint ids continue after the
/// last pipe id.
/// Runs are the connected components of the pipes over accepted joints, every pipe in exactly one
/// run, numbered from 1 in the order of their first pipe.
struct JointsResult {
  std::vector<PipeSegment> pipes;
  std::vector<Joint> joints;
  std::vector<Run> runs;
  std::vector<std::vector<std::uint32_t>> jointSupport;  ///< Per joint, the points on its surface.

  struct Diagnostics {
    std::size_t candidatePairs = 0;        ///< End–pipe pairs the spatial index proposed.
    std::array<std::size_t, 3> hypotheses{};  ///< Valid hypotheses by JointType (elbow, tee, boundary).
    std::size_t conflicts = 0;             ///< Hypotheses dropped: an end already taken, or a pipe left too short.
    std::size_t absorbedFragments = 0;     ///< Fragments removed because they lie on an elbow, and pieces of arcs.
    std::size_t completedPipes = 0;        ///< Pipes found beyond free ends (appended after the input pipes)...
    std::size_t legsBetweenEnds = 0;       ///< ...of them, legs joining two parallel pipes' ends (a U-turn or offset)...
    std::size_t carriedLegs = 0;           ///< ...legs carried on past the completion length to where their points stop...
    std::size_t branchPipes = 0;           ///< ...and branches found off pipes' bodies (appended with them).
    std::size_t splitKinks = 0;            ///< Pairs of pipes overlapping at a gentle bend, split at its corner...
    std::size_t kinkLegs = 0;              ///< ...and legs found beyond a bend one pipe was fitted across (appended
                                           ///< after the input pipes, before the completed ones).
    std::size_t occludedElbows = 0;        ///< Elbows across corners hidden farther than the search distance.
    std::size_t thinRunElbows = 0;         ///< Elbows onto pipes carried on over a stretch seen thinly...
    std::size_t hiddenRunElbows = 0;       ///< ...or over one hardly seen or not at all, their lines meeting exactly.
    std::size_t legsBetweenBends = 0;      ///< Legs between two seen bends, each with its two elbows (appended after
                                           ///< the completed pipes)...
    std::size_t hiddenLegs = 0;            ///< ...and legs a bend of which was not seen, between pipes turning square or offset.
    std::size_t hiddenBranches = 0;        ///< Legs hidden with their elbow and tee, from an end to a main's body.
    std::size_t piecesAtEnds = 0;          ///< Shorter pipes on a pipe's line at its end (completions running on
                                           ///< into it, pieces fitted again) merged into it, their joints its.
    std::size_t piecesInsidePipes = 0;     ///< Pipes taking no joint that lie in a longer pipe's tube (another
                                           ///< radius, or off its line), left out.
    std::size_t mergedSplitBends = 0;      ///< Pieces fitted across a bend, made one elbow with the elbows they took.
    std::size_t revotedBends = 0;          ///< Elbows whose bend was voted again with their arc pieces' points.
    std::size_t underGround = 0;           ///< Input pipes and completed legs whose tube reached below the ground (the
                                           ///< lowest floor, with no scan under it), left out.
    std::size_t planeResidue = 0;          ///< Input pipes over points running along removed planes (a room's edge,
                                           ///< a floor's seam), left out.
    std::size_t unjoinedPipes = 0;         ///< Input pipes that had to take a joint (PipeSegment::mustJoin) and took
                                           ///< none: left out, the rest joined again without them.
    double seconds = 0.0;
  } diagnostics;
};

JointsResult connectPipes(const JointsInput& input, const JointsParams& params, Progress& progress = Progress::none());

/// The paper's major-radius vote (its equations 3–4): the radii R for which `point` lies on the
/// surface of an elbow of minor radius `radius` whose arms leave `corner` (the intersection of the
/// two pipe axes) at ±halfAngle around the unit `bisector`, in the plane with unit normal
/// `planeNormal`. The torus centre is corner + R / sin(halfAngle) × bisector, so each side of the
/// tube gives a quadratic in R; returns its positive roots (up to four).
std::vector<double> elbowRadiusVotes(const Eigen::Vector3d& point, const Eigen::Vector3d& corner,
                                     const Eigen::Vector3d& bisector, const Eigen::Vector3d& planeNormal,
                                     double halfAngle, double radius);

/// The major radius of an elbow turning by `bendAngle` (radians) whose torus gave no vote: the
/// largest R in [minRadius, maxRadius] consistent with an end seen straight up to `seenToCorner`
/// before the corner (negative: past it; infinity: no such end). A straight pipe's inliers run on
/// past its tangent point, R tan(bendAngle / 2) from the corner, while the torus's centre line stays
/// within `band` of the cylinder's axis and its surface turns by at most `maxTilt` (radians, the
/// inliers' normal test), so an end that stops at s before the corner bounds R where that point
/// lies at s + `slack` or nearer. At gentle bends the whole torus stays in the band: no bound.
double unvotedBendRadius(double bendAngle, double seenToCorner, double band, double maxTilt, double slack,
                         double minRadius, double maxRadius);

}  // namespace piperun
