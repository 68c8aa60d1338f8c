// The pipeline: stage results held as immutable values, stale tracking, tiles in parallel.
//
// The per-tile stages run in rounds (directions → placement → extents on the points the previous
// rounds left unexplained), so a change to any per-tile stage re-runs that stage from the first
// round and everything after it; results of earlier stages in the first round are reused.

#include "piperun/pipeline.h"

#include "piperun/error.h"
#include "piperun/params.h"

#include "free_storage.h"
#include "random.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <stdexcept>

namespace piperun {

namespace {

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Independent, reproducible seeds per (seed, tile, round).
std::uint64_t mixSeed(std::uint64_t seed, std::uint64_t tile, std::uint64_t round) {
  return mixBits(seed + 0x9E3779B97F4A7C15ull * (1 + tile * 1000003ull + round));
}

std::vector<std::uint32_t> unexplainedPoints(const std::vector<std::uint32_t>& points, const ExtentsResult& extents) {
  std::vector<std::uint32_t> explained;
  for (const auto& segment : extents.segments) explained.insert(explained.end(), segment.inliers.begin(), segment.inliers.end());
  std::sort(explained.begin(), explained.end());
  std::vector<std::uint32_t> remaining;
  remaining.reserve(points.size());
  std::set_difference(points.begin(), points.end(), explained.begin(), explained.end(), std::back_inserter(remaining));
  return remaining;
}

int index(Stage stage) { return static_cast<int>(stage); }

// See Pipeline::releaseTileDetails.
void dropDetails(TileRound& round, TileDetails details) {
  freeStorage(round.directions.samples);
  freeStorage(round.directions.sampleDirection);
  for (auto& projection : round.placement.projections) freeStorage(projection.candidates);
  if (details == TileDetails::ViewSamples) return;
  freeStorage(round.points);
  for (auto& direction : round.directions.directions) freeStorage(direction.stripe);
  for (auto& cylinder : round.placement.cylinders) freeStorage(cylinder.inliers);
}

}  // namespace

const char* stageName(Stage stage) {
  switch (stage) {
    case Stage::Preprocess: return "preprocess";
    case Stage::Directions: return "directions";
    case Stage::Placement: return "placement";
    case Stage::Extents: return "extents";
    case Stage::Merge: return "merge";
    case Stage::Joints: return "joints";
  }
  return "?";
}

std::optional<Stage> stageFromName(const std::string& name) {
  for (Stage stage : kAllStages) {
    if (name == stageName(stage)) return stage;
  }
  return std::nullopt;
}

Pipeline::Pipeline(std::shared_ptr<const PointCloud> input, PipelineParams params)
    : input_(std::move(input)), params_(std::move(params)) {
  if (!input_) throw std::invalid_argument("Pipeline needs an input cloud");
  validateParams(params_);
}

void Pipeline::setParams(const PipelineParams& params) {
  validateParams(params);
  const auto changed = firstChangedStage(params_, params);
  params_ = params;
  if (changed) invalidate(*changed);
}

void Pipeline::invalidate(Stage stage) {
  for (int i = index(stage); i < kStageCount; ++i) fresh_[i] = false;
}

void Pipeline::run(Progress& progress, Stage last) {
  progress.checkCancelled();
  if (!fresh_[index(Stage::Preprocess)]) runPreprocess(progress);
  if (last == Stage::Preprocess) return;

  // The first stale per-tile stage up to `last`.
  Stage firstStale = Stage::Merge;
  for (Stage stage : {Stage::Directions, Stage::Placement, Stage::Extents}) {
    if (index(stage) > index(last)) break;
    if (!fresh_[index(stage)]) {
      firstStale = stage;
      break;
    }
  }
  if (firstStale != Stage::Merge) {
    progress.checkCancelled();
    runTiles(firstStale, std::min(last, Stage::Extents), progress);
  }
  if (index(last) >= index(Stage::Merge) && !fresh_[index(Stage::Merge)]) {
    progress.checkCancelled();
    runMerge(progress);
  }
  if (last == Stage::Joints && !fresh_[index(Stage::Joints)]) {
    progress.checkCancelled();
    runJoints(progress);
  }
}

void Pipeline::releaseInput() {
  releaseInput_ = true;
  if (fresh_[index(Stage::Preprocess)]) input_.reset();
}

void Pipeline::runPreprocess(Progress& progress) {
  if (!input_) throw std::logic_error("Pipeline: the input cloud was released; the preprocessing cannot run again");
  const auto started = std::chrono::steady_clock::now();
  invalidate(Stage::Preprocess);
  // Handing over the last share lets the stage free the input once it has read it.
  std::shared_ptr<const PointCloud> input = input_;
  if (releaseInput_) input_.reset();
  auto result = std::make_shared<const PreprocessResult>(preprocess(std::move(input), params_.preprocess, progress));
  preprocess_ = std::move(result);
  ++preprocessings_;
  seconds_[index(Stage::Preprocess)] = secondsSince(started);
  fresh_[index(Stage::Preprocess)] = true;
}

void Pipeline::runTiles(Stage first, Stage last, Progress& progress) {
  const PreprocessResult& prepared = *preprocess_;
  const std::vector<Tile>& tiles = prepared.tiles;
  // Earlier first-round results can be reused only when they were made from the current tiles and
  // kept what the later stages read.
  const bool reuse = first != Stage::Directions && tilesMatchPreprocessing() && tilesHaveStripes_;
  const auto previous = tiles_;
  auto results = std::make_shared<std::vector<TileReconstruction>>(tiles.size());
  const int rounds = last == Stage::Extents ? std::max(1, params_.rounds) : 1;

  std::atomic<std::size_t> finished{0};
  // Parallel tasks share the cancel flag but not the progress bar: the pipeline reports tiles done.
  Progress quiet(progress, {});
  tbb::parallel_for(std::size_t{0}, tiles.size(), [&](std::size_t t) {
    const Tile& tile = tiles[t];
    TileReconstruction& out = (*results)[t];
    out.tileId = tile.id;
    std::vector<std::uint32_t> remaining = tile.points;
    std::sort(remaining.begin(), remaining.end());
    for (int round = 0; round < rounds; ++round) {
      quiet.checkCancelled();
      const std::uint64_t seed = mixSeed(params_.seed, static_cast<std::uint64_t>(tile.id), static_cast<std::uint64_t>(round));
      TileRound current;
      const TileRound* old = reuse && round == 0 && !(*previous)[t].rounds.empty() ? &(*previous)[t].rounds[0] : nullptr;
      current.points = remaining;
      if (old && index(first) > index(Stage::Directions)) {
        current.directions = old->directions;
      } else {
        current.directions = detectDirections({prepared.points, current.points, seed}, params_.directions, quiet);
      }
      if (index(last) >= index(Stage::Placement)) {
        if (old && index(first) > index(Stage::Placement)) {
          current.placement = old->placement;
        } else {
          current.placement = placeCylinders({prepared.points, current.directions, seed}, params_.placement, quiet);
        }
      }
      if (index(last) >= index(Stage::Extents)) {
        current.extents = computeExtents({prepared.points, current.placement}, params_.extents, quiet);
      }
      const bool foundPipes = !current.extents.segments.empty();
      if (foundPipes) remaining = unexplainedPoints(remaining, current.extents);
      if (releasedDetails_) dropDetails(current, *releasedDetails_);
      out.rounds.push_back(std::move(current));
      if (!foundPipes) break;
    }
    progress.report("tiles", static_cast<double>(++finished) / static_cast<double>(tiles.size()));
  });

  tiles_ = std::move(results);
  tilesHaveStripes_ = releasedDetails_ != TileDetails::All;
  tileParams_ = params_;
  tilesPreprocessing_ = preprocessings_;
  for (Stage stage : {Stage::Directions, Stage::Placement, Stage::Extents}) {
    if (index(stage) > index(last)) break;
    double seconds = 0.0;
    for (const auto& tile : *tiles_) {
      for (const auto& round : tile.rounds) {
        if (stage == Stage::Directions) seconds += round.directions.diagnostics.seconds;
        if (stage == Stage::Placement) seconds += round.placement.diagnostics.seconds;
        if (stage == Stage::Extents) seconds += round.extents.diagnostics.seconds;
      }
    }
    seconds_[index(stage)] = seconds;
    fresh_[index(stage)] = true;
  }
  // Stages after `last` and the merge depend on what just changed.
  for (int i = index(last) + 1; i < kStageCount; ++i) fresh_[i] = false;
}

void Pipeline::runMerge(Progress& progress) {
  const auto started = std::chrono::steady_clock::now();
  std::vector<PipeSegment> segments;
  for (const auto& tile : *tiles_) {
    for (const auto& round : tile.rounds) {
      segments.insert(segments.end(), round.extents.segments.begin(), round.extents.segments.end());
    }
  }
  merge_ = std::make_shared<const MergeResult>(mergeAndExtend(preprocess_->points, segments, params_.merge, progress));
  seconds_[index(Stage::Merge)] = secondsSince(started);
  fresh_[index(Stage::Merge)] = true;
  fresh_[index(Stage::Joints)] = false;
}

void Pipeline::runJoints(Progress& progress) {
  const auto started = std::chrono::steady_clock::now();
  joints_ = std::make_shared<const JointsResult>(
      connectPipes({preprocess_->points, merge_->segments, &preprocess_->planePoints, upVector(params_.up)},
                   params_.joints, progress));
  seconds_[index(Stage::Joints)] = secondsSince(started);
  fresh_[index(Stage::Joints)] = true;
}

TileRound withViewSamples(const PreprocessResult& prepared, const TileReconstruction& tile, std::size_t round,
                          const PipelineParams& params) {
  TileRound result = tile.rounds.at(round);
  const std::uint64_t seed = mixSeed(params.seed, static_cast<std::uint64_t>(tile.tileId), round);
  DirectionsResult directions = detectDirections({prepared.points, result.points, seed}, params.directions);
  if (!result.placement.projections.empty()) {
    PlacementResult placement = placeCylinders({prepared.points, directions, seed}, params.placement);
    for (std::size_t k = 0; k < placement.projections.size() && k < result.placement.projections.size(); ++k)
      result.placement.projections[k].candidates = std::move(placement.projections[k].candidates);
  }
  result.directions.samples = std::move(directions.samples);
  result.directions.sampleDirection = std::move(directions.sampleDirection);
  return result;
}

PipeNetwork Pipeline::network() const {
  PipeNetwork network;
  if (!merge_ || !preprocess_) return network;
  const Eigen::Vector3d origin = preprocess_->points.origin;
  // Stale joints belong to an older merge or older parameters: the merged pipes alone then.
  const bool joined = joints_ && fresh_[index(Stage::Joints)];
  const std::vector<PipeSegment>& segments = joined ? joints_->pipes : merge_->segments;
  int id = 1;
  for (const auto& segment : segments) {
    // Without the joints stage, a pipe that must take a joint to stay has not been confirmed.
    if (!joined && segment.mustJoin) continue;
    Pipe pipe;
    pipe.id = id++;
    pipe.radius = segment.radius;
    pipe.start = origin + segment.start;
    pipe.end = origin + segment.end;
    pipe.fitRms = segment.rms;
    pipe.inlierCount = static_cast<std::int64_t>(segment.inliers.size());
    pipe.confidence = segment.confidence;
    pipe.status = segment.confidence >= 0.5 ? PipeStatus::Accepted : PipeStatus::Proposed;
    network.pipes.push_back(pipe);
  }
  if (!joined) return network;
  for (Joint joint : joints_->joints) {
    for (Eigen::Vector3d& point : joint.axis) point += origin;
    network.joints.push_back(std::move(joint));
  }
  network.runs = joints_->runs;
  for (const Run& run : network.runs) {
    for (int pipeId : run.pipeIds) network.pipes[static_cast<std::size_t>(pipeId - 1)].runId = run.id;
  }
  return network;
}

}  // namespace piperun
