#pragma once
// The layout of a synthetic industrial scene: analytic surfaces for the scanner, the truth pipe
// network, the room the scene stands in and the scanner stations.

#include <Eigen/Core>
#include <vector>

#include "piperun/pipe_network.h"
#include "piperun/synth/scene_generator.h"
#include "synth/shapes.h"

namespace piperun::synth {

struct SceneLayout {
  PipeNetwork truth;                      ///< Pipes 1..P, joints P+1..; runs are connected components.
  std::vector<Surface> surfaces;          ///< Labelled with truth ids; 0 for distractors.
  OrientedBox room;                       ///< The scene box (floor to roof height); outliers fall in it.
  /// A concrete roof slab over the room and its walls (a distractor, label 0), scanned only when
  /// SceneParams::roof asks for it.
  Surface roof;
  /// Scanner positions, in free space 1.5–1.8 m above the floor, set up where they see the most
  /// piping (later stations: the most piping the earlier ones do not see).
  std::vector<Eigen::Vector3d> stations;
};

/// Lays out the scene for `params` (preset, seed and station count; the noise settings are the
/// scanner's). The same params give the same layout. Throws std::runtime_error in the unlikely
/// case that no layout meeting the scene requirements is found within a bounded number of tries.
SceneLayout buildSceneLayout(const SceneParams& params);

/// Distinct directions (as lines, within `toleranceRadians`) among the network's pipes.
std::vector<Eigen::Vector3d> distinctPipeDirections(const PipeNetwork& network, double toleranceRadians);

}  // namespace piperun::synth
