#pragma once
// The scan's up direction, one of the six axis directions. PipeRun takes +z unless told otherwise:
// the joints stage finds the ground and the level under sloping pipes along it, and the studio
// stands its camera and measures heights on it.

#include <Eigen/Core>

#include <string>
#include <vector>

namespace piperun {

enum class UpAxis { PlusX, PlusY, PlusZ, MinusX, MinusY, MinusZ };

/// "x", "y", "z", "-x", "-y", "-z", in UpAxis order.
const std::vector<std::string>& upAxisNames();
std::string toString(UpAxis axis);
/// One of upAxisNames(), or "+x", "+y", "+z"; throws std::invalid_argument otherwise.
UpAxis upAxisFromString(const std::string& name);

/// The unit vector along `axis`.
Eigen::Vector3d upVector(UpAxis axis);
/// The coordinate index (0, 1, 2) of `axis`, and its sign (+1 or -1): height = sign * p[index].
int upIndex(UpAxis axis);
double upSign(UpAxis axis);
/// The height of point `p` along `axis`: its coordinate on that axis, negated for -x, -y, -z.
inline double heightAlong(UpAxis axis, const Eigen::Vector3d& p) { return upSign(axis) * p[upIndex(axis)]; }

/// The rotation that turns +z onto `axis` (identity for +z). Its entries are 0 and ±1, so turning
/// a scene and back is exact.
Eigen::Matrix3d turnZUpTo(UpAxis axis);

}  // namespace piperun
