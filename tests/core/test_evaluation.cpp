#include "piperun/eval/evaluation.h"

#include <gtest/gtest.h>

namespace piperun {
namespace {

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
  PipeNetwork truth;
  Pipe pipe;
  pipe.id = 1;
  pipe.radius = 0.1;
  pipe.start = {0, 0, 0};
  pipe.end = {4, 0, 0};
  truth.pipes = {pipe};
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

TEST(Evaluation, FormatLine) {
  const EvaluationResult result = evaluateNetwork(lShapedRun(), lShapedRun());
  EXPECT_EQ(formatEvaluation(result).substr(0, 52), "precision=1.000 recall=1.000 f1=1.000 radius_err_mm=");
}

}  // namespace
}  // namespace piperun
