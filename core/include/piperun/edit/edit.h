#pragma once
// One hand edit or review decision as data: what the studio's keys and buttons and the script
// commands produce, what the undo history and project files store, and what a re-run carries over.

#include "piperun/edit/nominal_sizes.h"
#include "piperun/point_cloud.h"
#include "piperun/stages/joints.h"
#include "piperun/stages/placement.h"

#include <Eigen/Core>

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace piperun {

enum class EditKind {
  AcceptJoint,   ///< joint ID accept
  RejectJoint,   ///< joint ID reject
  ProposeJoint,  ///< joint ID propose (back to the review queue)
  AddJoint,      ///< joint add A B
  DeletePipe,    ///< pipe ID delete
  RestorePipe,   ///< pipe ID restore
  AcceptPipe,    ///< pipe ID accept (a proposed pipe kept)
  MergePipes,    ///< pipe A merge B
  SplitPipe,     ///< pipe ID split X Y Z
  SetRadius,     ///< pipe ID radius R
  SnapRadius,    ///< pipe ID snap
  MoveEnd,       ///< pipe ID move-end start|end X Y Z
  FitInBox,      ///< pipe fit-box X0 Y0 Z0 X1 Y1 Z1
  FitAround,     ///< pipe fit-point X Y Z [REACH]
};

struct Edit {
  EditKind kind = EditKind::AcceptJoint;
  int id = 0;        ///< The joint or pipe edited; merge and add joint: the first pipe.
  int otherId = 0;   ///< Merge: the pipe merged into `id`; add joint: the second pipe.
  int side = 0;      ///< Move end: 0 for the start, 1 for the end.
  double value = 0.0;                                ///< Set radius: the radius; fit around: the reach (m).
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   ///< Split point, new end, box corner, fit centre (world, m).
  Eigen::Vector3d point2 = Eigen::Vector3d::Zero();  ///< Fit in box: the opposite corner.
};

/// Default reach of `pipe fit-point`: points within this distance of the picked point seed the fit (m).
constexpr double kDefaultFitReach = 0.25;

/// An edit that cannot be applied (unknown id, pipes not collinear, no points to fit...). what()
/// is one line saying why; the network is left unchanged.
class EditError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// What edits that look at the points or at the pipeline's rules need.
struct EditContext {
  /// The preprocessed cloud (positions relative to its origin, with normals), as the joints and
  /// placement stages see it; adding a joint and fitting a pipe need it.
  const PointCloud* cloud = nullptr;
  JointsParams joints;        ///< Joint typing for `joint add`, collinearity limits for `merge`.
  PlacementParams placement;  ///< Inlier band and refinement for the fits.
  const NominalSizes* sizes = nullptr;  ///< Table for `snap`.
};

/// The edit as its command line ("pipe 12 split 1.5 0 2.25"); numbers are written so that they
/// read back to the same doubles.
std::string toCommand(const Edit& edit);

/// The edit that the words of a command line name (["pipe", "12", "delete"]); nullopt when the
/// words are no edit command. Throws EditError with the expected form when they are malformed.
std::optional<Edit> parseEdit(const std::vector<std::string>& words);

}  // namespace piperun
