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

/// Median spacings (m) above this show no pipe but the widest: a scan read in metres whose points
/// lie this far apart is most likely in another unit. A terrestrial scan's 2–10 mm read as metres
/// from millimetres, centimetres or most inch files are over it; from feet they are not.
constexpr double kMaxPlausibleSpacing = 0.1;

/// A warning line when `spacing` (m) exceeds kMaxPlausibleSpacing, naming the `--units` option of
/// the tools that read scans; nullopt otherwise.
std::optional<std::string> sparseScanWarning(double spacing);

}  // namespace piperun
