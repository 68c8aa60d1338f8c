#pragma once
// Synthetic industrial scenes with ground truth: pipe-runs scanned by simulated terrestrial scanners.

#include "piperun/pipe_network.h"
#include "piperun/point_cloud.h"
#include "piperun/progress.h"
#include "piperun/up_axis.h"

#include <cstdint>
#include <functional>
#include <string>

namespace piperun {

enum class ScenePreset {
  Small,   ///< ~300k points, ~6 x 6 x 4 m.
  Medium,  ///< ~2M points.
  Large,   ///< ~20M points, generated in bounded memory.
};

struct SceneParams {
  ScenePreset preset = ScenePreset::Small;
  std::uint64_t seed = 1;
  double noiseSigma = 0.002;       ///< Gaussian noise along the surface normal (m).
  double outlierFraction = 0.01;   ///< Uniform outliers in the scene box, per surface point (expected count).
  int stations = 0;                ///< Scanner stations (1-3); 0 lets the seed choose.
  double densityScale = 1.0;       ///< Multiplies the preset's angular sampling density (points ~ scale).
  /// Misregistration of the stations (m): every station after the first is shifted by this much
  /// in a random direction and turned by this much per 10 m about a random axis through it, as a
  /// registered multi-station scan that is a few millimetres off. The truth stays in the first
  /// station's frame.
  double registrationError = 0.0;
  /// Share of the rays next to a depth edge (a silhouette) that return a range between the near
  /// and the far surface, as a laser beam straddling the edge does (mixed pixels, 0–1).
  double mixedPixelShare = 0.0;
  /// The scene's up direction: the z-up scene is turned so that this axis is up, points and truth
  /// alike, as a scan written by a tool that puts y up.
  UpAxis up = UpAxis::PlusZ;
  /// Close the room with a concrete roof slab at its height (a pump house, a building). The
  /// scanner's sampling is set without it, so the pipes get the points they get without a roof.
  bool roof = false;
};

struct SceneSummary {
  std::uint64_t points = 0;
  std::uint64_t outliers = 0;
  std::uint64_t mixedPixels = 0;
  int stations = 0;
  int pipes = 0;
  int elbows = 0;
  int tees = 0;
  int runs = 0;
  int directions = 0;              ///< Distinct pipe directions (principal directions) in the scene.
  BoundingBox bounds;
};

/// Receives the scene's points chunk by chunk (world coordinates, labels = truth element id:
/// the id of the pipe or joint the point lies on, 0 for distractors, -1 for outliers).
using PointChunkSink = std::function<void(const PointChunk& chunk)>;

/// Generates a scene: fills `truth` (ids unique across pipes and joints) and streams the points
/// to `sink` in chunks, in a fixed order, so the same params give the same points whatever the
/// thread count. Memory stays bounded for every preset.
SceneSummary generateScene(const SceneParams& params, PipeNetwork& truth, const PointChunkSink& sink,
                           Progress& progress = Progress::none());

/// The same, collected in memory (for tests and small scenes).
struct GeneratedScene {
  PointCloud cloud;
  PipeNetwork truth;
  SceneSummary summary;
};
GeneratedScene generateScene(const SceneParams& params, Progress& progress = Progress::none());

std::string toString(ScenePreset preset);
/// Parses "small", "medium" or "large"; throws std::invalid_argument otherwise.
ScenePreset scenePresetFromString(const std::string& name);

}  // namespace piperun
