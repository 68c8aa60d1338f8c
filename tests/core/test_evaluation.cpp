#include "piperun/eval/evaluation.h"

#include "piperun/edit/nominal_sizes.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <tuple>

namespace piperun {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// One straight pipe of radius 0.1 m, id 1.
PipeNetwork straightPipe(const Eigen::Vector3d& start, const Eigen::Vector3d& end) {
  PipeNetwork network;
  Pipe pipe;
  pipe.id = 1;
  pipe.radius = 0.1;
  pipe.start = start;
  pipe.end = end;
  network.pipes = {pipe};
  return network;
}

PipeNetwork lShapedRun(const Eigen::Vector3d& shift = Eigen::Vector3d::Zero()) {
  PipeNetwork network;
  Pipe a;
  a.id = 1;
  a.radius = 0.05;
  a.start = Eigen::Vector3d(0, 0, 0) + shift;
  a.end = Eigen::Vector3d(2, 0, 0) + shift;
  Pipe b = a;
  b.id = 2;
  b.start = Eigen::Vector3d(2.1, 0.1, 0) + shift;
  b.end = Eigen::Vector3d(2.1, 2, 0) + shift;
  Pipe c = a;
  c.id = 3;
  c.radius = 0.025;
  c.start = Eigen::Vector3d(1, 0.05, 0) + shift;
  c.end = Eigen::Vector3d(1, 1, 0) + shift;
  network.pipes = {a, b, c};
  Joint elbow;
  elbow.id = 4;
  elbow.type = JointType::Elbow;
  elbow.pipeIds = {1, 2};
  elbow.radius = 0.05;
  elbow.bendRadius = 0.1;
  elbow.axis = sampleArc(Eigen::Vector3d(2, 0.1, 0) + shift, a.end, b.start, 0.01);
  Joint tee;
  tee.id = 5;
  tee.type = JointType::Tee;
  tee.pipeIds = {1, 3};
  tee.radius = 0.025;
  tee.axis = {Eigen::Vector3d(1, 0, 0) + shift, c.start};
  network.joints = {elbow, tee};
  network.runs = {Run{0, {1, 2, 3}, {4, 5}}};
  return network;
}

TEST(Evaluation, TruthAgainstItselfIsPerfect) {
  const PipeNetwork truth = lShapedRun();
  const EvaluationResult result = evaluateNetwork(truth, truth);
  EXPECT_DOUBLE_EQ(result.precision, 1.0);
  EXPECT_DOUBLE_EQ(result.recall, 1.0);
  EXPECT_DOUBLE_EQ(result.f1, 1.0);
  EXPECT_DOUBLE_EQ(result.radiusErrorMedian, 0.0);
  EXPECT_EQ(result.truthElbows, 1);
  EXPECT_EQ(result.foundElbows, 1);
  EXPECT_EQ(result.truthTees, 1);
  EXPECT_EQ(result.foundTees, 1);
  EXPECT_EQ(result.spuriousJoints, 0);
  // Sampled every centimetre: 2 m + 1.9 m + 0.95 m of pipe plus the joints.
  EXPECT_GT(result.truthSamples, 480u);
}

TEST(Evaluation, ShiftedByTenCentimetresIsNearZero) {
  const EvaluationResult result = evaluateNetwork(lShapedRun(), lShapedRun(Eigen::Vector3d(0, 0, 0.1)));
  EXPECT_LT(result.f1, 0.05);
  EXPECT_EQ(result.foundElbows, 0);
  EXPECT_EQ(result.foundTees, 0);
  EXPECT_EQ(result.spuriousJoints, 2);
}

TEST(Evaluation, SmallShiftWithinToleranceStillMatches) {
  const EvaluationResult result = evaluateNetwork(lShapedRun(), lShapedRun(Eigen::Vector3d(0, 0, 0.015)));
  EXPECT_GT(result.f1, 0.99);
}

TEST(Evaluation, EmptyPredictionHasZeroRecall) {
  const EvaluationResult result = evaluateNetwork(lShapedRun(), PipeNetwork{});
  EXPECT_EQ(result.recall, 0.0);
  EXPECT_EQ(result.precision, 0.0);
  EXPECT_EQ(result.f1, 0.0);
}

TEST(Evaluation, HalfTheTruthGivesHalfTheRecall) {
  const PipeNetwork truth = straightPipe({0, 0, 0}, {4, 0, 0});
  PipeNetwork predicted = truth;
  predicted.pipes[0].end = {2, 0, 0};
  predicted.pipes[0].radius = 0.103;
  const EvaluationResult result = evaluateNetwork(truth, predicted);
  EXPECT_DOUBLE_EQ(result.precision, 1.0);
  // Truth samples up to 2 m + tolerance (5 cm = half the radius) are matched: about 205 of 401.
  EXPECT_NEAR(result.recall, 205.0 / 401.0, 1.5 / 401.0);
  EXPECT_NEAR(result.radiusErrorMedian, 0.003, 1e-9);
}

TEST(Evaluation, DeletedPipesAndRejectedJointsAreIgnored) {
  const PipeNetwork truth = lShapedRun();
  PipeNetwork predicted = lShapedRun();
  Pipe ghost = predicted.pipes[0];
  ghost.id = 99;
  ghost.start = {5, 5, 5};
  ghost.end = {6, 5, 5};
  ghost.status = PipeStatus::Deleted;
  predicted.pipes.push_back(ghost);
  predicted.joints[1].status = JointStatus::Rejected;
  const EvaluationResult result = evaluateNetwork(truth, predicted);
  EXPECT_DOUBLE_EQ(result.precision, 1.0);
  EXPECT_EQ(result.foundTees, 0);
  EXPECT_EQ(result.predictedJoints, 1);
  EXPECT_EQ(result.spuriousJoints, 0);
}

TEST(Evaluation, BendRadiusErrorIsRelative) {
  const PipeNetwork truth = lShapedRun();
  PipeNetwork predicted = lShapedRun();
  predicted.joints[0].bendRadius = 0.11;
  EXPECT_NEAR(evaluateNetwork(truth, predicted).bendRadiusErrorMedian, 0.1, 1e-9);
}

TEST(Evaluation, AnElbowTurningAsADifferentFittingIsNotTheTruths) {
  // The truth's 90° elbow, found at its place but turning 45° (the chord of its bend, with a leg
  // along the diagonal): spurious, and the truth's elbow missed. Turning 80° it is found.
  const PipeNetwork truth = lShapedRun();
  const Eigen::Vector3d centre(2, 0.1, 0);
  const Eigen::Vector3d middle = truth.joints[0].axis[truth.joints[0].axis.size() / 2];
  const auto turning = [&](double degrees) {
    PipeNetwork predicted = lShapedRun();
    const double half = 0.5 * degrees * kPi / 180.0;
    const Eigen::Vector3d fromCentre = (middle - centre).normalized();
    const Eigen::Vector3d start = centre + 0.1 * (Eigen::AngleAxisd(-half, Eigen::Vector3d::UnitZ()) * fromCentre);
    const Eigen::Vector3d end = centre + 0.1 * (Eigen::AngleAxisd(half, Eigen::Vector3d::UnitZ()) * fromCentre);
    predicted.joints[0].axis = sampleArc(centre, start, end, 0.01);
    return evaluateNetwork(truth, predicted);
  };
  const EvaluationResult chord = turning(45.0);
  EXPECT_EQ(chord.foundElbows, 0);
  EXPECT_EQ(chord.spuriousJoints, 1);
  const EvaluationResult near = turning(80.0);
  EXPECT_EQ(near.foundElbows, 1);
  EXPECT_EQ(near.spuriousJoints, 0);
}

TEST(Evaluation, PipesOnlyLeavesTheJointsOut) {
  const PipeNetwork truth = lShapedRun();
  PipeNetwork pipes = truth;
  pipes.joints.clear();
  EvaluationParams params;
  EXPECT_LT(evaluateNetwork(truth, pipes, params).recall, 0.99);
  params.pipesOnly = true;
  const EvaluationResult result = evaluateNetwork(truth, pipes, params);
  EXPECT_DOUBLE_EQ(result.recall, 1.0);
  EXPECT_DOUBLE_EQ(result.precision, 1.0);
}

/// A scan of the truth pipe 1 (0 to 4 m along x, r 0.1) that shows only x in [0, 1] and [3, 4]:
/// one labelled point per centimetre on its surface, plus points of other surfaces.
PointCloud partlyScannedPipe() {
  PointCloud scan;
  scan.origin = Eigen::Vector3d(100, 0, 0);  // labels are matched in world coordinates
  for (int cm = 0; cm <= 400; ++cm) {
    if (cm > 100 && cm < 300) continue;
    scan.positions.emplace_back(static_cast<float>(cm) * 0.01f, 0.0f, 0.1f);
    scan.labels.push_back(1);
  }
  for (int i = 0; i < 50; ++i) {  // clutter (0) and outliers (-1) along the hidden middle
    scan.positions.emplace_back(1.5f + 0.01f * static_cast<float>(i), 0.0f, 0.1f);
    scan.labels.push_back(i % 2 == 0 ? 0 : -1);
  }
  return scan;
}

TEST(Evaluation, ObservableRecallCountsOnlyWhatTheScanShows) {
  const PipeNetwork truth = straightPipe({100, 0, 0}, {104, 0, 0});
  PipeNetwork predicted = truth;
  predicted.pipes[0].end = {101, 0, 0};  // finds the first scanned metre only
  const PointCloud scan = partlyScannedPipe();

  const EvaluationResult result = evaluateNetwork(truth, predicted, {}, &scan);
  ASSERT_TRUE(result.observableMeasured);
  // A sample is observable while its ±5 cm window holds five points: up to 1 cm beyond each
  // scanned stretch, 0–1.01 m and 2.99–4 m, 204 of 401 samples.
  EXPECT_EQ(result.observableTruthSamples, 204u);
  EXPECT_NEAR(result.observableShare, 204.0 / 401.0, 1e-12);
  // The first stretch is matched and the last is not; recall over all the truth also counts the
  // hidden samples within the 5 cm tolerance of the found pipe (to 1.05 m).
  EXPECT_EQ(result.matchedObservableSamples, 102u);
  EXPECT_NEAR(result.recallObservable, 0.5, 1e-12);
  EXPECT_NEAR(result.recall, 106.0 / 401.0, 1e-12);
  EXPECT_NE(formatEvaluation(result).find(" observable=0.509 recall_observable=0.500 observable_elbows=0/0"),
            std::string::npos);

  EXPECT_FALSE(evaluateNetwork(truth, predicted).observableMeasured);
  PointCloud unlabelled = partlyScannedPipe();
  unlabelled.labels.clear();
  EXPECT_THROW(evaluateNetwork(truth, predicted, {}, &unlabelled), std::invalid_argument);
}

/// A scan of `count` points at each given place, labelled with a truth element: (label, place, count).
PointCloud placedLabelledScan(const std::vector<std::tuple<int, Eigen::Vector3f, int>>& groups) {
  PointCloud scan;
  for (const auto& [element, place, count] : groups) {
    for (int i = 0; i < count; ++i) {
      scan.positions.push_back(place);
      scan.labels.push_back(element);
    }
  }
  return scan;
}

/// A scan of points (all at the origin) labelled with truth elements: (label, count) pairs.
PointCloud labelledScan(const std::vector<std::pair<int, int>>& counts) {
  std::vector<std::tuple<int, Eigen::Vector3f, int>> groups;
  for (const auto& [element, count] : counts) groups.emplace_back(element, Eigen::Vector3f::Zero(), count);
  return placedLabelledScan(groups);
}

TEST(Evaluation, ObservableJointsHaveEnoughPointsOnEachPipe) {
  const PipeNetwork truth = lShapedRun();  // elbow 4 joins pipes 1 and 2, tee 5 pipes 1 and 3
  // Pipe 3 holds one short of the 20 points a pipe needs: the tee is not observable. Label 0: clutter.
  const PointCloud scan = labelledScan({{1, 30}, {2, 20}, {3, 19}, {0, 50}});

  const EvaluationResult all = evaluateNetwork(truth, truth, {}, &scan);
  EXPECT_EQ(all.observableElbows, 1);
  EXPECT_EQ(all.foundObservableElbows, 1);
  EXPECT_EQ(all.observableTees, 0);
  EXPECT_NE(formatEvaluation(all).find(" observable_elbows=1/1 observable_tees=0/0"), std::string::npos);

  PipeNetwork noElbow = truth;
  noElbow.joints.erase(noElbow.joints.begin());
  const EvaluationResult missed = evaluateNetwork(truth, noElbow, {}, &scan);
  EXPECT_EQ(missed.observableElbows, 1);
  EXPECT_EQ(missed.foundObservableElbows, 0);
  EXPECT_EQ(missed.foundElbows, 0);
  EXPECT_EQ(missed.foundTees, 1);
}

TEST(Evaluation, AJointIsSeenAtItsCornerWhenEachPipeHasPointsNearIt) {
  const PipeNetwork truth = lShapedRun();  // elbow 4 near (2.07, 0.03, 0) joins pipes 1 and 2
  // Pipe 1 is seen by the elbow and far off, pipe 2 only 1.8 m up: the elbow is observable (20
  // points or more on each pipe) but not seen at its corner (5 points within 0.5 m: 8 radii are less).
  std::vector<std::tuple<int, Eigen::Vector3f, int>> groups{
      {1, Eigen::Vector3f(1.9f, 0.0f, 0.0f), 6}, {1, Eigen::Vector3f(0.2f, 0.0f, 0.0f), 20},
      {2, Eigen::Vector3f(2.1f, 1.8f, 0.0f), 30}};
  const PointCloud farScan = placedLabelledScan(groups);
  const EvaluationResult hidden = evaluateNetwork(truth, truth, {}, &farScan);
  EXPECT_EQ(hidden.observableElbows, 1);
  EXPECT_EQ(hidden.cornerSeenElbows, 0);
  ASSERT_EQ(hidden.jointOutcomes.size(), 2u);
  EXPECT_EQ(hidden.jointOutcomes[0].pipePointsNearCorner, (std::vector<int>{6, 0}));
  EXPECT_DOUBLE_EQ(hidden.jointOutcomes[0].cornerDistance, 0.5);
  EXPECT_NE(formatEvaluation(hidden).find(" corner_seen_elbows=0/0 corner_seen_tees=0/0"), std::string::npos);

  // Five points of pipe 2 just past the elbow's tangent point: seen at its corner, and found.
  groups.emplace_back(2, Eigen::Vector3f(2.1f, 0.3f, 0.0f), 5);
  const PointCloud nearScan = placedLabelledScan(groups);
  const EvaluationResult seen = evaluateNetwork(truth, truth, {}, &nearScan);
  EXPECT_EQ(seen.cornerSeenElbows, 1);
  EXPECT_EQ(seen.foundCornerSeenElbows, 1);
  PipeNetwork noElbow = truth;
  noElbow.joints.erase(noElbow.joints.begin());
  const EvaluationResult missed = evaluateNetwork(truth, noElbow, {}, &nearScan);
  EXPECT_EQ(missed.cornerSeenElbows, 1);
  EXPECT_EQ(missed.foundCornerSeenElbows, 0);
}

TEST(Evaluation, AMissedJointSaysWhetherItWasUnseenItsPipeNotFoundOrItNotJoined) {
  const PipeNetwork truth = lShapedRun();  // elbow 4 near (2.07, 0.03, 0) joins pipes 1 and 2
  // Ten points on each pipe within the elbow's reach (0.5 m), enough for the samples there to be
  // observable; pipe 3 and the tee hold none.
  const std::vector<std::tuple<int, Eigen::Vector3f, int>> nearCorner{{1, Eigen::Vector3f(1.8f, 0.0f, 0.0f), 10},
                                                                      {2, Eigen::Vector3f(2.1f, 0.3f, 0.0f), 10}};
  const PointCloud scan = placedLabelledScan(nearCorner);
  PipeNetwork noElbow = truth;
  noElbow.joints.erase(noElbow.joints.begin());

  // Both pipes found where the scan shows them, the elbow not made: the joints stage's miss.
  const EvaluationResult notJoined = evaluateNetwork(truth, noElbow, {}, &scan);
  ASSERT_EQ(notJoined.jointOutcomes.size(), 2u);
  EXPECT_EQ(notJoined.jointOutcomes[0].cause, MissCause::NotJoined);
  EXPECT_EQ(notJoined.jointOutcomes[0].pipeFoundNearCorner, (std::vector<double>{1.0, 1.0}));
  EXPECT_EQ(notJoined.missedElbows.notJoined, 1);
  EXPECT_EQ(notJoined.missedElbows.pipeNotFound + notJoined.missedElbows.unseen, 0);
  // The tee was found: no cause, nothing counted for tees.
  EXPECT_EQ(notJoined.jointOutcomes[1].matchedId, 5);
  EXPECT_EQ(notJoined.jointOutcomes[1].cause, MissCause::None);
  EXPECT_EQ(notJoined.missedTees.unseen + notJoined.missedTees.pipeNotFound + notJoined.missedTees.notJoined, 0);
  EXPECT_NE(formatEvaluation(notJoined).find(" missed_elbows_unseen=0 missed_elbows_pipe_not_found=0"
                                             " missed_elbows_not_joined=1 missed_tees_unseen=0"),
            std::string::npos);

  // Pipe 2 found only from 1 m up, away from the points by the corner: a pipe not found there.
  PipeNetwork shortPipe = noElbow;
  shortPipe.pipes[1].start = Eigen::Vector3d(2.1, 1.0, 0);
  const EvaluationResult pipeNotFound = evaluateNetwork(truth, shortPipe, {}, &scan);
  EXPECT_EQ(pipeNotFound.jointOutcomes[0].cause, MissCause::PipeNotFound);
  EXPECT_DOUBLE_EQ(pipeNotFound.jointOutcomes[0].pipeFoundNearCorner[0], 1.0);
  EXPECT_DOUBLE_EQ(pipeNotFound.jointOutcomes[0].pipeFoundNearCorner[1], 0.0);
  EXPECT_EQ(pipeNotFound.missedElbows.pipeNotFound, 1);

  // Only four points of pipe 2 near the corner (under cornerMinPoints): unseen, found pipes or not.
  const PointCloud thinScan = placedLabelledScan({nearCorner[0],
                                                  {2, Eigen::Vector3f(2.1f, 0.3f, 0.0f), 4}});
  const EvaluationResult unseen = evaluateNetwork(truth, noElbow, {}, &thinScan);
  EXPECT_EQ(unseen.jointOutcomes[0].cause, MissCause::Unseen);
  EXPECT_EQ(unseen.missedElbows.unseen, 1);
  EXPECT_EQ(toString(MissCause::Unseen), "unseen");

  // Found: no cause; without a scan, none told.
  EXPECT_EQ(evaluateNetwork(truth, truth, {}, &scan).jointOutcomes[0].cause, MissCause::None);
  EXPECT_EQ(evaluateNetwork(truth, noElbow).jointOutcomes[0].cause, MissCause::None);
  EXPECT_TRUE(evaluateNetwork(truth, noElbow).jointOutcomes[0].pipeFoundNearCorner.empty());
}

TEST(Evaluation, JointOutcomesSayWhatWasFoundMissedAndSpurious) {
  const PipeNetwork truth = lShapedRun();  // elbow 4 joins pipes 1 and 2, tee 5 pipes 1 and 3
  PipeNetwork predicted = truth;
  predicted.joints[0].bendRadius = 0.12;
  predicted.joints[1].axis = {Eigen::Vector3d(1.5, 0, 0), Eigen::Vector3d(1.5, 0.05, 0)};  // 0.5 m off: no match
  predicted.joints[1].status = JointStatus::Proposed;
  predicted.joints[1].confidence = 0.3;
  // Seven points on the elbow itself; pipe 3 and the tee hold none.
  const PointCloud scan = labelledScan({{1, 30}, {2, 20}, {4, 7}});

  const EvaluationResult result = evaluateNetwork(truth, predicted, {}, &scan);
  ASSERT_EQ(result.jointOutcomes.size(), 2u);
  const JointOutcome& elbow = result.jointOutcomes[0];
  EXPECT_EQ(elbow.truthId, 4);
  EXPECT_EQ(elbow.type, JointType::Elbow);
  EXPECT_EQ(elbow.matchedId, 4);
  EXPECT_NEAR(elbow.distance, 0.0, 1e-12);
  EXPECT_DOUBLE_EQ(elbow.truthBendRadius, 0.1);
  EXPECT_DOUBLE_EQ(elbow.predictedBendRadius, 0.12);
  EXPECT_EQ(elbow.pipeIds, (std::vector<int>{1, 2}));
  EXPECT_EQ(elbow.pipePoints, (std::vector<int>{30, 20}));
  EXPECT_EQ(elbow.ownPoints, 7);
  const JointOutcome& tee = result.jointOutcomes[1];
  EXPECT_EQ(tee.truthId, 5);
  EXPECT_EQ(tee.matchedId, -1);
  EXPECT_EQ(tee.pipePoints, (std::vector<int>{30, 0}));
  EXPECT_EQ(tee.ownPoints, 0);
  EXPECT_TRUE(tee.position.isApprox(Eigen::Vector3d(1, 0, 0)));

  ASSERT_EQ(result.spurious.size(), 1u);
  EXPECT_EQ(result.spuriousJoints, 1);
  const SpuriousJoint& spurious = result.spurious[0];
  EXPECT_EQ(spurious.id, 5);
  EXPECT_EQ(spurious.type, JointType::Tee);
  EXPECT_EQ(spurious.status, JointStatus::Proposed);
  EXPECT_DOUBLE_EQ(spurious.confidence, 0.3);
  EXPECT_EQ(spurious.nearestTruthId, 5);
  EXPECT_NEAR(spurious.nearestTruthDistance, 0.5, 1e-9);

  // Without a scan there are no point counts.
  const EvaluationResult unscanned = evaluateNetwork(truth, predicted);
  EXPECT_TRUE(unscanned.jointOutcomes[0].pipePoints.empty());
  EXPECT_EQ(unscanned.jointOutcomes[0].ownPoints, -1);
}

TEST(Evaluation, FiguresByReviewStatusSplitTheSamplesAndTheSpuriousJoints) {
  const PipeNetwork truth = lShapedRun();  // elbow 4 joins pipes 1 and 2, tee 5 pipes 1 and 3
  PipeNetwork predicted = truth;
  predicted.pipes[2].status = PipeStatus::Proposed;     // pipe 3, on the truth
  predicted.joints[0].status = JointStatus::Proposed;   // elbow 4, on the truth
  Pipe stray = predicted.pipes[0];                      // proposed, a metre above the truth
  stray.id = 6;
  stray.start = Eigen::Vector3d(0, 0, 1);
  stray.end = Eigen::Vector3d(1, 0, 1);
  stray.status = PipeStatus::Proposed;
  predicted.pipes.push_back(stray);
  predicted.joints[1].axis = {Eigen::Vector3d(1.5, 0, 1), Eigen::Vector3d(1.5, 0.05, 1)};  // accepted, off the truth

  const EvaluationResult result = evaluateNetwork(truth, predicted);
  EXPECT_EQ(result.spuriousAccepted.part, 1u);
  EXPECT_EQ(result.spuriousAccepted.total, 1u);
  EXPECT_EQ(result.spuriousProposed.part, 0u);
  EXPECT_EQ(result.spuriousProposed.total, 1u);

  // The statuses split every predicted sample; the unmatched ones are the stray pipe's (proposed)
  // and the moved tee's (accepted).
  EXPECT_EQ(result.acceptedSamples.total + result.proposedSamples.total, result.predictedSamples);
  EXPECT_EQ(result.acceptedSamples.part + result.proposedSamples.part, result.matchedPredictedSamples);
  PipeNetwork strayAlone;
  strayAlone.pipes = {stray};
  const EvaluationResult strayFigures = evaluateNetwork(truth, strayAlone);
  EXPECT_EQ(strayFigures.matchedPredictedSamples, 0u);
  EXPECT_EQ(result.proposedSamples.total - result.proposedSamples.part, strayFigures.predictedSamples);
  EXPECT_GT(result.proposedSamples.part, 90u);  // pipe 3 (0.95 m) and the elbow, in 1 cm steps
  PipeNetwork teeAlone;
  teeAlone.joints = {predicted.joints[1]};
  const EvaluationResult teeFigures = evaluateNetwork(truth, teeAlone);
  EXPECT_EQ(teeFigures.matchedPredictedSamples, 0u);
  EXPECT_EQ(result.acceptedSamples.total - result.acceptedSamples.part, teeFigures.predictedSamples);
  EXPECT_NE(formatEvaluation(result).find(" spurious_accepted=1/1 spurious_proposed=0/1"), std::string::npos);
}

TEST(Evaluation, NominalSizeRightCountsMatchedSamplesOfTheTruthsSize) {
  const PipeNetwork truth = lShapedRun();  // 50 mm pipes 1 and 2 (DN 80), a 25 mm branch
  const NominalSizes sizes = NominalSizes::shipped();
  EvaluationParams params;
  params.nominalSizes = &sizes;
  const EvaluationResult same = evaluateNetwork(truth, truth, params);
  EXPECT_TRUE(same.nominalMeasured);
  EXPECT_EQ(same.nominalSizeRight, same.matchedTruthSamples);

  // Pipe 2 (1.9 m) fitted 8 mm wide is the next size up; 1 mm wide, still the truth's.
  PipeNetwork wide = truth;
  wide.pipes[1].radius = 0.058;
  const EvaluationResult wrong = evaluateNetwork(truth, wide, params);
  EXPECT_EQ(wrong.matchedTruthSamples, same.matchedTruthSamples);
  EXPECT_NEAR(static_cast<double>(wrong.matchedTruthSamples - wrong.nominalSizeRight), 190.0, 5.0);
  EXPECT_NE(formatEvaluation(wrong).find(" nominal_size_right="), std::string::npos);
  wide.pipes[1].radius = 0.051;
  EXPECT_EQ(evaluateNetwork(truth, wide, params).nominalSizeRight, same.matchedTruthSamples);

  const EvaluationResult unmeasured = evaluateNetwork(truth, truth);
  EXPECT_FALSE(unmeasured.nominalMeasured);
  EXPECT_EQ(formatEvaluation(unmeasured).find("nominal_size_right"), std::string::npos);
}

TEST(Evaluation, FormatLine) {
  const EvaluationResult result = evaluateNetwork(lShapedRun(), lShapedRun());
  EXPECT_EQ(formatEvaluation(result).substr(0, 52), "precision=1.000 recall=1.000 f1=1.000 radius_err_mm=");
}

}  // namespace
}  // namespace piperun
