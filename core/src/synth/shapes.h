#pragma once
// Analytic surfaces of a synthetic scene, each carrying the truth element id it belongs to.

#include <Eigen/Core>
#include <cstdint>
#include <variant>

namespace piperun::synth {

/// The lateral surface of a finite cylinder around the segment start → start + length · axis.
struct Cylinder {
  Eigen::Vector3d start = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  ///< Unit.
  double length = 0.0;
  double radius = 0.0;
};

/// A section of a ring torus (an elbow): the tube of `radius` around the arc of `bendRadius` about
/// `center` that starts in direction `u` and turns towards `v` by `sweep` radians (u ⟂ v, unit).
struct TorusSection {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  Eigen::Vector3d u = Eigen::Vector3d::UnitX();
  Eigen::Vector3d v = Eigen::Vector3d::UnitY();
  double bendRadius = 0.0;
  double radius = 0.0;
  double sweep = 0.0;
};

/// A solid box whose edges follow the orthonormal columns of `axes`.
struct OrientedBox {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();
  Eigen::Vector3d halfExtents = Eigen::Vector3d::Zero();

  Eigen::Vector3d toLocal(const Eigen::Vector3d& p) const { return axes.transpose() * (p - center); }
  Eigen::Vector3d toWorld(const Eigen::Vector3d& local) const { return center + axes * local; }
};

/// A flat disc: the cap on an open pipe end.
struct Disc {
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< Unit.
  double radius = 0.0;
};

using Shape = std::variant<Cylinder, TorusSection, OrientedBox, Disc>;

/// A scanned surface: a shape, the truth element it lies on (pipe or joint id, 0 for
/// distractors) and how strongly it reflects the laser.
struct Surface {
  Shape shape;
  std::int32_t label = 0;
  float reflectance = 0.5f;
};

}  // namespace piperun::synth
