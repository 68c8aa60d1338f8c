#include "piperun/up_axis.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <stdexcept>

namespace piperun {
namespace {

TEST(UpAxis, NamesReadBackAndAPlusSignIsAllowed) {
  for (const std::string& name : upAxisNames()) EXPECT_EQ(toString(upAxisFromString(name)), name);
  EXPECT_EQ(upAxisFromString("+y"), UpAxis::PlusY);
  EXPECT_EQ(upAxisFromString("-z"), UpAxis::MinusZ);
  for (const char* wrong : {"", "Y", "+-y", "--y", "w", "+"}) EXPECT_THROW(upAxisFromString(wrong), std::invalid_argument) << wrong;
}

TEST(UpAxis, EachTurnIsARotationTakingZOntoItsAxis) {
  for (const std::string& name : upAxisNames()) {
    const UpAxis axis = upAxisFromString(name);
    const Eigen::Matrix3d turn = turnZUpTo(axis);
    EXPECT_EQ(turn * Eigen::Vector3d::UnitZ(), upVector(axis)) << name;
    EXPECT_EQ(turn.transpose() * turn, Eigen::Matrix3d::Identity()) << name;
    EXPECT_EQ(turn.determinant(), 1.0) << name;  // A turn, not a mirror: the scene keeps its handedness.
    EXPECT_EQ(upSign(axis) * upVector(axis)[upIndex(axis)], 1.0) << name;
  }
  EXPECT_EQ(turnZUpTo(UpAxis::PlusZ), Eigen::Matrix3d::Identity());
  EXPECT_EQ(upVector(UpAxis::MinusX), -Eigen::Vector3d::UnitX());
}

}  // namespace
}  // namespace piperun
