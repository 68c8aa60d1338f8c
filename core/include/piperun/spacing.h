#pragma once
// Point spacing of a cloud: the typical distance between neighbouring points.

#include "piperun/point_cloud.h"

#include <cstddef>

namespace piperun {

/// Median nearest-neighbour distance (m) over `samples` points spread evenly through the cloud.
/// Memory stays small for any cloud size: only points in the cells around the samples are indexed.
/// Returns 0 for clouds with fewer than two points.
double estimatePointSpacing(const PointCloud& cloud, std::size_t samples = 2000);

}  // namespace piperun
