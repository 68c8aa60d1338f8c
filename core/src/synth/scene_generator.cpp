#include "piperun/synth/scene_generator.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>

#include <Eigen/Geometry>

#include "angles.h"
#include "random.h"
#include "synth/scanner.h"
#include "synth/scene_layout.h"

namespace piperun {
namespace {

/// Points handed to the sink at a time (about 8 MB of chunk).
constexpr std::size_t kChunkPoints = std::size_t{1} << 18;
/// Angular step of the sparse scan that measures how many rays hit something.
constexpr double kCalibrationStep = 0.5 * kDegree;
/// Finest angular step allowed, whatever the density scale (about 0.5 mm at 10 m).
constexpr double kFinestStep = 0.003 * kDegree;
/// A misregistered station turns by the registration error per this distance (radians per metre
/// of error), so points 10 m away move by about twice the error.
constexpr double kRegistrationLever = 10.0;
/// The random stream of the stations' misregistration, apart from the scan's noise.
constexpr std::uint64_t kRegistrationStream = 0x7265676973747279ULL;

/// Where a station's points land when the registration is off (params.registrationError): the
/// first station is the reference and stays; the others move rigidly about themselves.
std::optional<Eigen::Isometry3d> misregistration(const SceneParams& params, int stationIndex,
                                                 const Eigen::Vector3d& station) {
  if (params.registrationError == 0.0 || stationIndex == 0) return std::nullopt;
  Rng rng(params.seed, {kRegistrationStream, static_cast<std::uint64_t>(stationIndex)});
  auto randomUnit = [&rng] {
    Eigen::Vector3d v;
    do v = Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal());
    while (v.norm() < 1e-9);
    return v.normalized();
  };
  const Eigen::Vector3d shift = params.registrationError * randomUnit();
  const Eigen::AngleAxisd turn(params.registrationError / kRegistrationLever, randomUnit());
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translate(station + shift).rotate(turn).translate(-station);
  return pose;
}

double targetPoints(ScenePreset preset) {
  switch (preset) {
    case ScenePreset::Small:
      return 300e3;
    case ScenePreset::Medium:
      return 2e6;
    case ScenePreset::Large:
      return 20e6;
  }
  throw std::invalid_argument("unknown scene preset");
}

void checkParams(const SceneParams& params) {
  if (!(params.noiseSigma >= 0.0 && std::isfinite(params.noiseSigma))) {
    throw std::invalid_argument("scene noise sigma must be a finite value >= 0, got " +
                                std::to_string(params.noiseSigma));
  }
  if (!(params.outlierFraction >= 0.0 && params.outlierFraction < 1.0)) {
    throw std::invalid_argument("scene outlier fraction must be in [0, 1), got " +
                                std::to_string(params.outlierFraction));
  }
  if (!(params.densityScale > 0.0 && std::isfinite(params.densityScale))) {
    throw std::invalid_argument("scene density scale must be a finite value > 0, got " +
                                std::to_string(params.densityScale));
  }
  if (!(params.registrationError >= 0.0 && std::isfinite(params.registrationError))) {
    throw std::invalid_argument("scene registration error must be a finite value >= 0, got " +
                                std::to_string(params.registrationError));
  }
  if (!(params.mixedPixelShare >= 0.0 && params.mixedPixelShare <= 1.0)) {
    throw std::invalid_argument("scene mixed pixel share must be in [0, 1], got " +
                                std::to_string(params.mixedPixelShare));
  }
  if (params.stations < 0 || params.stations > 3) {
    throw std::invalid_argument("scene stations must be 0 (chosen by the seed) to 3, got " +
                                std::to_string(params.stations));
  }
}

}  // namespace

SceneSummary generateScene(const SceneParams& params, PipeNetwork& truth, const PointChunkSink& sink,
                           Progress& progress) {
  checkParams(params);
  progress.report("Laying out the scene", 0.0);
  synth::SceneLayout layout = synth::buildSceneLayout(params);
  progress.checkCancelled();
  std::vector<synth::Surface> roofed;
  if (params.roof) {
    roofed = layout.surfaces;
    roofed.push_back(layout.roof);
  }
  // The sampling is calibrated on the scene without its roof (below), so a roof adds points and
  // takes none from the pipes.
  const synth::Scanner calibration(std::move(layout.surfaces));
  const std::optional<synth::Scanner> withRoof =
      params.roof ? std::optional<synth::Scanner>(std::in_place, std::move(roofed)) : std::nullopt;
  const synth::Scanner& scanner = withRoof ? *withRoof : calibration;
  const int stationCount = static_cast<int>(layout.stations.size());

  synth::ScanSettings settings;
  settings.noiseSigma = params.noiseSigma;
  settings.outlierFraction = params.outlierFraction;
  settings.mixedPixelShare = params.mixedPixelShare;
  settings.outlierBox = layout.room;
  settings.seed = params.seed;
  // Hits grow as 1 / step² on an angular grid, so a sparse scan from every station tells which
  // step gives the preset's point count (outliers come on top of the surface points).
  settings.angularStep = kCalibrationStep;
  std::uint64_t sparseHits = 0;
  for (const Eigen::Vector3d& station : layout.stations) sparseHits += calibration.countHits(station, settings);
  const double wantedHits = targetPoints(params.preset) * params.densityScale / (1.0 + params.outlierFraction);
  settings.angularStep =
      std::max(kFinestStep,
               kCalibrationStep * std::sqrt(static_cast<double>(std::max<std::uint64_t>(sparseHits, 1)) / wantedHits));

  SceneSummary summary;
  summary.stations = stationCount;
  const std::size_t elementCount = layout.truth.pipes.size() + layout.truth.joints.size();
  std::vector<std::int64_t> pointsPerElement(elementCount + 1, 0);
  const bool turned = params.up != UpAxis::PlusZ;
  const Eigen::Matrix3d turn = turnZUpTo(params.up);
  PointChunk chunk;
  auto flush = [&] {
    if (chunk.empty()) return;
    sink(chunk);
    chunk.clear();
  };
  for (int s = 0; s < stationCount; ++s) {
    const std::string task = "Scanning station " + std::to_string(s + 1) + " of " + std::to_string(stationCount);
    const std::optional<Eigen::Isometry3d> registered = misregistration(params, s, layout.stations[s]);
    scanner.scan(layout.stations[s], s, settings, [&](synth::ScanStrip&& strip, double fraction) {
      if (registered) {
        for (Eigen::Vector3d& position : strip.positions) position = *registered * position;
      }
      if (turned) {
        for (Eigen::Vector3d& position : strip.positions) position = turn * position;
      }
      for (std::size_t i = 0; i < strip.positions.size(); ++i) {
        chunk.positions.push_back(strip.positions[i]);
        chunk.intensities.push_back(strip.intensities[i]);
        chunk.labels.push_back(strip.labels[i]);
        summary.bounds.extend(strip.positions[i]);
        const std::int32_t label = strip.labels[i];
        if (label > 0) ++pointsPerElement[static_cast<std::size_t>(label)];
        if (chunk.size() >= kChunkPoints) flush();
      }
      summary.points += strip.positions.size();
      summary.outliers += strip.outliers;
      summary.mixedPixels += strip.mixedPixels;
      progress.report(task, (s + fraction) / stationCount);
      progress.checkCancelled();
    });
  }
  flush();

  truth = std::move(layout.truth);
  if (turned) truth.turn(turn);
  for (Pipe& pipe : truth.pipes) pipe.inlierCount = pointsPerElement[static_cast<std::size_t>(pipe.id)];
  summary.pipes = static_cast<int>(truth.pipes.size());
  for (const Joint& joint : truth.joints) {
    if (joint.type == JointType::Elbow) ++summary.elbows;
    if (joint.type == JointType::Tee) ++summary.tees;
  }
  summary.runs = static_cast<int>(truth.runs.size());
  summary.directions = static_cast<int>(synth::distinctPipeDirections(truth, 0.5 * kDegree).size());
  progress.report("Scene generated", 1.0);
  return summary;
}

GeneratedScene generateScene(const SceneParams& params, Progress& progress) {
  GeneratedScene scene;
  scene.summary = generateScene(
      params, scene.truth, [&](const PointChunk& chunk) { scene.cloud.append(chunk); }, progress);
  return scene;
}

std::string toString(ScenePreset preset) {
  switch (preset) {
    case ScenePreset::Small:
      return "small";
    case ScenePreset::Medium:
      return "medium";
    case ScenePreset::Large:
      return "large";
  }
  return "unknown";
}

ScenePreset scenePresetFromString(const std::string& name) {
  if (name == "small") return ScenePreset::Small;
  if (name == "medium") return ScenePreset::Medium;
  if (name == "large") return ScenePreset::Large;
  throw std::invalid_argument("unknown scene preset '" + name + "', expected small, medium or large");
}

}  // namespace piperun
