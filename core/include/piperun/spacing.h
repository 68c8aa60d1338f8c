#pragma once
// Point spacing of a cloud: the typical distance between neighbouring points.

#include "piperun/point_cloud.h"

#include <cstddef>
#include <optional>
#include <string>

namespace piperun {

/// Median nearest-neighbour distance (m) over `samples` points spread evenly through the cloud.
/// Memory stays small for any cloud size: only points in the cells around the samples are indexed.
/// Returns 0 for clouds with fewer than two points.
double estimatePointSpacing(const PointCloud& cloud, std::size_t samples = 2000);

/// Median spacings (m) above this find no pipe: a scan read in metres whose points lie this far
/// apart is most likely in another unit (millimetres, inches).
constexpr double kMaxPlausibleSpacing = 0.2;

/// A warning line when `spacing` (m) exceeds kMaxPlausibleSpacing, naming the `--units` option of
/// the tools that read scans; nullopt otherwise.
std::optional<std::string> sparseScanWarning(double spacing);

}  // namespace piperun
