// Edit operations and the undo history.
//
// Every edit runs on a copy of the network; the step keeps only the difference (NetworkDiff), so
// the history costs memory in proportion to what the edits touched, never a copy per step.

#include "piperun/edit/edit_session.h"

#include "piperun/edit/pipe_fit.h"
#include "piperun/edit/runs.h"

#include "angles.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace piperun {

namespace {

constexpr double kMinPipeLength = 0.01;  // shortest pipe a split or a moved end may leave (m)

std::string name(const char* kind, int id) { return std::string(kind) + " " + std::to_string(id); }

Pipe& livePipe(PipeNetwork& network, int id) {
  Pipe* pipe = network.findPipe(id);
  if (!pipe) throw EditError("there is no pipe " + std::to_string(id));
  if (pipe->status == PipeStatus::Deleted) throw EditError(name("pipe", id) + " is deleted (restore it first)");
  return *pipe;
}

Joint& jointById(PipeNetwork& network, int id) {
  Joint* joint = network.findJoint(id);
  if (!joint) throw EditError("there is no joint " + std::to_string(id));
  return *joint;
}

/// A joint's radius follows its pipes as the joints stage sets it: a tee takes its branch's, the
/// others the mean of their two pipes'.
void updateJointRadii(PipeNetwork& network, int pipeId) {
  for (Joint& joint : network.joints) {
    if (std::find(joint.pipeIds.begin(), joint.pipeIds.end(), pipeId) == joint.pipeIds.end()) continue;
    if (joint.type == JointType::Tee && joint.pipeIds.size() == 2) {
      joint.radius = network.findPipe(joint.pipeIds[1])->radius;
    } else if (joint.pipeIds.size() == 2) {
      joint.radius = 0.5 * (network.findPipe(joint.pipeIds[0])->radius + network.findPipe(joint.pipeIds[1])->radius);
    }
  }
}

void setRadius(PipeNetwork& network, int id, double radius) {
  if (!(radius > 0.0) || !std::isfinite(radius)) throw EditError("a radius must be a positive number of metres");
  livePipe(network, id).radius = radius;
  updateJointRadii(network, id);
}

void mergePipes(PipeNetwork& network, int keepId, int otherId, const JointsParams& limits) {
  if (keepId == otherId) throw EditError("a pipe cannot be merged with itself");
  Pipe& keep = livePipe(network, keepId);
  const Pipe other = livePipe(network, otherId);
  const std::string pair = "pipes " + std::to_string(keepId) + " and " + std::to_string(otherId);
  if (keep.length() <= 0.0 || other.length() <= 0.0) throw EditError(pair + ": a pipe has no length");

  // Collinear by the joints stage's boundary-joint limits: angle, centre-line offset, radius ratio.
  const double angle = std::acos(std::min(1.0, std::abs(keep.direction().dot(other.direction())))) / kDegree;
  if (angle > limits.maxBoundaryAngleDeg) {
    throw EditError(pair + " are not collinear: their axes differ by " + std::to_string(angle) + " deg (joints.maxBoundaryAngleDeg is " +
                    std::to_string(limits.maxBoundaryAngleDeg) + ")");
  }
  const double skewLimit = std::max(limits.minSkewDistance, limits.maxSkewRadii * std::min(keep.radius, other.radius));
  const auto offAxis = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector3d q = p - keep.start;
    return (q - q.dot(keep.direction()) * keep.direction()).norm();
  };
  const double skew = std::max(offAxis(other.start), offAxis(other.end));
  if (skew > skewLimit) {
    throw EditError(pair + " are not collinear: their centre lines pass " + std::to_string(skew) + " m apart (limit " +
                    std::to_string(skewLimit) + " m)");
  }
  if (std::min(keep.radius, other.radius) < limits.minRadiusRatio * std::max(keep.radius, other.radius)) {
    throw EditError(pair + " differ in radius beyond joints.minRadiusRatio");
  }

  // The merged axis: the length-weighted principal direction through the length-weighted centre,
  // spanning both pipes' ends; the fit figures are length-weighted too.
  const double a = keep.length(), b = other.length();
  const Eigen::Vector3d da = keep.direction();
  const Eigen::Vector3d db = other.direction().dot(da) >= 0.0 ? other.direction() : Eigen::Vector3d(-other.direction());
  const Eigen::Matrix3d scatter = a * da * da.transpose() + b * db * db.transpose();
  Eigen::Vector3d axis = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter).eigenvectors().col(2);
  if (axis.dot(da) < 0.0) axis = -axis;
  const Eigen::Vector3d center = (a * 0.5 * (keep.start + keep.end) + b * 0.5 * (other.start + other.end)) / (a + b);
  double low = std::numeric_limits<double>::infinity(), high = -low;
  for (const Eigen::Vector3d& p : {keep.start, keep.end, other.start, other.end}) {
    low = std::min(low, (p - center).dot(axis));
    high = std::max(high, (p - center).dot(axis));
  }
  keep.start = center + low * axis;
  keep.end = center + high * axis;
  keep.radius = (a * keep.radius + b * other.radius) / (a + b);
  keep.fitRms = std::sqrt((a * keep.fitRms * keep.fitRms + b * other.fitRms * other.fitRms) / (a + b));
  keep.confidence = (a * keep.confidence + b * other.confidence) / (a + b);
  keep.inlierCount += other.inlierCount;
  if (other.status == PipeStatus::Accepted) keep.status = PipeStatus::Accepted;

  // The joint between the two is inside the merged pipe now; the other pipe's joints move to it.
  const auto joinsBoth = [&](const Joint& joint) {
    const auto has = [&](int id) { return std::find(joint.pipeIds.begin(), joint.pipeIds.end(), id) != joint.pipeIds.end(); };
    return has(keepId) && has(otherId);
  };
  network.joints.erase(std::remove_if(network.joints.begin(), network.joints.end(), joinsBoth), network.joints.end());
  for (Joint& joint : network.joints) std::replace(joint.pipeIds.begin(), joint.pipeIds.end(), otherId, keepId);
  network.pipes.erase(std::find_if(network.pipes.begin(), network.pipes.end(), [&](const Pipe& p) { return p.id == otherId; }));
  updateJointRadii(network, keepId);
}

void splitPipe(PipeNetwork& network, int id, const Eigen::Vector3d& at) {
  const int newId = nextElementId(network);
  Pipe& pipe = livePipe(network, id);
  const double length = pipe.length();
  const double along = (at - pipe.start).dot(pipe.direction());
  if (along < kMinPipeLength || along > length - kMinPipeLength) {
    throw EditError("the split point is not inside " + name("pipe", id) + " (it lies " + std::to_string(along) + " m along a " +
                    std::to_string(length) + " m axis)");
  }
  const Eigen::Vector3d cut = pipe.start + along * pipe.direction();
  Pipe second = pipe;
  second.id = newId;
  second.start = cut;
  second.inlierCount = static_cast<std::int64_t>(std::llround(static_cast<double>(pipe.inlierCount) * (length - along) / length));
  pipe.inlierCount -= second.inlierCount;
  pipe.end = cut;
  const Eigen::Vector3d start = pipe.start, direction = second.direction();
  network.pipes.push_back(second);
  // Joints beyond the cut now belong to the second piece.
  for (Joint& joint : network.joints) {
    if ((joint.position() - start).dot(direction) > along) std::replace(joint.pipeIds.begin(), joint.pipeIds.end(), id, newId);
  }
}

void moveEnd(PipeNetwork& network, int id, int side, const Eigen::Vector3d& to) {
  Pipe& pipe = livePipe(network, id);
  const Eigen::Vector3d& fixed = side == 0 ? pipe.end : pipe.start;
  if ((to - fixed).norm() < kMinPipeLength) throw EditError("the moved end would leave " + name("pipe", id) + " without length");
  (side == 0 ? pipe.start : pipe.end) = to;
}

void addJoint(PipeNetwork& network, int firstId, int secondId, const EditContext& context) {
  if (firstId == secondId) throw EditError("a joint needs two different pipes");
  const Pipe& first = livePipe(network, firstId);
  const Pipe& second = livePipe(network, secondId);
  for (const Joint& joint : network.joints) {
    const auto has = [&](int id) { return std::find(joint.pipeIds.begin(), joint.pipeIds.end(), id) != joint.pipeIds.end(); };
    if (joint.status != JointStatus::Rejected && has(firstId) && has(secondId)) {
      throw EditError("pipes " + std::to_string(firstId) + " and " + std::to_string(secondId) + " are already joined by " +
                      name("joint", joint.id));
    }
  }
  if (!context.cloud) throw EditError("adding a joint needs the scan's points (open the project with its scan)");
  const PointCloud& cloud = *context.cloud;
  // The joints stage on these two pipes alone types and reconstructs the joint as the pipeline would.
  std::vector<PipeSegment> segments(2);
  for (std::size_t k = 0; k < 2; ++k) {
    const Pipe& pipe = k == 0 ? first : second;
    segments[k].start = pipe.start - cloud.origin;
    segments[k].end = pipe.end - cloud.origin;
    segments[k].radius = pipe.radius;
    segments[k].rms = pipe.fitRms;
    segments[k].confidence = pipe.confidence;
  }
  JointsParams twoPipes = context.joints;
  twoPipes.maxCompletionLength = 0.0;  // Only these two pipes: nothing is completed beyond their ends.
  const JointsResult joined = connectPipes({cloud, segments}, twoPipes);
  if (joined.joints.empty() || joined.pipes.size() != 2) {
    throw EditError("no elbow, tee or boundary joint fits pipes " + std::to_string(firstId) + " and " + std::to_string(secondId) +
                    " (their ends are too far apart, or their axes do not meet within the joints limits)");
  }
  Joint joint = joined.joints.front();
  const int ids[2] = {firstId, secondId};
  for (int& id : joint.pipeIds) id = ids[id - 1];
  for (Eigen::Vector3d& p : joint.axis) p += cloud.origin;
  joint.id = nextElementId(network);
  joint.status = JointStatus::Accepted;
  if (joint.type == JointType::Elbow) {
    // The elbow trims or extends its pipes to its tangent points.
    for (std::size_t k = 0; k < 2; ++k) {
      Pipe& pipe = *network.findPipe(ids[k]);
      pipe.start = joined.pipes[k].start + cloud.origin;
      pipe.end = joined.pipes[k].end + cloud.origin;
    }
  }
  network.joints.push_back(std::move(joint));
}

void addFittedPipe(PipeNetwork& network, Pipe pipe) {
  pipe.id = nextElementId(network);
  network.pipes.push_back(pipe);
}

const PointCloud& cloudFor(const EditContext& context) {
  if (!context.cloud) throw EditError("fitting a pipe needs the scan's points (open the project with its scan)");
  return *context.cloud;
}

}  // namespace

int nextElementId(const PipeNetwork& network) {
  int next = 1;
  for (const Pipe& pipe : network.pipes) next = std::max(next, pipe.id + 1);
  for (const Joint& joint : network.joints) next = std::max(next, joint.id + 1);
  return next;
}

void applyEdit(PipeNetwork& network, const Edit& edit, const EditContext& context, PipeStatus restoredStatus) {
  switch (edit.kind) {
    case EditKind::AcceptJoint: jointById(network, edit.id).status = JointStatus::Accepted; return;
    case EditKind::RejectJoint: jointById(network, edit.id).status = JointStatus::Rejected; return;
    case EditKind::ProposeJoint: jointById(network, edit.id).status = JointStatus::Proposed; return;
    case EditKind::AddJoint: addJoint(network, edit.id, edit.otherId, context); return;
    case EditKind::DeletePipe: livePipe(network, edit.id).status = PipeStatus::Deleted; return;
    case EditKind::AcceptPipe: livePipe(network, edit.id).status = PipeStatus::Accepted; return;
    case EditKind::RestorePipe: {
      Pipe* pipe = network.findPipe(edit.id);
      if (!pipe) throw EditError("there is no pipe " + std::to_string(edit.id));
      if (pipe->status != PipeStatus::Deleted) throw EditError(name("pipe", edit.id) + " is not deleted");
      pipe->status = restoredStatus;
      return;
    }
    case EditKind::MergePipes: mergePipes(network, edit.id, edit.otherId, context.joints); return;
    case EditKind::SplitPipe: splitPipe(network, edit.id, edit.point); return;
    case EditKind::SetRadius: setRadius(network, edit.id, edit.value); return;
    case EditKind::SnapRadius: {
      if (!context.sizes) throw EditError("snapping needs the nominal size table");
      setRadius(network, edit.id, context.sizes->nearest(livePipe(network, edit.id).radius).radius());
      return;
    }
    case EditKind::MoveEnd: moveEnd(network, edit.id, edit.side, edit.point); return;
    case EditKind::FitInBox:
      addFittedPipe(network, fitPipeInBox(cloudFor(context), edit.point, edit.point2, context.placement));
      return;
    case EditKind::FitAround:
      addFittedPipe(network, fitPipeAround(cloudFor(context), edit.point, edit.value, context.placement));
      return;
  }
}

EditSession::EditSession(PipeNetwork base) : base_(std::move(base)) {
  assignRuns(base_);
  network_ = base_;
}

EditSession::EditSession(PipeNetwork base, std::vector<EditStep> steps, std::size_t position)
    : EditSession(std::move(base)) {
  if (position > steps.size()) throw std::invalid_argument("history position beyond its steps");
  steps_ = std::move(steps);
  for (position_ = 0; position_ < position; ++position_) applyDiff(network_, steps_[position_].diff);
  assignRuns(network_);
}

PipeStatus EditSession::statusBeforeDeletion(const Pipe& pipe) const {
  for (std::size_t k = position_; k-- > 0;) {
    for (const auto& change : steps_[k].diff.pipes.changed) {
      if (change.after.id == pipe.id && change.after.status == PipeStatus::Deleted && change.before.status != PipeStatus::Deleted) {
        return change.before.status;
      }
    }
  }
  // Deleted before the session began: the pipeline's rule.
  return pipe.confidence >= 0.5 ? PipeStatus::Accepted : PipeStatus::Proposed;
}

const EditStep& EditSession::apply(const Edit& edit, const EditContext& context) {
  PipeNetwork edited = network_;
  PipeStatus restored = PipeStatus::Accepted;
  if (edit.kind == EditKind::RestorePipe) {
    if (const Pipe* pipe = network_.findPipe(edit.id)) restored = statusBeforeDeletion(*pipe);
  }
  applyEdit(edited, edit, context, restored);
  assignRuns(edited);
  steps_.resize(position_);
  steps_.push_back({edit, diffNetworks(network_, edited)});
  network_ = std::move(edited);
  ++position_;
  return steps_.back();
}

const EditStep& EditSession::undo() {
  if (!canUndo()) throw EditError("nothing to undo");
  const EditStep& step = steps_[--position_];
  revertDiff(network_, step.diff);
  assignRuns(network_);
  return step;
}

const EditStep& EditSession::redo() {
  if (!canRedo()) throw EditError("nothing to redo");
  const EditStep& step = steps_[position_++];
  applyDiff(network_, step.diff);
  assignRuns(network_);
  return step;
}

}  // namespace piperun
