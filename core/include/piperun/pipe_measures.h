#pragma once
// What a plant engineer reads off a network: how a pipe lies against the up axis (level, sloping
// or vertical, and at which heights), how high and low a tube reaches, the angle an elbow turns and
// the fitting that names, and how far two pipes are from each other.

#include "piperun/pipe_network.h"
#include "piperun/up_axis.h"

#include <Eigen/Core>

#include <optional>
#include <vector>

namespace piperun {

/// How a pipe's axis lies against the up axis.
struct PipeLie {
  double slopeDegrees = 0.0;  ///< Angle to the level plane: 0 level, 90 vertical.
  double lowHeight = 0.0;     ///< Height (along the up axis) of the axis's lower end...
  double highHeight = 0.0;    ///< ...and of its higher one.

  /// The rise over the level run in per cent (a 2 % fall is 2), as a drain's slope is given.
  double slopePercent() const;
};

PipeLie pipeLie(const Eigen::Vector3d& start, const Eigen::Vector3d& end, UpAxis up);
PipeLie pipeLie(const Pipe& pipe, UpAxis up);

/// The lowest and highest heights (along the up axis) that the tube of `radius` around the centre
/// line `axis` reaches: a level pipe's bottom and top of pipe, a riser's end faces.
struct TubeHeights {
  double lowest = 0.0;
  double highest = 0.0;
};

/// Over each segment of `axis` (at least one point): its ends' heights, less and plus how far its
/// end circles reach along the up axis (the radius for a level segment, nothing for a plumb one).
TubeHeights tubeHeights(const std::vector<Eigen::Vector3d>& axis, double radius, UpAxis up);

/// The circle an elbow's centre line follows, through its first, middle and last points.
struct Bend {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  ///< Unit normal; the arc turns about it (right hand).
  double radius = 0.0;                              ///< The bend radius.
  double angle = 0.0;                               ///< Radians, in (0, 2π).

  double angleDegrees() const;
};

/// nullopt when those three points are collinear (a straight "arc").
std::optional<Bend> bendOf(const std::vector<Eigen::Vector3d>& arc);

/// Standard elbow fittings by the angle they turn: 90° and 45°, each within 7.5° (halfway to a 60°
/// fitting), else other (a fit between them, a 180° return).
enum class ElbowAngle { Ninety, FortyFive, Other };
ElbowAngle elbowAngleOf(double degrees);

/// Where two pipes are to each other.
struct PipesApart {
  double axisDistance = 0.0;  ///< Nearest distance between the two axis segments.
  /// Between their surfaces where the axes are nearest: axisDistance less both radii (negative
  /// where the tubes overlap). Exact for pipes passing each other; past an end, the caps'
  /// rounded edges make the true gap a little wider.
  double clearance = 0.0;
  double angleDegrees = 0.0;  ///< Between the axes' lines, 0 to 90.
};

PipesApart pipesApart(const Pipe& a, const Pipe& b);

}  // namespace piperun
