// Reviews driven by script on a generated scene: fits, added joints, re-runs with carry-over,
// save and reopen.

#include "piperun/edit/command_interpreter.h"
#include "piperun/edit/pipe_fit.h"
#include "piperun/io/network_io.h"
#include "piperun/io/point_writer.h"
#include "piperun/params.h"
#include "piperun/synth/scene_generator.h"
#include "test_scene.h"
#include "test_util.h"

#include <gtest/gtest.h>

#include <fstream>
#include <limits>

namespace piperun {
namespace {

std::shared_ptr<const PointCloud> sceneCloud() { return test::smallSceneCloud(); }

std::string snapshot(const PipeNetwork& network) { return networkToJson(network); }

const Pipe& longestPipe(const PipeNetwork& network) {
  return *std::max_element(network.pipes.begin(), network.pipes.end(),
                           [](const Pipe& a, const Pipe& b) { return a.length() < b.length(); });
}

double distanceToAxis(const Pipe& pipe, const Eigen::Vector3d& p) {
  const Eigen::Vector3d q = p - pipe.start;
  return (q - q.dot(pipe.direction()) * pipe.direction()).norm();
}

const Joint* firstJoint(const PipeNetwork& network, JointType type, const std::vector<int>& skip = {}) {
  for (const Joint& joint : network.joints) {
    if (joint.type == type && std::find(skip.begin(), skip.end(), joint.id) == skip.end()) return &joint;
  }
  return nullptr;
}

class EditReview : public ::testing::Test {
 protected:
  void SetUp() override {
    pipeline_ = std::make_unique<Pipeline>(sceneCloud());
    pipeline_->run();
    writePointCloud(dir_ / "scene.ply", *sceneCloud());
    project_ = newProject(dir_ / "scene.ply", *pipeline_);
    interpreter_ = std::make_unique<CommandInterpreter>(project_, pipeline_.get());
  }

  test::TempDir dir_;
  std::unique_ptr<Pipeline> pipeline_;
  Project project_;
  std::unique_ptr<CommandInterpreter> interpreter_;
};

TEST_F(EditReview, EditedRunsFollowTheJointsStageRule) {
  // The session rebuilds runs with assignRuns(); on the pipeline's network it changes nothing.
  EXPECT_EQ(snapshot(project_.edits.network()), snapshot(pipeline_->network()));
}

TEST_F(EditReview, FitInABoxFindsThePipeInside) {
  const Pipe& pipe = longestPipe(project_.edits.network());
  // The middle 60 % of the pipe, with a margin around its surface.
  const Eigen::Vector3d a = pipe.start + 0.2 * (pipe.end - pipe.start), b = pipe.start + 0.8 * (pipe.end - pipe.start);
  const Eigen::Vector3d margin = Eigen::Vector3d::Constant(pipe.radius + 0.03);
  const Pipe fitted = fitPipeInBox(pipeline_->preprocessResult()->points, a.cwiseMin(b) - margin, a.cwiseMax(b) + margin,
                                   pipeline_->params().placement);
  EXPECT_NEAR(fitted.radius, pipe.radius, 0.003);
  EXPECT_GT(std::abs(fitted.direction().dot(pipe.direction())), std::cos(2.0 * 3.14159265 / 180.0));
  EXPECT_LT(distanceToAxis(pipe, fitted.start), 0.01);
  EXPECT_LT(distanceToAxis(pipe, fitted.end), 0.01);
  EXPECT_NEAR(fitted.length(), 0.6 * pipe.length(), 0.1 * pipe.length());
  EXPECT_GE(fitted.inlierCount, pipeline_->params().placement.minInliers);
}

TEST_F(EditReview, FitAroundAPointGrowsAlongThePipe) {
  const Pipe pipe = longestPipe(project_.edits.network());
  // The point a click would pick: on the pipe's surface, nearest its middle.
  const PointCloud& cloud = pipeline_->preprocessResult()->points;
  const Eigen::Vector3d middle = 0.5 * (pipe.start + pipe.end);
  Eigen::Vector3d picked = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  for (const Eigen::Vector3f& position : cloud.positions) {
    const Eigen::Vector3d p = cloud.origin + position.cast<double>();
    if (std::abs(distanceToAxis(pipe, p) - pipe.radius) < 0.003 && (p - middle).norm() < (picked - middle).norm()) picked = p;
  }
  ASSERT_LT((picked - middle).norm(), 0.2);
  const auto command = [](const Eigen::Vector3d& p) {
    return "pipe fit-point " + std::to_string(p.x()) + " " + std::to_string(p.y()) + " " + std::to_string(p.z());
  };
  const CommandOutcome outcome = interpreter_->execute(command(picked));
  const Pipe& fitted = project_.edits.network().pipes.back();
  EXPECT_EQ(outcome.message.rfind("fitted pipe " + std::to_string(fitted.id), 0), 0u) << outcome.message;
  EXPECT_NEAR(fitted.radius, pipe.radius, 0.003);
  EXPECT_GT(fitted.length(), 0.8 * pipe.length());  // one click, the whole pipe
  EXPECT_LT(fitted.length(), pipe.length() + 4.0 * pipe.radius + 0.1);
  EXPECT_LT(distanceToAxis(pipe, 0.5 * (fitted.start + fitted.end)), 0.01);
  // A point off the pipe, or empty space, fits nothing.
  try {
    interpreter_->execute(command(middle));
    FAIL() << "fitted a pipe around its own axis point";
  } catch (const CommandError& error) {
    EXPECT_NE(std::string(error.what()).find("pick a point on the pipe"), std::string::npos) << error.what();
  }
  EXPECT_THROW(interpreter_->execute("pipe fit-box 1000 1000 1000 1001 1001 1001"), CommandError);
}

TEST_F(EditReview, AddedJointIsTypedAsThePipelineTypesIt) {
  const Joint* elbow = firstJoint(project_.edits.network(), JointType::Elbow);
  ASSERT_NE(elbow, nullptr);
  const Joint original = *elbow;
  const std::string pipes = std::to_string(original.pipeIds[0]) + " " + std::to_string(original.pipeIds[1]);
  EXPECT_THROW(interpreter_->execute("joint add " + pipes), CommandError);  // already joined
  interpreter_->execute("joint " + std::to_string(original.id) + " reject");
  const CommandOutcome added = interpreter_->execute("joint add " + pipes);
  const Joint& joint = project_.edits.network().joints.back();
  EXPECT_NE(added.message.find("(elbow)"), std::string::npos) << added.message;
  EXPECT_EQ(joint.type, JointType::Elbow);
  EXPECT_EQ(joint.pipeIds, original.pipeIds);
  EXPECT_EQ(joint.status, JointStatus::Accepted);
  EXPECT_NEAR(joint.bendRadius, original.bendRadius, 0.2 * original.bendRadius);
  EXPECT_LT((joint.position() - original.position()).norm(), 0.02);
  // It joins the two pipes' runs again.
  EXPECT_EQ(project_.edits.network().findPipe(original.pipeIds[0])->runId,
            project_.edits.network().findPipe(original.pipeIds[1])->runId);
}

TEST_F(EditReview, RerunWithTheSameParametersCarriesEveryEditExactly) {
  const PipeNetwork& network = project_.edits.network();
  const Joint* elbow = firstJoint(network, JointType::Elbow);
  const Joint* other = firstJoint(network, JointType::Elbow, {elbow->id});
  ASSERT_TRUE(elbow && other);
  const std::string script[] = {
      "joint " + std::to_string(elbow->id) + " reject",
      "joint " + std::to_string(other->id) + " reject",
      "pipe " + std::to_string(longestPipe(network).id) + " delete",
      "joint add " + std::to_string(elbow->pipeIds[0]) + " " + std::to_string(elbow->pipeIds[1]),
      "pipe " + std::to_string(network.pipes.back().id) + " snap",
  };
  for (const auto& line : script) interpreter_->execute(line);
  const std::string edited = snapshot(project_.edits.network());
  const CommandOutcome outcome = interpreter_->execute("rerun joints");
  EXPECT_TRUE(outcome.dropped.empty()) << outcome.dropped.front().command << ": " << outcome.dropped.front().reason;
  EXPECT_EQ(snapshot(project_.edits.network()), edited);
  EXPECT_EQ(project_.edits.position(), std::size(script));
}

TEST_F(EditReview, RunInHalvesCarriesTheReviewAsRunDoes) {
  // What the studio does with a background run: prepare, run the pipeline, finish.
  const Joint* elbow = firstJoint(project_.edits.network(), JointType::Elbow);
  ASSERT_TRUE(elbow);
  const int elbowId = elbow->id;
  interpreter_->execute("joint " + std::to_string(elbowId) + " reject");
  const std::string edited = snapshot(project_.edits.network());

  EXPECT_FALSE(interpreter_->prepareRun("undo"));
  try {
    interpreter_->prepareRun("rerun placement max_radius=0.001");
    FAIL() << "a radius range below min_radius was taken";
  } catch (const CommandError& error) {
    EXPECT_NE(std::string(error.what()).find("placement.min_radius (0.012) must be below"), std::string::npos)
        << error.what();
  }
  EXPECT_EQ(pipeline_->params().placement.maxRadius, PipelineParams{}.placement.maxRadius);
  const auto placement = interpreter_->prepareRun("rerun placement min_candidates=41");
  ASSERT_TRUE(placement);
  EXPECT_EQ(placement->last, Stage::Placement);
  EXPECT_FALSE(placement->newNetwork);
  pipeline_->run(Progress::none(), placement->last);
  const CommandOutcome partial = interpreter_->finishRun(*placement);
  EXPECT_FALSE(partial.networkChanged);
  EXPECT_FALSE(project_.freshStages[static_cast<std::size_t>(Stage::Extents)]);
  EXPECT_EQ(project_.params.placement.minCandidates, 41);
  EXPECT_EQ(snapshot(project_.edits.network()), edited);  // The review waits for the joints stage.

  const auto rest = interpreter_->prepareRun("run");
  ASSERT_TRUE(rest);
  EXPECT_TRUE(rest->newNetwork);
  pipeline_->run(Progress::none(), rest->last);
  const CommandOutcome carried = interpreter_->finishRun(*rest);
  EXPECT_TRUE(carried.networkChanged);
  EXPECT_TRUE(project_.freshStages[static_cast<std::size_t>(Stage::Joints)]);
  EXPECT_EQ(project_.edits.position() + carried.dropped.size(), 1u);
  EXPECT_THROW(interpreter_->prepareRun("run nowhere"), CommandError);
}

TEST_F(EditReview, RerunTakesTheStagesKeysAndTopLevelOnes) {
  // "up=y" is no joints key: the top-level parameter. An unknown key is named as the stage's.
  const auto joints = interpreter_->prepareRun("rerun joints up=y min_pipe_diameters=2.5");
  ASSERT_TRUE(joints);
  EXPECT_EQ(joints->last, Stage::Joints);
  EXPECT_EQ(pipeline_->params().up, UpAxis::PlusY);
  EXPECT_EQ(pipeline_->params().joints.minPipeDiameters, 2.5);
  try {
    interpreter_->prepareRun("rerun joints upp=y");
    FAIL() << "an unknown key was taken";
  } catch (const CommandError& error) {
    EXPECT_NE(std::string(error.what()).find("unknown parameter 'joints.upp'"), std::string::npos) << error.what();
  }
}

TEST_F(EditReview, ScriptedReviewRerunSaveAndReopen) {
  const PipeNetwork network = project_.edits.network();
  const Joint* first = firstJoint(network, JointType::Elbow);
  ASSERT_NE(first, nullptr);
  const Joint* second = firstJoint(network, JointType::Elbow, {first->id});
  if (!second) second = firstJoint(network, JointType::Tee);
  ASSERT_NE(second, nullptr);
  const Joint* third = nullptr;
  for (const Joint& joint : network.joints) {
    if (joint.id != first->id && joint.id != second->id && (!third || joint.status == JointStatus::Proposed)) third = &joint;
  }
  ASSERT_NE(third, nullptr);
  int deleted = 0;
  for (const Pipe& pipe : network.pipes) {
    const auto joins = [&](const Joint* joint) {
      return std::find(joint->pipeIds.begin(), joint->pipeIds.end(), pipe.id) != joint->pipeIds.end();
    };
    if (!joins(first) && !joins(second) && !joins(third)) deleted = pipe.id;
  }
  ASSERT_GT(deleted, 0);
  const std::filesystem::path saved = dir_ / "review.piperun";
  std::ofstream(dir_ / "review.txt") << "# review of the generated scene\n"
                                     << "joint " << first->id << " reject\n"
                                     << "joint " << second->id << " reject\n"
                                     << "joint " << third->id << " accept\n"
                                     << "pipe " << deleted << " delete\n"
                                     << "joint add " << first->pipeIds[0] << " " << first->pipeIds[1] << "\n"
                                     << "rerun placement center_bandwidth=0.012\n"
                                     << "run\n"
                                     << "save " << saved.string() << "\n";
  const std::vector<CommandOutcome> outcomes = interpreter_->runScript(dir_ / "review.txt");
  ASSERT_EQ(outcomes.size(), 9u);
  EXPECT_NE(outcomes[6].message.find("stale"), std::string::npos) << outcomes[6].message;
  EXPECT_EQ(pipeline_->params().placement.centerBandwidth, 0.012);

  // Every edit is carried or listed with a reason.
  const CommandOutcome& rerun = outcomes[7];
  EXPECT_EQ(project_.edits.position() + rerun.dropped.size(), 5u) << rerun.message;
  for (const DroppedEdit& dropped : rerun.dropped) EXPECT_FALSE(dropped.reason.empty()) << dropped.command;
  for (const EditStep& step : project_.edits.steps()) {
    const PipeNetwork& now = project_.edits.network();
    if (step.edit.kind == EditKind::RejectJoint) {
      EXPECT_EQ(now.findJoint(step.edit.id)->status, JointStatus::Rejected);
    } else if (step.edit.kind == EditKind::AcceptJoint) {
      EXPECT_EQ(now.findJoint(step.edit.id)->status, JointStatus::Accepted);
    } else if (step.edit.kind == EditKind::DeletePipe) {
      EXPECT_EQ(now.findPipe(step.edit.id)->status, PipeStatus::Deleted);
    }
  }
  EXPECT_GE(project_.edits.position(), 3u) << "most of the review should survive a small bandwidth change";
  for (Stage stage : kAllStages) EXPECT_TRUE(project_.freshStages[static_cast<std::size_t>(stage)]);

  const OpenedProject reopened = openProject(saved);
  EXPECT_TRUE(reopened.warnings.empty()) << reopened.warnings.front();
  EXPECT_FALSE(reopened.newerAutosave.has_value());
  EXPECT_EQ(snapshot(reopened.project.edits.network()), snapshot(project_.edits.network()));
  EXPECT_EQ(snapshot(reopened.project.edits.base()), snapshot(project_.edits.base()));
  EXPECT_EQ(paramsToJson(reopened.project.params), paramsToJson(project_.params));
  EXPECT_EQ(reopened.project.freshStages, project_.freshStages);
  EXPECT_EQ(reopened.project.scanHash, project_.scanHash);
  ASSERT_EQ(reopened.project.edits.steps().size(), project_.edits.steps().size());
  // The history reopens too: undoing everything gives the same states in both.
  EditSession original = project_.edits, restored = reopened.project.edits;
  while (original.canUndo()) {
    original.undo();
    restored.undo();
    EXPECT_EQ(snapshot(restored.network()), snapshot(original.network()));
  }
  EXPECT_FALSE(restored.canUndo());
}

}  // namespace
}  // namespace piperun
