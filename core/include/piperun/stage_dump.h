#pragma once
// Writes every stage's output as files a user can open in any point-cloud viewer.

#include "piperun/pipeline.h"

#include <filesystem>

namespace piperun {

/// Writes into `directory` (created if needed), all PLY in world coordinates:
///   preprocessed.ply          kept points with normals
///   planes.ply                points removed as planes
///   tile_<id>/round_<r>/directions.ply      the round's points, label = direction index (-1 none)
///   tile_<id>/round_<r>/sphere_samples.ply  direction samples on the unit sphere, label = direction
///   tile_<id>/round_<r>/candidates_<k>.ply  direction k's circle candidates as (cx, cy, r), label = circle
///   tile_<id>/round_<r>/cylinders.ply       cylinder inliers, label = cylinder index
///   pipes.ply                 merged pipes' inliers, label = pipe id in network()
/// Stages that have not run are skipped. Returns the number of files written.
int dumpStages(const Pipeline& pipeline, const std::filesystem::path& directory);

}  // namespace piperun
