#pragma once
// Colours shared by the layers: a categorical palette for ids, scalar maps, review statuses.

#include "piperun/pipe_network.h"

#include <vtkSmartPointer.h>

#include <array>
#include <cstdint>
#include <vector>

class vtkLookupTable;

namespace piperun::ui {

using Rgb = std::array<std::uint8_t, 3>;

/// A colour per category (segment, run, element id), distinct for neighbouring indices; -1 and
/// other negative indices get kNeutral.
Rgb categoryColor(int index);

constexpr Rgb kNeutral{150, 150, 150};   ///< Points and pipes with no category.
constexpr Rgb kHighlight{255, 40, 255};  ///< The selected element: magenta, in no colour map.
constexpr Rgb kTileBox{120, 200, 230};   ///< The cube of the tile the Gaussian sphere shows.
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

/// The values a colour bar over [low, high] is labelled at: multiples of a round step (1, 2 or 5
/// times a power of ten), at most `most` of them, the most that fit; the ends themselves when the
/// range is empty or not finite. So a height bar over −0.008–4.0 m reads 0 1 2 3 4, not −0.00821
/// 0.994 1.996 ….
std::vector<double> roundTicks(double low, double high, int most = 5);

}  // namespace piperun::ui
