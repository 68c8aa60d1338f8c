#pragma once
// π and degree conversion, shared by the stages, the editors, the exporters and the scene generator.

namespace piperun {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kDegree = kPi / 180.0;

/// Degrees to radians.
inline double radians(double degrees) { return degrees * kPi / 180.0; }
/// Radians to degrees.
inline double degrees(double radians) { return radians * 180.0 / kPi; }

}  // namespace piperun
