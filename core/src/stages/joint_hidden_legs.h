#pragma once
// The joints stage's last searches (see joints.cpp, step 5): ends still free joined across corners
// hidden behind something, to pipes seen running on thinly, and by legs little or none of which was seen.

#include "stages/joint_resolution.h"
#include "points_near.h"

#include <vector>

namespace piperun::joints {

/// Elbows across occlusions. A corner hidden behind equipment or another pipe leaves both its
/// pipes cut short, often farther from it than the search distance, and after the completion no
/// other joint claims their ends. Two such ends look for each other up to
/// `occludedSearchDiameters`, for corners the search distance does not reach. An elbow between
/// them is chosen (the best-supported first) when the stretches it bridges to its tangent points
/// keep out of every other pipe and hold no points near their axes (whatever was seen there stands
/// where the pipe would run). Nothing was seen on those stretches, so the elbow's confidence stays
/// low: it is proposed, for review. Returns the bridged stretches.
std::vector<PipeSegment> bridgeOccludedCorners(const JointsInput& input, const JointsParams& params,
                                               const std::vector<char>& explained, const PointCells& cells,
                                               Resolution& resolution);

/// Elbows onto pipes that run on thinly. A long pipe running away from the scanner thins out, and
/// placement and the extents keep only its denser part: its end may stop metres short of the elbow
/// where the pipe it meets is seen right up to the corner. After the hidden corners, a free end
/// whose corner with another pipe's free end lies ahead of it within the search distance, while the
/// other end faces the corner from farther (at most `maxThinStretch`), makes that elbow when the
/// stretch the other pipe would run to its tangent point was seen thinly all along: at least half
/// its 25 cm sections hold a point on its surface that no pipe explains, and at most
/// kMaxThinCorePoints points per metre lie near its axis (stray points, not something in the way);
/// it cuts no other pipe. (Its points are looked at in the preprocessed cloud, which keeps fewer of
/// them than the scan: isolated points go as outliers.) The best-supported go first, an end takes
/// one. The elbow's confidence is capped at the share of the stretch's 4 cm sections seen:
/// proposed, for review, when as thin as such stretches are. A stretch seen less than that, or not
/// at all (hidden behind a pipe running in front of it, or out of the scanner's sight), is carried
/// on as well when the two centre lines meet within kMaxHiddenSkewRadii: a pipe seen up to its
/// tangent point below another's line, which meets it that exactly, turns into it. Either way the
/// bend is voted for only up to the radius that starts it a radius back along the near pipe, seen
/// straight up to its end (other points near the corner vote for wider bends). Returns the
/// stretches carried on.
std::vector<PipeSegment> reachThinRuns(const JointsInput& input, const JointsParams& params,
                                       const std::vector<char>& explained, const PointCells& cells, Resolution& resolution);

/// Legs between two seen bends. Two pipes may each be seen turning square off their ends, one
/// towards the other's line, while the leg between the bends holds too few points for any
/// completion (a thin or far leg, or one mostly in shadow). After the hidden corners, two ends
/// still free whose lines pass each other askew and near square, or run parallel facing past each
/// other, are joined by the lines' common perpendicular (squareLegCandidates) with an elbow at each
/// corner, when both bends are seen (their tori hold at least a fifth of the points their pipes'
/// density gives an arc, and that is at least ten points), or when the lines pass square or run
/// parallel and the pipes are alike (SquareLeg::mayBeHidden: a leg hidden whole, bends included,
/// behind something), and everything the joints bridge (the leg between its tangent points and the
/// stretches from the ends to theirs) keeps out of every other pipe and holds no points near its
/// axis. The best-supported pair of bends goes first; a leg cuts no leg chosen before it. The
/// elbows' confidence is capped at the share of the leg's sections seen: a leg that little of was
/// seen is proposed, for review. Returns the legs chosen, which follow `input.pipes` in
/// `resolution`.
std::vector<PipeSegment> joinSeenBends(const JointsInput& input, const JointsParams& params,
                                       const std::vector<char>& explained, const PointCells& cells, Resolution& resolution);

/// Legs hidden between an end and a main. A pipe may turn square off its end into a short leg that
/// meets a thicker pipe's body at a tee, the leg seen in glimpses at most (behind the main, in a
/// station's shadow): too little for a completion. After the legs between bends, an end still free
/// is joined to another pipe, at least as thick, by a leg along one of the network's `directions`
/// square to both: where the end's line passes square to the main's axis (within
/// kSquareLegDirectionDeg), their common perpendicular, its corner within the search distance
/// ahead of the end; where the end's pipe runs beside the main, the perpendicular from where a
/// short-radius elbow's corner would be (the end seen up to its tangent point). The leg's foot lies
/// two of its radii inside the main's body, and it is long enough for an elbow and the main's
/// radius and no longer than a completion. The elbow and the tee are reconstructed as every joint
/// is; the bend must have been seen at the density of the end's pipe (as a short-radius elbow's,
/// beside the main), a section of the leg seen too, and nothing stand where they bridge (see
/// nothingInTheWay). Their confidence is capped at the share of the leg seen: proposed, for review.
/// The best-supported go first, an end takes one. Returns the legs.
std::vector<PipeSegment> joinHiddenBranches(const JointsInput& input, const JointsParams& params,
                                            const std::vector<char>& explained, const PointCells& cells,
                                            Resolution& resolution);

}  // namespace piperun::joints
