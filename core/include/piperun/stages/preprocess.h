#pragma once
// Stage 1 — preprocessing: voxel-grid density normalisation, statistical outlier removal,
// normal estimation, removal of large planes, and the split into cubic sub-volumes (tiles).

#include "piperun/point_cloud.h"
#include "piperun/progress.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace piperun {

struct PreprocessParams {
  double voxelSize = 0.01;          ///< Voxel-grid leaf (m): one point (the centroid) per occupied voxel; 0 keeps all.
  bool autoVoxel = true;            ///< Leaf from the scan instead: twice its median point spacing, at least 5 mm and
                                    ///< at most voxelSize (dense close-range scans keep enough points on small pipes).
  int outlierNeighbors = 8;         ///< Statistical outlier removal: a point whose mean distance to its k
  double outlierStdRatio = 3.0;     ///< neighbours exceeds mean + ratio × std of all points goes; ratio 0 disables.
  bool outlierRobust = false;       ///< Median and MAD instead of mean and std: copes with 20 % outliers, but also drops sparse far-range surfaces.
  double sparseSurfaceSpacings = 4; ///< A point those statistics take stays when its mean neighbour distance is within
                                    ///< this many times the median one and at most twice its neighbours' own: a sparse
                                    ///< far surface, not a stray point (0: the statistics alone).
  int normalNeighbors = 16;         ///< k of the k-nearest-neighbour PCA normal estimation (at least 3).
  double keptNeighborsMB = 1000;    ///< The normals' neighbours are kept from the outlier search up to this memory
                                    ///< (MB, 4 bytes a neighbour); beyond it they are searched again: the same normals,
                                    ///< less memory, more time (100 M point scans).
  bool removePlanes = true;         ///< Remove large planar regions (floors, walls, equipment faces).
  double planeCellSize = 0.3;       ///< Planes are detected cell by cell at this edge length (m)...
  double planeMaxThickness = 0.006; ///< ...a cell is planar when the RMS distance to its plane is below this (m)...
  double planeMaxCurvature = 1.0;   ///< ...and bends less than this (1/m), so pipe walls (r < 1 m) are never planes...
  double planeMinArea = 0.6;        ///< ...and connected coplanar cells covering at least this area (m²) are removed.
  double tileSize = 5.0;            ///< Edge of the cubic sub-volumes (m).
  double tileOverlap = 0.5;         ///< Margin each tile reaches into its neighbours (m).
};

/// A cubic sub-volume. `core` tiles the scene without overlap (cubes from the low corner of the kept
/// points' bounding box); `box` is core grown by the overlap.
struct Tile {
  int id = 0;                         ///< Number of the tile among the non-empty ones, in grid order (x slowest, z fastest).
  BoundingBox core;
  BoundingBox box;
  std::vector<std::uint32_t> points;  ///< Indices into PreprocessResult::points of the points inside `box`.
};

struct PreprocessResult {
  PointCloud points;                  ///< Kept points with unit normals (labels unset); normal signs are arbitrary.
  std::vector<float> curvature;       ///< Surface variation λ0 / (λ0 + λ1 + λ2) of each kept point.
  PointCloud planePoints;             ///< Points removed as large planes, for display.
  std::vector<Tile> tiles;            ///< Non-empty tiles, ordered by id.

  struct Diagnostics {
    std::size_t inputPoints = 0;
    double inputSpacing = 0.0;        ///< The scan's median point spacing (m), estimated for the leaf.
    double voxelSize = 0.0;           ///< Leaf used (m), after autoVoxel.
    std::size_t afterVoxel = 0;       ///< Occupied voxels (finite input points when voxelSize is 0).
    std::size_t outliersRemoved = 0;  ///< Statistical outliers, and points left without a normal.
    std::size_t planePoints = 0;
    std::size_t keptPoints = 0;
    int planes = 0;                   ///< Planar regions removed.
    double seconds = 0.0;             ///< Whole stage; the step times follow.
    double voxelSeconds = 0.0;
    int neighborSearches = 0;         ///< 2 when the normals searched their neighbours again (keptNeighborsMB).
    double outlierSeconds = 0.0;      ///< Outlier removal: its neighbour search and the statistics.
    double normalSeconds = 0.0;       ///< Normals: PCA, and their own neighbour search when not kept from the first.
    double planeSeconds = 0.0;
    double tileSeconds = 0.0;
  } diagnostics;
};

/// Pure function of its inputs; deterministic for any thread count.
PreprocessResult preprocess(const PointCloud& input, const PreprocessParams& params,
                            Progress& progress = Progress::none());

/// The same, holding its share of the input only until the voxel grid is made: a caller that hands
/// over its last reference has the scan freed before the rest of the stage (a site scan's points
/// outweigh everything the stage makes from them).
PreprocessResult preprocess(std::shared_ptr<const PointCloud> input, const PreprocessParams& params,
                            Progress& progress = Progress::none());

}  // namespace piperun
