#pragma once
// Per-point figures behind the point colour modes: distance to the network's surfaces (QA map,
// element assignment), the preprocessed point each input point became (segment colours), and the
// height a ceiling over the network starts at (the first view's clip).

#include "piperun/pipe_network.h"
#include "piperun/point_cloud.h"
#include "piperun/up_axis.h"

#include <limits>
#include <optional>
#include <vector>

namespace piperun::ui {

struct SurfaceDistances {
  std::vector<float> distance;  ///< |distance to the nearest pipe or joint surface| (m); +inf beyond the reach.
  std::vector<int> element;     ///< Id of that pipe or joint, -1 beyond the reach.
};

/// For every point, the nearest surface among the network's pipes and joints within `reach` metres.
/// Parallel; the result does not depend on the thread count.
SurfaceDistances surfaceDistances(const PointCloud& cloud, const PipeNetwork& network, double reach);

/// For every point of `input`, the index of the nearest point of `preprocessed` within `reach`
/// metres, -1 when none (the point was merged away as an outlier or a plane, or is far from any kept point).
std::vector<int> nearestKeptPoint(const PointCloud& input, const PointCloud& preprocessed, double reach);

/// The stray points of a scan: those with fewer than `minNeighbours` other points in the 3 x 3 x 3
/// block of cubic cells of edge `cell` (m) around their own cell, and the non-finite ones: the
/// outliers a scanner scatters through the air (mixed pixels, dust, reflections).
std::vector<bool> strayPoints(const PointCloud& cloud, double cell, int minNeighbours);

/// Points this far above the network's top still show (m): what sits on the highest pipes.
inline constexpr double kCeilingMargin = 0.25;

/// Share of a footprint cell's points above the network's top that makes the cell covered.
inline constexpr double kCeilingShare = 0.05;

/// The height (along `up`, m) above which the points hide the network from above, as a building's
/// roof or a deck over the piping does: the network's top (its highest surface) plus
/// kCeilingMargin, when at least half of the scan's footprint is covered above that height (square
/// cells of a 64th of its larger horizontal extent, at least 0.25 m, in which kCeilingShare of the
/// points lie above it; outliers scattered through the volume do not). nullopt when the network is
/// empty or nothing above it covers the scan.
std::optional<double> ceilingHeight(const PointCloud& cloud, const PipeNetwork& network, UpAxis up);

}  // namespace piperun::ui
