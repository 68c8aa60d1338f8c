#pragma once
// The anchor the benchmark compares PipeRun against: the usual PCL recipe for pipes, i.e. voxel
// grid, normals, plane removal, Euclidean clusters, then sequential RANSAC cylinders per cluster.
// PCL stays inside pcl_baseline.cpp, as in core.

#include "piperun/pipe_network.h"
#include "piperun/point_cloud.h"

#include <cstddef>

namespace piperun::bench {

struct PclBaselineParams {
  double voxelSize = 0.01;              ///< pcl::VoxelGrid leaf (m), as PipeRun's preprocess default.
  int normalNeighbors = 16;             ///< k of pcl::NormalEstimationOMP.
  bool removePlanes = true;             ///< Remove floors and walls by RANSAC planes before clustering, as PCL's cylinder tutorial does.
  double planeDistance = 0.015;         ///< Inlier distance of a plane (m)...
  double planeMinShare = 0.05;          ///< ...which is removed while it holds at least this share of the voxelised points...
  int maxPlanes = 10;                   ///< ...up to this many planes.
  double clusterTolerance = 0.025;      ///< pcl::EuclideanClusterExtraction distance (m).
  int minClusterPoints = 100;           ///< Smaller clusters are dropped.
  double normalDistanceWeight = 0.1;    ///< Weight of the normal angle in SACSegmentationFromNormals' distance.
  double cylinderDistance = 0.01;       ///< RANSAC inlier distance of a cylinder (m).
  double minRadius = 0.012;             ///< Radius limits of a cylinder (m).
  double maxRadius = 0.35;
  int maxIterations = 1000;             ///< RANSAC iterations per model (PCL stops earlier once confident).
  int minCylinderPoints = 100;          ///< A cluster is searched until fewer points remain or a model has fewer inliers.
  int threads = 0;                      ///< Normal estimation threads; 0 uses every core.
};

struct PclBaselineResult {
  PipeNetwork network;                  ///< One accepted pipe per cylinder, ids from 1, world coordinates.

  struct Diagnostics {
    std::size_t afterVoxel = 0;
    std::size_t planePoints = 0;
    int planes = 0;
    int clusters = 0;
    int cylinders = 0;
    double convertSeconds = 0.0;        ///< Copying the cloud into a pcl::PointCloud.
    double voxelSeconds = 0.0;
    double normalSeconds = 0.0;
    double planeSeconds = 0.0;
    double clusterSeconds = 0.0;
    double cylinderSeconds = 0.0;
  } diagnostics;
};

/// Deterministic: PCL's RANSAC is seeded with its fixed seed, clusters are fitted in parallel (TBB,
/// limited by the caller's tbb::global_control) and their cylinders are collected in cluster order.
PclBaselineResult runPclBaseline(const PointCloud& cloud, const PclBaselineParams& params = {});

}  // namespace piperun::bench
