#pragma once
// What a plant engineer reads off a pipe: how it lies against the up axis (level, sloping or
// vertical, and at which heights), and how far it is from another pipe.

#include "piperun/pipe_network.h"
#include "piperun/up_axis.h"

namespace piperun {

/// How a pipe's axis lies against the up axis.
struct PipeLie {
  double slopeDegrees = 0.0;  ///< Angle to the level plane: 0 level, 90 vertical.
  double lowHeight = 0.0;     ///< Height (along the up axis) of the axis's lower end...
  double highHeight = 0.0;    ///< ...and of its higher one.

  /// The rise over the level run in per cent (a 2 % fall is 2), as a drain's slope is given.
  double slopePercent() const;
};

PipeLie pipeLie(const Pipe& pipe, UpAxis up);

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
