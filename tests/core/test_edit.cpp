// Edits on a hand-made network: operations, runs, undo/redo, the command forms.

#include "piperun/edit/carry_over.h"
#include "piperun/edit/command_interpreter.h"
#include "piperun/edit/edit_session.h"
#include "piperun/edit/review_queue.h"
#include "piperun/edit/runs.h"
#include "piperun/io/network_io.h"
#include "test_util.h"

#include <gtest/gtest.h>

#include <map>
#include <sstream>

namespace piperun {
namespace {

Pipe makePipe(int id, Eigen::Vector3d start, Eigen::Vector3d end, double radius, double confidence = 0.9) {
  Pipe pipe;
  pipe.id = id;
  pipe.start = start;
  pipe.end = end;
  pipe.radius = radius;
  pipe.fitRms = 0.002;
  pipe.inlierCount = 1000;
  pipe.confidence = confidence;
  pipe.status = confidence >= 0.5 ? PipeStatus::Accepted : PipeStatus::Proposed;
  return pipe;
}

Joint makeJoint(int id, JointType type, std::vector<int> pipes, std::vector<Eigen::Vector3d> axis, JointStatus status) {
  Joint joint;
  joint.id = id;
  joint.type = type;
  joint.pipeIds = std::move(pipes);
  joint.radius = 0.05;
  joint.axis = std::move(axis);
  joint.confidence = status == JointStatus::Accepted ? 0.8 : 0.3;
  joint.status = status;
  return joint;
}

// Pipes 1 and 2 collinear along x with a boundary joint (5, accepted); an elbow (6, proposed) up
// into pipe 3; a tee (7, accepted) from pipe 1 to the branch pipe 4 (proposed).
PipeNetwork sampleNetwork() {
  PipeNetwork network;
  network.pipes.push_back(makePipe(1, {0, 0, 0}, {2, 0, 0}, 0.05));
  network.pipes.push_back(makePipe(2, {2.1, 0, 0}, {4, 0, 0}, 0.05));
  network.pipes.push_back(makePipe(3, {4.15, 0, 0.15}, {4.15, 0, 2}, 0.05));
  network.pipes.push_back(makePipe(4, {1, 0.1, 0}, {1, 2, 0}, 0.03, 0.4));
  network.joints.push_back(makeJoint(5, JointType::Boundary, {1, 2}, {{2, 0, 0}, {2.1, 0, 0}}, JointStatus::Accepted));
  network.joints.push_back(
      makeJoint(6, JointType::Elbow, {2, 3}, {{4, 0, 0}, {4.11, 0, 0.04}, {4.15, 0, 0.15}}, JointStatus::Proposed));
  network.joints.push_back(makeJoint(7, JointType::Tee, {1, 4}, {{1, 0, 0}, {1, 0.1, 0}}, JointStatus::Accepted));
  return network;
}

Edit parse(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> words;
  for (std::string word; in >> word;) words.push_back(word);
  return parseEdit(words).value();
}

std::string snapshot(const PipeNetwork& network) { return networkToJson(network); }

EditContext context() {
  static const NominalSizes sizes = NominalSizes::shipped();
  EditContext result;
  result.sizes = &sizes;
  return result;
}

TEST(Runs, ConnectedOverAcceptedJointsOnly) {
  PipeNetwork network = sampleNetwork();
  assignRuns(network);
  ASSERT_EQ(network.runs.size(), 2u);
  EXPECT_EQ(network.runs[0].pipeIds, (std::vector<int>{1, 2, 4}));
  EXPECT_EQ(network.runs[0].jointIds, (std::vector<int>{5, 7}));
  EXPECT_EQ(network.runs[1].pipeIds, (std::vector<int>{3}));
  EXPECT_EQ(network.findPipe(3)->runId, 2);
}

TEST(Runs, TheAcceptedPartLeavesOutWhatIsProposedAndTheJointsOnIt) {
  PipeNetwork network = sampleNetwork();
  network.pipes.push_back(makePipe(8, {0, 1, 0}, {2, 1, 0}, 0.05));
  network.pipes.back().status = PipeStatus::Deleted;
  network.joints.push_back(makeJoint(9, JointType::Tee, {2, 8}, {{3, 0, 0}, {3, 1, 0}}, JointStatus::Accepted));
  assignRuns(network);
  const std::string before = snapshot(network);

  const PipeNetwork accepted = acceptedPart(network);
  EXPECT_EQ(snapshot(network), before);  // the network itself is left as it was
  ASSERT_EQ(accepted.pipes.size(), network.pipes.size());
  ASSERT_EQ(accepted.joints.size(), network.joints.size());
  EXPECT_EQ(accepted.findPipe(1)->status, PipeStatus::Accepted);
  EXPECT_EQ(accepted.findPipe(4)->status, PipeStatus::Deleted);  // proposed
  EXPECT_EQ(accepted.findPipe(8)->status, PipeStatus::Deleted);
  EXPECT_EQ(accepted.findJoint(5)->status, JointStatus::Accepted);
  EXPECT_EQ(accepted.findJoint(6)->status, JointStatus::Rejected);  // proposed
  EXPECT_EQ(accepted.findJoint(7)->status, JointStatus::Rejected);  // accepted, onto the proposed pipe 4
  EXPECT_EQ(accepted.findJoint(9)->status, JointStatus::Rejected);  // accepted, onto the deleted pipe 8
  ASSERT_EQ(accepted.runs.size(), 2u);
  EXPECT_EQ(accepted.runs[0].pipeIds, (std::vector<int>{1, 2}));
  EXPECT_EQ(accepted.runs[0].jointIds, (std::vector<int>{5}));
  EXPECT_EQ(accepted.runs[1].pipeIds, (std::vector<int>{3}));
  EXPECT_EQ(accepted.findPipe(4)->runId, -1);
}

/// The review queue as "joint 9", "pipe 4", ...
std::vector<std::string> queued(const PipeNetwork& network) {
  std::vector<std::string> names;
  for (const ReviewItem& item : reviewQueue(network)) {
    names.push_back((item.kind == ReviewItem::Kind::Joint ? "joint " : "pipe ") + std::to_string(item.id));
  }
  return names;
}

TEST(ReviewQueue, ProposedJointsAndPipesLowestConfidenceFirst) {
  PipeNetwork network = sampleNetwork();
  network.joints.push_back(makeJoint(9, JointType::Tee, {2, 4}, {{2.5, 0, 0}, {2.5, 0.1, 0}}, JointStatus::Proposed));
  network.joints.back().confidence = 0.1;
  // Joints 9 (0.1) and 6 (0.3), then pipe 4 (0.4); a joint goes before a pipe of its confidence.
  EXPECT_EQ(queued(network), (std::vector<std::string>{"joint 9", "joint 6", "pipe 4"}));
  EXPECT_TRUE(reviewsBefore({ReviewItem::Kind::Joint, 20, 0.4}, {ReviewItem::Kind::Pipe, 4, 0.4}));
  EditSession session(network);
  session.apply(parse("joint 9 reject"), context());
  EXPECT_EQ(queued(session.network()), (std::vector<std::string>{"joint 6", "pipe 4"}));
  const ReviewCounts joints = countJointReview(session.network());
  EXPECT_EQ(joints.accepted, 2);
  EXPECT_EQ(joints.rejected, 1);
  EXPECT_EQ(joints.left, 1);
  session.apply(parse("pipe 4 accept"), context());
  EXPECT_EQ(queued(session.network()), (std::vector<std::string>{"joint 6"}));
  session.apply(parse("pipe 3 delete"), context());
  const ReviewCounts pipes = countPipeReview(session.network());
  EXPECT_EQ(pipes.accepted, 3);
  EXPECT_EQ(pipes.rejected, 1);
  EXPECT_EQ(pipes.left, 0);
  EXPECT_THROW(session.apply(parse("pipe 3 accept"), context()), EditError);  // deleted: restore it first
  session.apply(parse("joint 9 propose"), context());  // Back in the queue, in its place.
  EXPECT_EQ(queued(session.network()), (std::vector<std::string>{"joint 9", "joint 6"}));
  session.undo();
  session.undo();
  session.undo();  // "pipe 4 accept" undone: proposed again
  EXPECT_EQ(queued(session.network()), (std::vector<std::string>{"joint 6", "pipe 4"}));
}

TEST(EditSession, RejectedJointsAndDeletedPipesLeaveTheRunsAtOnce) {
  EditSession session(sampleNetwork());
  session.apply(parse("joint 6 accept"), context());
  EXPECT_EQ(session.network().runs.size(), 1u);
  session.apply(parse("joint 5 reject"), context());
  ASSERT_EQ(session.network().runs.size(), 2u);
  EXPECT_EQ(session.network().runs[0].pipeIds, (std::vector<int>{1, 4}));
  EXPECT_EQ(session.network().runs[1].pipeIds, (std::vector<int>{2, 3}));
  session.apply(parse("pipe 1 delete"), context());
  EXPECT_EQ(session.network().findPipe(1)->runId, -1);
  for (const piperun::Run& run : session.network().runs) {
    EXPECT_EQ(std::count(run.jointIds.begin(), run.jointIds.end(), 7), 0) << "a joint of a deleted pipe stays in a run";
  }
  EXPECT_EQ(session.network().runs.size(), 2u);  // {4} alone, {2, 3}
}

TEST(EditSession, RestoreGivesBackTheStatusBeforeDeletion) {
  EditSession session(sampleNetwork());
  session.apply(parse("pipe 4 delete"), context());
  EXPECT_EQ(session.network().findPipe(4)->status, PipeStatus::Deleted);
  session.apply(parse("pipe 4 restore"), context());
  EXPECT_EQ(session.network().findPipe(4)->status, PipeStatus::Proposed);
  EXPECT_THROW(session.apply(parse("pipe 4 restore"), context()), EditError);
  EXPECT_THROW(session.apply(parse("pipe 9 delete"), context()), EditError);
}

TEST(EditSession, MergeJoinsCollinearPipesAndRewiresTheirJoints) {
  EditSession session(sampleNetwork());
  session.apply(parse("pipe 1 merge 2"), context());
  const PipeNetwork& network = session.network();
  EXPECT_EQ(network.findPipe(2), nullptr);
  const Pipe& merged = *network.findPipe(1);
  EXPECT_NEAR((merged.start - Eigen::Vector3d(0, 0, 0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((merged.end - Eigen::Vector3d(4, 0, 0)).norm(), 0.0, 1e-12);
  EXPECT_EQ(merged.inlierCount, 2000);
  EXPECT_EQ(network.findJoint(5), nullptr);  // the gap between them is closed
  EXPECT_EQ(network.findJoint(6)->pipeIds, (std::vector<int>{1, 3}));
  try {
    session.apply(parse("pipe 1 merge 3"), context());
    FAIL() << "merged pipes at right angles";
  } catch (const EditError& error) {
    EXPECT_NE(std::string(error.what()).find("not collinear"), std::string::npos) << error.what();
  }
}

TEST(EditSession, SplitMovesTheJointsBeyondTheCutToTheNewPiece) {
  EditSession session(sampleNetwork());
  session.apply(parse("pipe 1 split 1.5 0.02 0"), context());
  const PipeNetwork& network = session.network();
  const Pipe& near = *network.findPipe(1);
  const Pipe& far = *network.findPipe(8);  // next id after joint 7
  EXPECT_NEAR((near.end - Eigen::Vector3d(1.5, 0, 0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((far.start - Eigen::Vector3d(1.5, 0, 0)).norm(), 0.0, 1e-12);
  EXPECT_EQ(far.end, Eigen::Vector3d(2, 0, 0));
  EXPECT_EQ(near.inlierCount + far.inlierCount, 1000);
  EXPECT_EQ(network.findJoint(7)->pipeIds, (std::vector<int>{1, 4}));  // the tee at x = 1 stays
  EXPECT_EQ(network.findJoint(5)->pipeIds, (std::vector<int>{8, 2}));  // the gap at x = 2 moves
  EXPECT_THROW(session.apply(parse("pipe 1 split 3 0 0"), context()), EditError);
}

TEST(EditSession, RadiusSnapsToTheNearestNominalSizeAndJointsFollow) {
  EditSession session(sampleNetwork());
  session.apply(parse("pipe 1 snap"), context());
  EXPECT_DOUBLE_EQ(session.network().findPipe(1)->radius, 0.1016 / 2);  // NPS 3-1/2
  EXPECT_DOUBLE_EQ(session.network().findJoint(5)->radius, 0.5 * (0.1016 / 2 + 0.05));
  session.apply(parse("pipe 4 radius 0.035"), context());
  EXPECT_DOUBLE_EQ(session.network().findJoint(7)->radius, 0.035);  // a tee takes its branch's radius
  session.apply(parse("pipe 3 move-end end 4.15 0 2.5"), context());
  EXPECT_EQ(session.network().findPipe(3)->end, Eigen::Vector3d(4.15, 0, 2.5));
  EXPECT_THROW(session.apply(parse("pipe 3 move-end end 4.15 0 0.15"), context()), EditError);
}

TEST(EditSession, UndoAndRedoReturnToIdenticalStates) {
  EditSession session(sampleNetwork());
  const char* script[] = {"joint 5 reject", "joint 6 accept", "pipe 4 delete", "pipe 1 split 0.5 0 0",
                          "pipe 3 radius 0.06", "pipe 1 merge 8", "pipe 4 restore", "pipe 2 move-end start 2.05 0 0",
                          "pipe 2 snap"};
  std::vector<std::string> states{snapshot(session.network())};
  for (const char* line : script) {
    session.apply(parse(line), context());
    states.push_back(snapshot(session.network()));
  }
  for (std::size_t k = states.size() - 1; k-- > 0;) {
    session.undo();
    EXPECT_EQ(snapshot(session.network()), states[k]) << "after undoing step " << k + 1;
  }
  EXPECT_FALSE(session.canUndo());
  EXPECT_THROW(session.undo(), EditError);
  for (std::size_t k = 1; k < states.size(); ++k) {
    session.redo();
    EXPECT_EQ(snapshot(session.network()), states[k]) << "after redoing step " << k;
  }
  EXPECT_THROW(session.redo(), EditError);
  // A new edit after undoing drops what could be redone.
  session.undo();
  session.undo();
  session.apply(parse("joint 7 reject"), context());
  EXPECT_FALSE(session.canRedo());
  EXPECT_EQ(session.steps().size(), states.size() - 2);
}

TEST(CarryOver, PipesMatchByAxisOverlapAndRadius) {
  const Pipe pipe = makePipe(1, {0, 0, 0}, {2, 0, 0}, 0.05);
  EXPECT_DOUBLE_EQ(pipeMatchOverlap(pipe, pipe), 2.0);
  EXPECT_DOUBLE_EQ(pipeMatchOverlap(pipe, makePipe(2, {1.9, 0.01, 0}, {0.4, 0.01, 0}, 0.052)), 1.5);  // reversed, shifted 1 cm
  EXPECT_EQ(pipeMatchOverlap(pipe, makePipe(2, {0, 0.08, 0}, {2, 0.08, 0}, 0.05)), 0.0);   // beside it
  EXPECT_EQ(pipeMatchOverlap(pipe, makePipe(2, {0, 0, 0}, {2, 0, 0}, 0.07)), 0.0);         // 40 % thicker
  EXPECT_EQ(pipeMatchOverlap(pipe, makePipe(2, {0, 0, 0}, {2, 0.54, 0}, 0.05)), 0.0);      // 15 degrees off
  EXPECT_EQ(pipeMatchOverlap(pipe, makePipe(2, {1.5, 0, 0}, {3.5, 0, 0}, 0.05)), 0.0);     // overlaps a quarter
}

TEST(CarryOver, MatchingPairsEachPipeWithItsCounterpart) {
  // A thousand pipes in a grid, re-found in another order and shifted by a few millimetres.
  PipeNetwork before, after;
  for (int i = 0; i < 1000; ++i) {
    const Eigen::Vector3d start((i % 40) * 1.0, (i / 40) * 0.3, 0.5 * (i % 3));
    before.pipes.push_back(makePipe(i + 1, start, start + Eigen::Vector3d(0.8, 0, 0), 0.02 + 0.01 * (i % 5)));
  }
  for (int i = 999; i >= 0; --i) {
    Pipe pipe = before.pipes[static_cast<std::size_t>(i)];
    pipe.id = 5000 - i;
    pipe.start += Eigen::Vector3d(0.004, -0.003, 0.002);
    after.pipes.push_back(pipe);
  }
  after.pipes.front().status = PipeStatus::Deleted;  // deleted pipes are no counterparts
  const std::map<int, int> matched = matchPipes(before, after);
  ASSERT_EQ(matched.size(), 999u);
  for (const auto& [from, to] : matched) EXPECT_EQ(to, 5001 - from);
  EXPECT_EQ(matched.count(1000), 0u);
}

// The sample network as a re-run might return it: ids renumbered, pipe 3 not found, the rest
// moved by a few millimetres.
PipeNetwork rerunNetwork() {
  const PipeNetwork old = sampleNetwork();
  const std::map<int, int> newId = {{1, 21}, {2, 22}, {4, 24}};
  PipeNetwork network;
  for (int id : {4, 2, 1}) {
    Pipe pipe = *old.findPipe(id);
    pipe.id = newId.at(id);
    pipe.start += Eigen::Vector3d(0.003, 0.002, 0);
    network.pipes.push_back(pipe);
  }
  for (int id : {7, 5}) {
    Joint joint = *old.findJoint(id);
    joint.id += 30;
    for (int& pipeId : joint.pipeIds) pipeId = newId.at(pipeId);
    joint.status = JointStatus::Accepted;
    network.joints.push_back(joint);
  }
  return network;
}

TEST(CarryOver, DecisionsFollowTheirElementsAndTheRestIsListed) {
  EditSession session(sampleNetwork());
  for (const char* line : {"joint 5 reject", "joint 6 accept", "pipe 4 delete", "pipe 1 split 0.5 0 0", "pipe 8 radius 0.055",
                           "pipe 3 radius 0.06", "joint 7 reject"}) {
    session.apply(parse(line), context());
  }
  session.undo();  // the undone step stays behind
  const CarryOver carried = carryOver(session, rerunNetwork(), context());
  const PipeNetwork& network = carried.session.network();
  EXPECT_EQ(network.findJoint(35)->status, JointStatus::Rejected);  // joint 5 joins pipes 1 and 2 = 21 and 22
  EXPECT_EQ(network.findJoint(37)->status, JointStatus::Accepted);  // "joint 7 reject" was undone
  EXPECT_EQ(network.findPipe(24)->status, PipeStatus::Deleted);
  // The split made pipe 8; its radius edit follows it to the pipe the split makes now.
  const int split = nextElementId(rerunNetwork());
  EXPECT_EQ(network.findPipe(split)->radius, 0.055);
  EXPECT_NEAR((network.findPipe(21)->end - Eigen::Vector3d(0.5, 0, 0)).norm(), 0.0, 0.005);
  // Pipe 3 and the elbow 6 into it are gone: both edits are listed with why.
  ASSERT_EQ(carried.dropped.size(), 2u);
  EXPECT_EQ(carried.dropped[0].command, "joint 6 accept");
  EXPECT_NE(carried.dropped[0].reason.find("pipe 3 has none"), std::string::npos) << carried.dropped[0].reason;
  EXPECT_EQ(carried.dropped[1].command, "pipe 3 radius 0.06");
  EXPECT_EQ(carried.dropped[1].reason, "pipe 3 has no counterpart in the new network");
  EXPECT_EQ(carried.session.position(), 4u);
}

TEST(CarryOver, APipeAcceptedInReviewStaysAccepted) {
  EditSession session(sampleNetwork());
  session.apply(parse("pipe 4 accept"), context());
  const CarryOver carried = carryOver(session, rerunNetwork(), context());
  EXPECT_EQ(rerunNetwork().findPipe(24)->status, PipeStatus::Proposed);
  EXPECT_EQ(carried.session.network().findPipe(24)->status, PipeStatus::Accepted);
  EXPECT_TRUE(carried.dropped.empty());
}

TEST(EditCommands, RoundTripThroughTheirText) {
  for (const char* line : {"joint 12 accept", "joint 12 reject", "joint 12 propose", "joint add 3 4", "pipe 3 accept",
                           "pipe 3 delete", "pipe 3 restore",
                           "pipe 3 merge 4", "pipe 3 split 1.5 -0.25 2.125", "pipe 3 radius 0.0545", "pipe 3 snap",
                           "pipe 3 move-end start 0.1 0.2 0.30000000000000004", "pipe fit-box 0 0 0 1 1 1",
                           "pipe fit-point 1 2 3 0.25"}) {
    EXPECT_EQ(toCommand(parse(line)), line);
  }
  EXPECT_EQ(toCommand(parse("pipe fit-point 1 2 3")), "pipe fit-point 1 2 3 0.25");  // the default reach
}

TEST(EditCommands, MalformedCommandsSayTheExpectedForm) {
  try {
    parseEdit({"pipe", "3", "radius", "-1"});
    FAIL();
  } catch (const EditError& error) {
    EXPECT_EQ(std::string(error.what()), "expected \"pipe ID radius R (metres, positive)\"");
  }
  EXPECT_THROW(parseEdit({"joint", "x", "accept"}), EditError);
  EXPECT_THROW(parseEdit({"pipe", "3", "move-end", "middle", "0", "0", "0"}), EditError);
  EXPECT_FALSE(parseEdit({"view", "all"}).has_value());
}

TEST(CommandInterpreter, ErrorsNameTheScriptLineAndCommand) {
  Project project;
  project.edits = EditSession(sampleNetwork());
  CommandInterpreter interpreter(project, nullptr);
  interpreter.setAutosaveInterval(0);
  const CommandOutcome rejected = interpreter.execute("joint 5 reject  # a comment");
  EXPECT_EQ(rejected.message, "joint 5 rejected");
  EXPECT_TRUE(rejected.networkChanged);
  EXPECT_TRUE(interpreter.execute("   # only a comment").message.empty());
  try {
    interpreter.execute("pipe 99 delete");
    FAIL();
  } catch (const CommandError& error) {
    EXPECT_EQ(std::string(error.what()), "pipe 99 delete: there is no pipe 99");
  }
  test::TempDir dir;
  test::writeFile(dir / "review.txt", "joint 6 accept\nframble 3\n");
  try {
    interpreter.runScript(dir / "review.txt");
    FAIL();
  } catch (const CommandError& error) {
    const std::string message = error.what();
    EXPECT_EQ(message.rfind((dir / "review.txt").string() + ": line 2: framble 3: unknown command", 0), 0u) << message;
  }
  EXPECT_EQ(project.edits.network().findJoint(6)->status, JointStatus::Accepted);
  EXPECT_THROW(interpreter.execute("run"), CommandError);  // no scan open
  interpreter.addCommand("select", [](const std::vector<std::string>& args) { return "selected " + args.at(1); });
  EXPECT_EQ(interpreter.execute("select pipe 3").message, "selected 3");
  EXPECT_EQ(interpreter.execute("undo").message, "undid: joint 6 accept");
}

}  // namespace
}  // namespace piperun
