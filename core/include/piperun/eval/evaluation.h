#pragma once
// Accuracy of a reconstructed network against ground truth (the paper's metric, docs/EVALUATION.md).

#include "piperun/pipe_network.h"
#include "piperun/point_cloud.h"

#include <cstddef>
#include <string>
#include <vector>

namespace piperun {

class NominalSizes;

struct EvaluationParams {
  double sampleStep = 0.01;          ///< Axis polylines are sampled every this many metres.
  double minTolerance = 0.02;        ///< A sample matches within max(minTolerance, radiusFactor × truth radius)...
  double radiusFactor = 0.5;         ///< ...of a truth sample.
  double fixedTolerance = 0.0;       ///< When > 0, this tolerance (m) replaces the rule above.
  double jointMinDistance = 0.05;    ///< Joints match when their positions are within
  double jointRadiusFactor = 1.0;    ///< max(jointMinDistance, jointRadiusFactor × truth radius), same type,
  double jointMaxTurnDifferenceDeg = 22.5;  ///< and elbows turn alike to within this (half a 45° fitting's turn).
  bool pipesOnly = false;            ///< Sample only the straight pipes of both networks (figures "before joints").
  /// With a labelled scan: a truth sample is observable when at least observableMinPoints points
  /// labelled with its element lie nearest to the element's samples within ±observableWindow (m).
  double observableWindow = 0.05;
  int observableMinPoints = 5;
  /// With a labelled scan: a truth elbow or tee is observable when each of its pipes has at least
  /// this many labelled points.
  int observableJointMinPoints = 20;
  /// With a labelled scan: a truth elbow or tee is seen at its corner when each of its pipes has at
  /// least cornerMinPoints labelled points within max(cornerMinDistance, cornerRadii × the joint's
  /// radius) of its position. A pipe seen far off but hidden where it turns shows nothing of the turn.
  double cornerMinDistance = 0.5;
  double cornerRadii = 8.0;
  int cornerMinPoints = 5;
  /// With a labelled scan: a pipe of a missed joint counts as found at the corner when the prediction
  /// matches at least this share of its samples within the corner's reach that are observable (of
  /// all its samples there when none is; see MissCause).
  double cornerFoundShare = 0.5;
  /// When given: also how often the prediction's nominal size (the table's nearest to its radius,
  /// as PCF exports write it) is the truth's, over the matched truth samples.
  const NominalSizes* nominalSizes = nullptr;
};

/// Why a truth elbow or tee was missed, told with a labelled scan: the stage to look at.
enum class MissCause {
  None,          ///< Found, or no labelled scan to tell.
  Unseen,        ///< A pipe is not seen at the corner (under cornerMinPoints points near it; see corner_seen).
  PipeNotFound,  ///< Each pipe is seen at the corner, but the prediction misses one there (placement, completion).
  NotJoined,     ///< Each pipe is seen and found at the corner, but no joint of the type matches (joints).
};

/// "unseen", "pipe_not_found", "not_joined" ("" for None).
std::string toString(MissCause cause);

/// What the evaluation made of one truth elbow or tee.
struct JointOutcome {
  int truthId = 0;
  JointType type = JointType::Elbow;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< The truth joint's position (Joint::position).
  int matchedId = -1;                ///< The predicted joint matched to it; -1: missed.
  double distance = 0.0;             ///< Between the two positions (m), when matched.
  double truthBendRadius = 0.0;      ///< Elbows: the truth's major radius R...
  double predictedBendRadius = 0.0;  ///< ...and the matched elbow's (m).
  std::vector<int> pipeIds;          ///< The truth pipes it joins...
  std::vector<int> pipePoints;       ///< ...and the scan points labelled with each (with a labelled scan, else empty).
  int ownPoints = -1;                ///< With a labelled scan (and joints sampled): the points labelled with the
                                     ///< joint itself; -1 when not measured.
  std::vector<int> pipePointsNearCorner;  ///< With a labelled scan: each pipe's labelled points near the joint
  double cornerDistance = 0.0;       ///< (within this of its position, m; see EvaluationParams::cornerMinDistance).
  std::vector<double> pipeFoundNearCorner;  ///< With a labelled scan: per pipe, the share of its samples
                                            ///< within cornerDistance that the prediction matches (see
                                            ///< EvaluationParams::cornerFoundShare; -1: none there).
  MissCause cause = MissCause::None;  ///< With a labelled scan, when missed: why.
};

/// Missed truth joints of one type by cause (with a labelled scan).
struct MissCounts {
  int unseen = 0;
  int pipeNotFound = 0;
  int notJoined = 0;
};

/// A predicted joint (not rejected) that matched no truth joint.
struct SpuriousJoint {
  int id = 0;
  JointType type = JointType::Elbow;
  JointStatus status = JointStatus::Accepted;
  double confidence = 0.0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  int nearestTruthId = -1;           ///< The nearest truth elbow or tee, whatever its type; -1 when none...
  double nearestTruthDistance = 0.0; ///< ...and how far it is (m).
};

/// A part of a whole, counted over the predicted elements of one review status.
struct ReviewShare {
  std::size_t part = 0;
  std::size_t total = 0;
};

struct EvaluationResult {
  double precision = 0.0;            ///< Share of predicted samples within tolerance of a truth sample.
  double recall = 0.0;               ///< Share of truth samples within tolerance of a predicted sample.
  double f1 = 0.0;
  double radiusErrorMedian = 0.0;    ///< Median |r_pred − r_truth| over matched truth samples (m); 0 when none.
  bool nominalMeasured = false;      ///< EvaluationParams::nominalSizes was given: of the matched truth samples,
  std::size_t nominalSizeRight = 0;  ///< those whose nearest predicted sample has the truth's nominal size.
  std::size_t truthSamples = 0;
  std::size_t predictedSamples = 0;
  std::size_t matchedTruthSamples = 0;
  std::size_t matchedPredictedSamples = 0;

  bool observableMeasured = false;   ///< The figures below were computed (a labelled scan was given).
  std::size_t observableTruthSamples = 0;
  std::size_t matchedObservableSamples = 0;
  double observableShare = 0.0;      ///< Observable truth samples / all truth samples.
  double recallObservable = 0.0;     ///< Share of observable truth samples within tolerance of a predicted sample.
  int observableElbows = 0;          ///< Truth elbows whose pipes the scan shows, and how many of those were found.
  int foundObservableElbows = 0;
  int observableTees = 0;            ///< The same for tees.
  int foundObservableTees = 0;
  int cornerSeenElbows = 0;          ///< Truth elbows each of whose pipes the scan shows near the corner (see
  int foundCornerSeenElbows = 0;     ///< EvaluationParams::cornerMinPoints), and how many of those were found.
  int cornerSeenTees = 0;            ///< The same for tees.
  int foundCornerSeenTees = 0;
  MissCounts missedElbows;           ///< The missed truth elbows by cause (see MissCause)...
  MissCounts missedTees;             ///< ...and tees.

  int truthElbows = 0;
  int foundElbows = 0;               ///< Truth elbows matched by a predicted elbow.
  int truthTees = 0;
  int foundTees = 0;                 ///< Truth tees matched by a predicted tee.
  int predictedJoints = 0;           ///< Predicted joints that are not rejected.
  int spuriousJoints = 0;            ///< Predicted joints that match no truth joint.
  double bendRadiusErrorMedian = 0.0;  ///< Median |R_pred − R_truth| / R_truth over matched elbows.

  /// By review status, what a user who keeps the accepted elements and reviews the proposed ones
  /// gets: the predicted samples of accepted (and of proposed) pipes and joints that match the truth
  /// (precision by status)...
  ReviewShare acceptedSamples;
  ReviewShare proposedSamples;
  /// ...and the accepted (proposed) joints that are spurious.
  ReviewShare spuriousAccepted;
  ReviewShare spuriousProposed;

  std::vector<JointOutcome> jointOutcomes;  ///< Every truth elbow, then every tee, each in truth order.
  std::vector<SpuriousJoint> spurious;      ///< The spurious joints, in prediction order.
};

/// Compares `predicted` with `truth`. Pipes with status Deleted and joints with status Rejected
/// of the prediction are left out; every element of the truth counts. `labelledScan`, when given,
/// is the scan the prediction came from with each point labelled by the truth element it samples
/// (`piperun generate --labels`): recall is then also measured over the truth the scan shows.
EvaluationResult evaluateNetwork(const PipeNetwork& truth, const PipeNetwork& predicted,
                                 const EvaluationParams& params = {}, const PointCloud* labelledScan = nullptr);

/// "precision=0.912 recall=0.874 f1=0.893 radius_err_mm=3.1 elbows=17/20 tees=5/6 ...
/// accepted_matched=2410/2436 proposed_matched=120/300 spurious_accepted=1/20 spurious_proposed=1/4", with
/// nominal sizes " nominal_size_right=2390/2412", then
/// "observable=0.906 recall_observable=0.939 observable_elbows=73/89 observable_tees=20/22
/// corner_seen_elbows=70/80 corner_seen_tees=19/21 missed_elbows_unseen=2
/// missed_elbows_pipe_not_found=1 missed_elbows_not_joined=0 missed_tees_unseen=1 …" when those
/// were measured.
std::string formatEvaluation(const EvaluationResult& result);

}  // namespace piperun
