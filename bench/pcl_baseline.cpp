// The PCL baseline: the pipeline people build from PCL's tutorials to find pipes.
//
//   voxel grid → k-NN normals (OpenMP) → RANSAC planes removed (floors, walls) → Euclidean
//   clusters → per cluster, RANSAC cylinders found one after another, each model's inliers
//   removed before the next search → each cylinder's extent from its inliers' axial span.
//
// Every RANSAC is PCL's own (SACSegmentationFromNormals, seeded with PCL's fixed seed, single
// threaded so the sample sequence is reproducible). Clusters are independent, so they are fitted
// in parallel and their cylinders collected in cluster order: the network does not depend on the
// thread count.
//
// The plane step is not in the minimal recipe, but without it the floor and walls join pipes into
// a few huge clusters and the baseline is less accurate and no faster (--pcl-keep-planes shows
// it). It uses PCL's plain plane model: walls and floors need no normals to be found, and the
// normal-weighted model took about five times as long on the generated scenes.

#include "pcl_baseline.h"

#include <pcl/ModelCoefficients.h>
#include <pcl/PointIndices.h>
#include <pcl/common/common.h>
#include <pcl/console/print.h>
#include <pcl/features/normal_3d_omp.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>
#include <pcl/segmentation/sac_segmentation.h>
#include <tbb/parallel_for.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

namespace piperun::bench {
namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using Normals = pcl::PointCloud<pcl::Normal>;

class Stopwatch {
 public:
  double lap() {
    const auto now = std::chrono::steady_clock::now();
    const double seconds = std::chrono::duration<double>(now - last_).count();
    last_ = now;
    return seconds;
  }

 private:
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

/// `points` minus `removed`; both sorted.
pcl::Indices without(const pcl::Indices& points, pcl::Indices removed) {
  std::sort(removed.begin(), removed.end());
  pcl::Indices remaining;
  remaining.reserve(points.size());
  std::set_difference(points.begin(), points.end(), removed.begin(), removed.end(), std::back_inserter(remaining));
  return remaining;
}

/// One RANSAC model of `type` among `indices` (PCL seeds it with 12345: `random` = false).
/// Returns false when PCL found no model.
bool segmentOne(const Cloud::ConstPtr& cloud, const Normals::ConstPtr& normals, const pcl::Indices& indices,
                int type, double distance, const PclBaselineParams& params, pcl::PointIndices& inliers,
                pcl::ModelCoefficients& coefficients) {
  pcl::SACSegmentationFromNormals<pcl::PointXYZ, pcl::Normal> segmentation(/*random=*/false);
  segmentation.setOptimizeCoefficients(true);
  segmentation.setModelType(type);
  segmentation.setMethodType(pcl::SAC_RANSAC);
  segmentation.setNormalDistanceWeight(params.normalDistanceWeight);
  segmentation.setDistanceThreshold(distance);
  segmentation.setMaxIterations(params.maxIterations);
  if (type == pcl::SACMODEL_CYLINDER) segmentation.setRadiusLimits(params.minRadius, params.maxRadius);
  segmentation.setInputCloud(cloud);
  segmentation.setInputNormals(normals);
  segmentation.setIndices(std::make_shared<const pcl::Indices>(indices));
  segmentation.segment(inliers, coefficients);
  return !inliers.indices.empty() && !coefficients.values.empty();
}

/// The pipe of a cylinder (point on axis, axis direction, radius): the axis segment spanned by
/// the inliers' projections, in world coordinates.
std::optional<Pipe> pipeFromCylinder(const Cloud& cloud, const pcl::Indices& inliers,
                                     const std::vector<float>& coefficients, const Eigen::Vector3d& origin) {
  const Eigen::Vector3d axisPoint(coefficients[0], coefficients[1], coefficients[2]);
  const Eigen::Vector3d axis = Eigen::Vector3d(coefficients[3], coefficients[4], coefficients[5]).normalized();
  const double radius = coefficients[6];
  if (!axis.allFinite() || !std::isfinite(radius) || radius <= 0.0) return std::nullopt;
  double lowest = std::numeric_limits<double>::infinity();
  double highest = -lowest;
  double squaredResiduals = 0.0;
  for (const auto index : inliers) {
    const Eigen::Vector3d offset = cloud[index].getVector3fMap().cast<double>() - axisPoint;
    const double along = offset.dot(axis);
    lowest = std::min(lowest, along);
    highest = std::max(highest, along);
    const double residual = (offset - along * axis).norm() - radius;
    squaredResiduals += residual * residual;
  }
  Pipe pipe;
  pipe.radius = radius;
  pipe.start = origin + axisPoint + lowest * axis;
  pipe.end = origin + axisPoint + highest * axis;
  pipe.fitRms = std::sqrt(squaredResiduals / static_cast<double>(inliers.size()));
  pipe.inlierCount = static_cast<std::int64_t>(inliers.size());
  return pipe;
}

/// Sequential RANSAC on one cluster: find a cylinder, remove its inliers, repeat.
std::vector<Pipe> cylindersOfCluster(const Cloud::ConstPtr& cloud, const Normals::ConstPtr& normals,
                                     pcl::Indices remaining, const PclBaselineParams& params,
                                     const Eigen::Vector3d& origin) {
  std::sort(remaining.begin(), remaining.end());
  std::vector<Pipe> pipes;
  const auto minPoints = static_cast<std::size_t>(params.minCylinderPoints);
  while (remaining.size() >= minPoints) {
    pcl::PointIndices inliers;
    pcl::ModelCoefficients coefficients;
    if (!segmentOne(cloud, normals, remaining, pcl::SACMODEL_CYLINDER, params.cylinderDistance, params, inliers,
                    coefficients) ||
        inliers.indices.size() < minPoints) {
      break;
    }
    if (auto pipe = pipeFromCylinder(*cloud, inliers.indices, coefficients.values, origin)) pipes.push_back(*pipe);
    remaining = without(remaining, std::move(inliers.indices));
  }
  return pipes;
}

/// pcl::VoxelGrid numbers voxels with 32-bit integers over the bounding box and hands the cloud
/// back unfiltered when they would overflow (a "medium" scene already does at 1 cm), so the
/// cloud is filtered in slabs along x cut on voxel boundaries, the usual workaround.
void voxelFilter(const Cloud::ConstPtr& input, float leaf, Cloud& output) {
  Eigen::Vector4f lowest, highest;
  pcl::getMinMax3D(*input, lowest, highest);
  const auto cells = [&](int axis) { return std::floor(highest[axis] / leaf) - std::floor(lowest[axis] / leaf) + 1.0; };
  // Half of PCL's limit leaves room for its own float rounding of the slab bounds.
  const double voxelLimit = 0.5 * static_cast<double>(std::numeric_limits<std::int32_t>::max());
  const auto slabCells = static_cast<std::int64_t>(std::max(1.0, std::floor(voxelLimit / (cells(1) * cells(2)))));
  const double firstCell = std::floor(lowest[0] / leaf);
  std::vector<pcl::Indices> slabs(static_cast<std::size_t>(std::ceil(cells(0) / static_cast<double>(slabCells))));
  for (std::size_t i = 0; i < input->size(); ++i) {
    const auto cell = static_cast<std::int64_t>(std::floor((*input)[i].x / leaf) - firstCell);
    const auto slab = std::clamp<std::int64_t>(cell / slabCells, 0, static_cast<std::int64_t>(slabs.size()) - 1);
    slabs[static_cast<std::size_t>(slab)].push_back(static_cast<pcl::index_t>(i));
  }
  pcl::VoxelGrid<pcl::PointXYZ> voxelGrid;
  voxelGrid.setLeafSize(leaf, leaf, leaf);
  voxelGrid.setInputCloud(input);
  output.clear();
  for (auto& slab : slabs) {
    if (slab.empty()) continue;
    voxelGrid.setIndices(std::make_shared<const pcl::Indices>(std::move(slab)));
    Cloud part;
    voxelGrid.filter(part);
    output += part;
  }
}

}  // namespace

PclBaselineResult runPclBaseline(const PointCloud& input, const PclBaselineParams& params) {
  // RANSAC on a cluster with no cylinder in it is routine here, not worth a console line.
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  PclBaselineResult result;
  auto& diagnostics = result.diagnostics;
  Stopwatch stopwatch;

  auto raw = std::make_shared<Cloud>();
  raw->resize(input.size());
  for (std::size_t i = 0; i < input.size(); ++i) (*raw)[i].getVector3fMap() = input.positions[i];
  diagnostics.convertSeconds = stopwatch.lap();

  auto cloud = std::make_shared<Cloud>();
  if (params.voxelSize > 0.0 && !raw->empty()) {
    voxelFilter(raw, static_cast<float>(params.voxelSize), *cloud);
  } else {
    *cloud = *raw;
  }
  raw.reset();
  diagnostics.afterVoxel = cloud->size();
  diagnostics.voxelSeconds = stopwatch.lap();

  auto normals = std::make_shared<Normals>();
  {
    pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal> estimation(static_cast<unsigned>(params.threads));
    estimation.setSearchMethod(std::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
    estimation.setKSearch(params.normalNeighbors);
    estimation.setInputCloud(cloud);
    estimation.compute(*normals);
  }
  pcl::Indices remaining;
  remaining.reserve(cloud->size());
  for (std::size_t i = 0; i < normals->size(); ++i) {
    if ((*normals)[i].getNormalVector3fMap().allFinite()) remaining.push_back(static_cast<pcl::index_t>(i));
  }
  diagnostics.normalSeconds = stopwatch.lap();

  if (params.removePlanes) {
    const auto minPlanePoints = static_cast<std::size_t>(params.planeMinShare * static_cast<double>(cloud->size()));
    for (int plane = 0; plane < params.maxPlanes && !remaining.empty(); ++plane) {
      pcl::PointIndices inliers;
      pcl::ModelCoefficients coefficients;
      if (!segmentOne(cloud, normals, remaining, pcl::SACMODEL_PLANE, params.planeDistance, params, inliers,
                      coefficients) ||
          inliers.indices.size() < std::max<std::size_t>(minPlanePoints, 1)) {
        break;
      }
      diagnostics.planePoints += inliers.indices.size();
      ++diagnostics.planes;
      remaining = without(remaining, std::move(inliers.indices));
    }
  }
  diagnostics.planeSeconds = stopwatch.lap();

  std::vector<pcl::PointIndices> clusters;
  {
    pcl::EuclideanClusterExtraction<pcl::PointXYZ> extraction;
    extraction.setClusterTolerance(params.clusterTolerance);
    extraction.setMinClusterSize(params.minClusterPoints);
    extraction.setMaxClusterSize(std::numeric_limits<int>::max());
    extraction.setSearchMethod(std::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
    extraction.setInputCloud(cloud);
    extraction.setIndices(std::make_shared<const pcl::Indices>(std::move(remaining)));
    extraction.extract(clusters);
  }
  diagnostics.clusters = static_cast<int>(clusters.size());
  diagnostics.clusterSeconds = stopwatch.lap();

  std::vector<std::vector<Pipe>> pipesOfCluster(clusters.size());
  tbb::parallel_for(std::size_t{0}, clusters.size(), [&](std::size_t c) {
    pipesOfCluster[c] = cylindersOfCluster(cloud, normals, std::move(clusters[c].indices), params, input.origin);
  });
  for (auto& pipes : pipesOfCluster) {
    for (Pipe& pipe : pipes) {
      pipe.id = static_cast<int>(result.network.pipes.size()) + 1;
      result.network.pipes.push_back(pipe);
    }
  }
  diagnostics.cylinders = static_cast<int>(result.network.pipes.size());
  diagnostics.cylinderSeconds = stopwatch.lap();
  return result;
}

}  // namespace piperun::bench
