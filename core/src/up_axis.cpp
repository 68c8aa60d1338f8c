#include "piperun/up_axis.h"

#include <stdexcept>

namespace piperun {

const std::vector<std::string>& upAxisNames() {
  static const std::vector<std::string> names = {"x", "y", "z", "-x", "-y", "-z"};
  return names;
}

std::string toString(UpAxis axis) { return upAxisNames()[static_cast<std::size_t>(axis)]; }

UpAxis upAxisFromString(const std::string& name) {
  const std::string bare = name.size() == 2 && name[0] == '+' ? name.substr(1) : name;
  const auto& names = upAxisNames();
  for (std::size_t k = 0; k < names.size(); ++k) {
    if (names[k] == bare) return static_cast<UpAxis>(k);
  }
  throw std::invalid_argument("unknown up axis '" + name + "', expected x, y, z, -x, -y or -z");
}

int upIndex(UpAxis axis) { return static_cast<int>(axis) % 3; }

double upSign(UpAxis axis) { return static_cast<int>(axis) < 3 ? 1.0 : -1.0; }

Eigen::Vector3d upVector(UpAxis axis) { return upSign(axis) * Eigen::Vector3d::Unit(upIndex(axis)); }

Eigen::Matrix3d turnZUpTo(UpAxis axis) {
  Eigen::Matrix3d turn;
  // Each maps (x, y, z) to the point given, a quarter or half turn about x or y.
  switch (axis) {
    case UpAxis::PlusZ:
      turn << 1, 0, 0, 0, 1, 0, 0, 0, 1;  // (x, y, z)
      break;
    case UpAxis::MinusZ:
      turn << 1, 0, 0, 0, -1, 0, 0, 0, -1;  // (x, -y, -z)
      break;
    case UpAxis::PlusY:
      turn << 1, 0, 0, 0, 0, 1, 0, -1, 0;  // (x, z, -y)
      break;
    case UpAxis::MinusY:
      turn << 1, 0, 0, 0, 0, -1, 0, 1, 0;  // (x, -z, y)
      break;
    case UpAxis::PlusX:
      turn << 0, 0, 1, 0, 1, 0, -1, 0, 0;  // (z, y, -x)
      break;
    case UpAxis::MinusX:
      turn << 0, 0, -1, 0, 1, 0, 1, 0, 0;  // (-z, y, x)
      break;
  }
  return turn;
}

}  // namespace piperun
