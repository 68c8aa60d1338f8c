#pragma once
// The pipe network: straight pipes, joints (elbows, tees, boundary joints) and pipe-runs.

#include <Eigen/Core>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace piperun {

enum class PipeStatus { Accepted, Proposed, Deleted };
enum class JointType { Elbow, Tee, Boundary };
enum class JointStatus { Proposed, Accepted, Rejected };

/// A straight pipe: a cylinder of `radius` around the segment start–end (metres).
struct Pipe {
  int id = 0;
  double radius = 0.0;
  Eigen::Vector3d start = Eigen::Vector3d::Zero();
  Eigen::Vector3d end = Eigen::Vector3d::Zero();
  double fitRms = 0.0;             ///< RMS distance of the inliers to the fitted surface (m).
  std::int64_t inlierCount = 0;    ///< Points that support the pipe.
  double confidence = 1.0;         ///< In [0, 1].
  int runId = -1;                  ///< Run this pipe belongs to; -1 when not in a run.
  PipeStatus status = PipeStatus::Accepted;

  double length() const { return (end - start).norm(); }
  Eigen::Vector3d direction() const;  ///< Unit vector start → end (zero for a degenerate pipe).
};

/// A joint between pipes.
///
/// `axis` is the joint's centre line: for an elbow the arc sampled every centimetre or finer,
/// for a tee the branch segment from the main pipe's axis to the branch pipe's end, for a boundary
/// joint the segment that closes the gap between two collinear pipes.
struct Joint {
  int id = 0;
  JointType type = JointType::Elbow;
  std::vector<int> pipeIds;        ///< Pipes it connects (elbow/boundary: 2; tee: main then branch).
  double radius = 0.0;
  std::vector<Eigen::Vector3d> axis;
  double bendRadius = 0.0;         ///< Elbows: major radius of the torus (centre line radius); else 0.
  double confidence = 1.0;         ///< In [0, 1].
  JointStatus status = JointStatus::Accepted;

  double length() const;           ///< Length of the axis polyline.
  /// A representative point: the arc midpoint for an elbow, the point on the main axis for a tee,
  /// the gap midpoint for a boundary joint. Used to match joints between networks.
  Eigen::Vector3d position() const;
};

/// A pipe-run: a connected set of pipes and joints.
struct Run {
  int id = 0;
  std::vector<int> pipeIds;
  std::vector<int> jointIds;
};

struct PipeNetwork {
  std::vector<Pipe> pipes;
  std::vector<Joint> joints;
  std::vector<Run> runs;

  const Pipe* findPipe(int id) const;
  const Joint* findJoint(int id) const;
  Pipe* findPipe(int id);
  Joint* findJoint(int id);

  /// Throws std::invalid_argument naming the first problem: duplicate ids, a joint or run that
  /// refers to an unknown pipe or joint, a non-positive radius, an axis with fewer than two points.
  void validate() const;
  /// Turns every position (pipe ends, joint axes) about the origin by the rotation `turn`.
  void turn(const Eigen::Matrix3d& turn);
};

std::string toString(PipeStatus status);
std::string toString(JointType type);
std::string toString(JointStatus status);
std::optional<PipeStatus> pipeStatusFromString(const std::string& text);
std::optional<JointType> jointTypeFromString(const std::string& text);
std::optional<JointStatus> jointStatusFromString(const std::string& text);

/// Samples a polyline every `step` metres or closer (both ends included).
std::vector<Eigen::Vector3d> samplePolyline(const std::vector<Eigen::Vector3d>& polyline, double step);

/// The arc of an elbow from `start` to `end` around `center` (same distance from both), sampled
/// with at most `step` metres between points. Used by the generator and by joint reconstruction.
std::vector<Eigen::Vector3d> sampleArc(const Eigen::Vector3d& center, const Eigen::Vector3d& start,
                                       const Eigen::Vector3d& end, double step);

}  // namespace piperun
