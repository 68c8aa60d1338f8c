#pragma once
// Colours shared by the layers: a categorical palette for ids, scalar maps, review statuses.

#include "piperun/pipe_network.h"

#include <vtkSmartPointer.h>

#include <array>
#include <cstdint>

class vtkLookupTable;

namespace piperun::ui {

using Rgb = std::array<std::uint8_t, 3>;

/// A colour per category (segment, run, element id), distinct for neighbouring indices; -1 and
/// other negative indices get kNeutral.
Rgb categoryColor(int index);

constexpr Rgb kNeutral{150, 150, 150};   ///< Points and pipes with no category.
constexpr Rgb kHighlight{255, 40, 255};  ///< The selected element: magenta, in no colour map.
constexpr Rgb kAccepted{60, 180, 75};
constexpr Rgb kProposed{245, 160, 30};
constexpr Rgb kRejected{220, 40, 40};
/// Deleted pipes, drawn as see-through ghosts.
constexpr Rgb kDeleted{150, 155, 165};

Rgb statusColor(JointStatus status);

/// A perceptually ordered blue→red map over [low, high]; values above `high` map to kNeutral when
/// `neutralAbove` (the QA map: points far from every element are not errors of it).
vtkSmartPointer<vtkLookupTable> scalarMap(double low, double high, bool neutralAbove = false);

/// The colour of `value` in `map`.
Rgb mapColor(vtkLookupTable* map, double value);

}  // namespace piperun::ui
