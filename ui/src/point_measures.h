#pragma once
// Per-point figures behind the point colour modes: distance to the network's surfaces (QA map,
// element assignment) and the preprocessed point each input point became (segment colours).

#include "piperun/pipe_network.h"
#include "piperun/point_cloud.h"

#include <limits>
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

}  // namespace piperun::ui
