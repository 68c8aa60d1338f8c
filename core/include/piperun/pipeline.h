#pragma once
// The reconstruction pipeline: holds each stage's latest result, re-runs stages with new
// parameters (marking later ones stale), reports progress and can be cancelled from another thread.

#include "piperun/pipe_network.h"
#include "piperun/point_cloud.h"
#include "piperun/progress.h"
#include "piperun/stages/directions.h"
#include "piperun/stages/extents.h"
#include "piperun/stages/joints.h"
#include "piperun/stages/merge.h"
#include "piperun/stages/placement.h"
#include "piperun/stages/preprocess.h"
#include "piperun/up_axis.h"

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace piperun {

enum class Stage { Preprocess, Directions, Placement, Extents, Merge, Joints };
constexpr int kStageCount = 6;
constexpr std::array<Stage, kStageCount> kAllStages = {Stage::Preprocess, Stage::Directions, Stage::Placement,
                                                      Stage::Extents,    Stage::Merge,      Stage::Joints};

/// "preprocess", "directions", "placement", "extents", "merge", "joints".
const char* stageName(Stage stage);
std::optional<Stage> stageFromName(const std::string& name);

struct PipelineParams {
  std::uint64_t seed = 1;  ///< Seed of every random choice; the same seed gives the same network.
  int rounds = 2;          ///< Rounds of directions → placement → extents per tile on points not yet explained.
  UpAxis up = UpAxis::PlusZ;  ///< The scan's up direction (the joints stage's ground and level).
  PreprocessParams preprocess;
  DirectionsParams directions;
  PlacementParams placement;
  ExtentsParams extents;
  MergeParams merge;
  JointsParams joints;
};

/// One round of the per-tile stages. Like every stage output, coordinates are in the preprocessed
/// cloud's local frame (PointCloud::positions, relative to its origin); Pipeline::network() adds
/// the origin back.
struct TileRound {
  std::vector<std::uint32_t> points;  ///< The points this round analysed (the tile's unexplained points).
  DirectionsResult directions;
  PlacementResult placement;
  ExtentsResult extents;
};

struct TileReconstruction {
  int tileId = 0;
  std::vector<TileRound> rounds;
};

/// What tile rounds may drop as they finish (Pipeline::releaseTileDetails).
enum class TileDetails {
  ViewSamples,  ///< The sphere samples and circle candidates, which only views draw (withViewSamples makes them again).
  All,          ///< Those, and the analysed points, stripes and cylinder inliers, which re-runs of single stages read.
};

struct StageTiming {
  double seconds = 0.0;
};

class Pipeline {
 public:
  explicit Pipeline(std::shared_ptr<const PointCloud> input, PipelineParams params = {});

  const PipelineParams& params() const { return params_; }
  /// Replaces the parameters: the earliest stage whose parameters changed, and every later stage,
  /// become stale. (The seed and round count affect the tile stages.)
  void setParams(const PipelineParams& params);
  /// Marks `stage` and every later stage stale.
  void invalidate(Stage stage);
  bool isFresh(Stage stage) const { return fresh_[static_cast<int>(stage)]; }

  /// Runs the stale stages up to and including `last`, in order. Tiles run in parallel; the result
  /// does not depend on the thread count. progress.cancel() from another thread stops at the next
  /// safe point and throws Cancelled; results of the stages that had finished are kept, the rest
  /// stay stale.
  void run(Progress& progress = Progress::none(), Stage last = Stage::Joints);

  /// The input cloud; null once released.
  std::shared_ptr<const PointCloud> input() const { return input_; }
  /// Lets go of the input cloud, for a batch run that needs it no more (no stage after the
  /// preprocessing reads it; a site scan's points outweigh every later result): at once when the
  /// preprocessing is fresh, otherwise as soon as its next run has made the voxel grid. The
  /// preprocessing cannot run again: run() then throws std::logic_error where it would.
  void releaseInput();
  /// Lets each tile round drop, as it finishes, what only a viewer and the stage dump read, the
  /// sphere samples and circle candidates (most of a site scan's per-tile results), and with
  /// TileDetails::All also what only a re-run of a single per-tile stage reads: the points it
  /// analysed, the directions' stripes and the cylinders' inliers. The directions, cylinders and
  /// pipe pieces stay, so the network is the same. From the next run on; after TileDetails::All a
  /// later re-run of the per-tile stages starts from the directions.
  void releaseTileDetails(TileDetails details = TileDetails::All) { releasedDetails_ = details; }
  /// Latest results (null before the stage first ran). A stale stage keeps its previous result
  /// until it runs again, so a viewer can go on showing it.
  std::shared_ptr<const PreprocessResult> preprocessResult() const { return preprocess_; }
  std::shared_ptr<const std::vector<TileReconstruction>> tileResults() const { return tiles_; }
  /// The parameters the tile results were made with (withViewSamples needs them).
  const PipelineParams& tileParams() const { return tileParams_; }
  /// Whether the tile results were made from the current preprocessing result (not from one that
  /// a later preprocessing replaced: their point indices refer to that one's points).
  bool tilesMatchPreprocessing() const { return tiles_ && tilesPreprocessing_ == preprocessings_; }
  std::shared_ptr<const MergeResult> mergeResult() const { return merge_; }
  std::shared_ptr<const JointsResult> jointsResult() const { return joints_; }
  double stageSeconds(Stage stage) const { return seconds_[static_cast<int>(stage)]; }

  /// The network in world coordinates: the joined pipes, joints and runs once the joints stage has
  /// run (pipe ids from 1, longest first; joint ids after them), else the merged pipes alone;
  /// empty before the merge ran.
  PipeNetwork network() const;

 private:
  void runPreprocess(Progress& progress);
  void runTiles(Stage first, Stage last, Progress& progress);
  void runMerge(Progress& progress);
  void runJoints(Progress& progress);

  std::shared_ptr<const PointCloud> input_;
  bool releaseInput_ = false;
  std::optional<TileDetails> releasedDetails_;
  bool tilesHaveStripes_ = false;  ///< tiles_ kept what later stages read, so a re-run may reuse them.
  PipelineParams tileParams_;
  std::uint64_t preprocessings_ = 0;      ///< Preprocessing results made so far...
  std::uint64_t tilesPreprocessing_ = 0;  ///< ...and the one the tile results were made from.
  PipelineParams params_;
  std::array<bool, kStageCount> fresh_{};
  std::array<double, kStageCount> seconds_{};
  std::shared_ptr<const PreprocessResult> preprocess_;
  std::shared_ptr<const std::vector<TileReconstruction>> tiles_;
  std::shared_ptr<const MergeResult> merge_;
  std::shared_ptr<const JointsResult> joints_;
};

/// Round `round` of `tile` (one of tileResults(), made from `prepared`) as it was made, with the
/// sphere samples and circle candidates that releaseTileDetails(TileDetails::ViewSamples) dropped
/// made again: its directions and placement run again on the points it analysed, with the
/// parameters it was made with (tileParams()) and its seed, which gives the same results.
TileRound withViewSamples(const PreprocessResult& prepared, const TileReconstruction& tile, std::size_t round,
                          const PipelineParams& params);

}  // namespace piperun
