#include "commands.h"

#include "console.h"
#include "piperun/edit/bill_of_materials.h"
#include "piperun/edit/nominal_sizes.h"
#include "piperun/edit/project.h"
#include "piperun/edit/review_queue.h"
#include "piperun/edit/runs.h"
#include "piperun/error.h"
#include "piperun/eval/evaluation.h"
#include "piperun/io/network_export.h"
#include "piperun/io/network_io.h"
#include "piperun/io/output_path.h"
#include "piperun/io/point_reader.h"
#include "piperun/io/point_writer.h"
#include "piperun/params.h"
#include "piperun/pipeline.h"
#include "piperun/spacing.h"
#include "piperun/stage_dump.h"
#include "piperun/synth/scene_generator.h"

#include <nlohmann/json.hpp>
#include <sys/resource.h>
#include <tbb/global_control.h>
#include <tbb/info.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>

namespace piperun::cli {

namespace {

using nlohmann::json;

/// A network file's network, or the reviewed network of a project (.piperun), whose metadata
/// then names the project's scan, and its up axis when that is not z (as reconstruct records it).
PipeNetwork readNetworkOrProject(const std::string& path, NetworkMetadata* metadata = nullptr) {
  if (!isProjectFile(path)) return readNetwork(path, metadata);
  Project project = readProject(path);
  if (metadata) {
    (*metadata)["project"] = "reviewed network, " + std::to_string(project.edits.position()) + " edits";
    if (!project.scanPath.empty()) (*metadata)["scan"] = project.scanPath.string();
    recordUpAxis(*metadata, project.params.up);
  }
  return project.edits.network();
}

/// The process's peak resident memory so far (MB), as /usr/bin/time reports it.
double peakResidentMegabytes() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // kilobytes on Linux
}

json vectorJson(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

template <typename Names>
std::string joinNames(const Names& names) {
  std::string text;
  for (const auto& name : names) text += (text.empty() ? "" : ", ") + std::string(name);
  return text.empty() ? "none" : text;
}

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

int networkInfo(const InfoOptions& options) {
  NetworkMetadata metadata;
  const PipeNetwork network = readNetworkOrProject(options.input, &metadata);
  const bool project = isProjectFile(options.input);
  const char* format = project ? kProjectFormatName : kNetworkFormatName;
  int elbows = 0, tees = 0, boundaries = 0;
  for (const auto& joint : network.joints) {
    elbows += joint.type == JointType::Elbow;
    tees += joint.type == JointType::Tee;
    boundaries += joint.type == JointType::Boundary;
  }
  double pipeLength = 0.0;
  for (const auto& pipe : network.pipes) pipeLength += pipe.length();
  const NominalSizes table = NominalSizes::shipped();
  const std::vector<SizeTally> sizes = tallyBySize(network, table);
  const std::vector<RunSummary> runs = options.runs ? summarizeRuns(network, table) : std::vector<RunSummary>{};
  if (options.json) {
    json out = {{"file", options.input},     {"format", format}, {"pipes", network.pipes.size()},
                {"joints", network.joints.size()}, {"elbows", elbows},        {"tees", tees},
                {"boundary_joints", boundaries},    {"runs", network.runs.size()}, {"pipe_length_m", pipeLength},
                {"metadata", metadata}};
    out["sizes"] = json::array();
    for (const SizeTally& size : sizes) {
      out["sizes"].push_back({{"nps", size.size.nps}, {"dn", size.size.dn}, {"pipes", size.pipes},
                              {"pipe_length_m", size.pipeLength}, {"elbows", size.elbows},
                              {"elbows_90", size.elbows90}, {"elbows_45", size.elbows45}, {"tees", size.tees},
                              {"boundary_joints", size.boundaries}, {"proposed", size.proposed}});
    }
    if (options.runs) {
      out["run_list"] = json::array();
      for (const RunSummary& run : runs) {
        out["run_list"].push_back({{"id", run.id}, {"length_m", run.length}, {"nps", run.size.nps}, {"dn", run.size.dn},
                                   {"pipes", run.pipes}, {"elbows", run.elbows}, {"tees", run.tees},
                                   {"proposed", run.proposed}});
      }
    }
    std::printf("%s\n", out.dump(2).c_str());
    return kExitOk;
  }
  std::printf("file: %s\n", options.input.c_str());
  std::printf("format: %s version %d\n", format, project ? kProjectFormatVersion : kNetworkFormatVersion);
  for (const auto& [key, value] : metadata) std::printf("metadata: %s = %s\n", key.c_str(), value.c_str());
  std::printf("pipes: %zu (total length %.2f m)\n", network.pipes.size(), pipeLength);
  std::printf("joints: %zu (elbows %d, tees %d, boundary %d)\n", network.joints.size(), elbows, tees, boundaries);
  std::printf("runs: %zu\n", network.runs.size());
  for (const SizeTally& size : sizes) {
    // The elbows by fitting: those at 90° and 45°, and the others.
    std::string fittings;
    if (size.elbows > 0) {
      std::vector<std::string> kinds;
      if (size.elbows90 > 0) kinds.push_back(std::to_string(size.elbows90) + " at 90\u00b0");
      if (size.elbows45 > 0) kinds.push_back(std::to_string(size.elbows45) + " at 45\u00b0");
      const int other = size.elbows - size.elbows90 - size.elbows45;
      if (other > 0) kinds.push_back(std::to_string(other) + " other");
      fittings = " (" + joinNames(kinds) + ")";
    }
    std::printf("size %s\" (DN %d): pipes %d (%.2f m), elbows %d%s, tees %d, boundary %d, proposed %d\n",
                size.size.nps.c_str(), size.size.dn, size.pipes, size.pipeLength, size.elbows, fittings.c_str(),
                size.tees, size.boundaries, size.proposed);
  }
  for (const RunSummary& run : runs) {
    std::printf("run %d: %.2f m, %s\" (DN %d), pipes %d, elbows %d, tees %d, proposed %d\n", run.id, run.length,
                run.size.nps.c_str(), run.size.dn, run.pipes, run.elbows, run.tees, run.proposed);
  }
  return kExitOk;
}

/// The unit a scan was read in and why: "m", "mm (--units)", "us-ft (GeoTIFF key …)".
std::string unitsNote(const CloudInfo& info, const std::string& asked, const std::string& used) {
  if (!asked.empty()) return used + " (--units)";
  if (!info.declaredUnits.empty()) return used + " (" + info.declaredUnitsSource + ")";
  return used;
}

struct ExportTarget {
  ExportFormat format;
  std::string path;
};

// "obj:out/net.obj" → (Obj, "out/net.obj").
ExportTarget parseExportTarget(const std::string& spec) {
  const auto colon = spec.find(':');
  const auto format = colon == std::string::npos ? std::nullopt : exportFormatFromString(spec.substr(0, colon));
  if (!format || colon + 1 >= spec.size()) {
    throw std::invalid_argument("--export " + spec + ": expected FORMAT:FILE with FORMAT one of " +
                                joinNames(exportFormatNames()));
  }
  return {*format, spec.substr(colon + 1)};
}

}  // namespace

int runInfo(const InfoOptions& options) {
  if (isNetworkFile(options.input) || isProjectFile(options.input)) return networkInfo(options);

  const auto start = std::chrono::steady_clock::now();
  ProgressBar bar(options.quiet);
  ReadOptions readOptions;
  readOptions.progress = &bar.progress();
  readOptions.units = options.units;
  ReadReport report;
  const PointCloud cloud = readPointCloud(options.input, readOptions, &report);
  const double readSeconds = secondsSince(start);
  bar.finish();
  for (const auto& warning : report.warnings) warn(warning);

  const BoundingBox box = cloud.boundingBox();
  const double spacing = estimatePointSpacing(cloud);
  if (const auto sparse = sparseScanWarning(spacing)) warn(options.input + ": " + *sparse);
  std::string fields;
  for (const auto& field : report.info.fields) fields += (fields.empty() ? "" : " ") + field;

  if (options.json) {
    json out = {{"file", options.input},
                {"format", report.info.format},
                {"fields", report.info.fields},
                {"points", cloud.size()},
                {"non_finite_dropped", report.nonFiniteDropped},
                {"attributes", attributeNames(cloud.attributes())},
                {"units", report.units},
                {"units_source", options.units.empty() ? report.info.declaredUnitsSource : "--units"},
                {"spacing_m", spacing},
                {"read_seconds", readSeconds}};
    if (!box.empty()) out["bounds"] = {{"min", vectorJson(box.min)}, {"max", vectorJson(box.max)}, {"size", vectorJson(box.size())}};
    std::printf("%s\n", out.dump(2).c_str());
    return kExitOk;
  }
  std::printf("file: %s\n", options.input.c_str());
  std::printf("format: %s\n", report.info.format.c_str());
  std::printf("fields: %s\n", fields.c_str());
  std::printf("points: %zu\n", cloud.size());
  if (report.nonFiniteDropped > 0) {
    std::printf("dropped: %llu points with NaN or infinite coordinates\n",
                static_cast<unsigned long long>(report.nonFiniteDropped));
  }
  std::printf("attributes: %s\n", joinNames(attributeNames(cloud.attributes())).c_str());
  std::printf("units: %s%s\n", unitsNote(report.info, options.units, report.units).c_str(),
              report.units == "m" ? "" : ", read as metres");
  if (!box.empty()) {
    std::printf("bounds min: %.3f %.3f %.3f\n", box.min.x(), box.min.y(), box.min.z());
    std::printf("bounds max: %.3f %.3f %.3f\n", box.max.x(), box.max.y(), box.max.z());
    std::printf("size: %.3f x %.3f x %.3f m\n", box.size().x(), box.size().y(), box.size().z());
  }
  std::printf("spacing: %.1f mm (median nearest-neighbour distance)\n", spacing * 1000.0);
  std::printf("read: %.2f s\n", readSeconds);
  return kExitOk;
}

int runGenerate(const GenerateOptions& options) {
  SceneParams params;
  params.preset = scenePresetFromString(options.preset);
  params.seed = options.seed;
  params.noiseSigma = options.noise;
  params.outlierFraction = options.outliers;
  params.stations = options.stations;
  params.densityScale = options.density;
  params.registrationError = options.registrationError;
  params.mixedPixelShare = options.mixedPixels;
  params.up = upAxisFromString(options.up);
  params.roof = options.roof;

  // The truth is written after the scene; the scan's file is checked by opening it, below.
  if (!options.truth.empty()) requireWritableFile(options.truth);
  const auto start = std::chrono::steady_clock::now();
  ProgressBar bar(options.quiet);
  const unsigned attributes = kIntensity | (options.labels ? kLabels : kNoAttributes);
  auto writer = openPointWriter(options.output, attributes);
  PipeNetwork truth;
  PointChunk kept;
  const SceneSummary summary = generateScene(
      params, truth,
      [&](const PointChunk& chunk) {
        if (options.labels) {
          writer->write(chunk);
          return;
        }
        kept.positions = chunk.positions;
        kept.intensities = chunk.intensities;
        writer->write(kept);
      },
      bar.progress());
  writer->close();
  if (!options.truth.empty()) {
    NetworkMetadata metadata = {{"generator", "piperun generate"},
                                {"preset", options.preset},
                                {"seed", std::to_string(options.seed)},
                                {"noise_m", std::to_string(options.noise)},
                                {"outlier_fraction", std::to_string(options.outliers)},
                                {"stations", std::to_string(summary.stations)}};
    // Only the scan effects a scene has, so the default scenes' truths stay as they were.
    if (options.registrationError > 0.0) metadata["registration_error_m"] = std::to_string(options.registrationError);
    if (options.mixedPixels > 0.0) metadata["mixed_pixel_share"] = std::to_string(options.mixedPixels);
    recordUpAxis(metadata, params.up);
    if (options.roof) metadata["roof"] = "true";
    writeNetwork(options.truth, truth, metadata);
  }
  bar.finish();

  const BoundingBox& box = summary.bounds;
  std::printf("scene: preset %s, seed %llu, %d station(s)\n", options.preset.c_str(),
              static_cast<unsigned long long>(options.seed), summary.stations);
  const std::string mixed =
      summary.mixedPixels > 0 ? ", " + std::to_string(summary.mixedPixels) + " mixed pixels" : std::string();
  std::printf("points: %llu written to %s (%llu outliers%s)\n", static_cast<unsigned long long>(summary.points),
              options.output.c_str(), static_cast<unsigned long long>(summary.outliers), mixed.c_str());
  if (!options.truth.empty()) std::printf("truth: %s\n", options.truth.c_str());
  if (!box.empty()) std::printf("size: %.1f x %.1f x %.1f m\n", box.size().x(), box.size().y(), box.size().z());
  std::printf("time: %.2f s\n", secondsSince(start));
  std::printf("points=%llu pipes=%d elbows=%d tees=%d runs=%d directions=%d stations=%d\n",
              static_cast<unsigned long long>(summary.points), summary.pipes, summary.elbows, summary.tees,
              summary.runs, summary.directions, summary.stations);
  return kExitOk;
}

namespace {

/// One line per truth elbow and tee ("joint …", found or missed) and per spurious joint
/// ("spurious …"), positions in metres.
void printJointOutcomes(const EvaluationResult& figures) {
  for (const JointOutcome& outcome : figures.jointOutcomes) {
    std::string line = "joint " + toString(outcome.type) + " " + std::to_string(outcome.truthId);
    char text[160];
    if (outcome.matchedId >= 0) {
      std::snprintf(text, sizeof text, " found as %d, %.3f m off", outcome.matchedId, outcome.distance);
    } else {
      std::snprintf(text, sizeof text, " missed");
    }
    line += text;
    if (outcome.type == JointType::Elbow) {
      if (outcome.matchedId >= 0) {
        std::snprintf(text, sizeof text, ", R %.3f -> %.3f m", outcome.truthBendRadius, outcome.predictedBendRadius);
      } else {
        std::snprintf(text, sizeof text, ", R %.3f m", outcome.truthBendRadius);
      }
      line += text;
    }
    std::snprintf(text, sizeof text, ", at (%.2f, %.2f, %.2f), pipes", outcome.position.x(), outcome.position.y(),
                  outcome.position.z());
    line += text;
    for (std::size_t k = 0; k < outcome.pipeIds.size(); ++k) {
      line += " " + std::to_string(outcome.pipeIds[k]);
      if (k < outcome.pipePoints.size()) {
        line += " (" + std::to_string(outcome.pipePoints[k]) + " points";
        if (k < outcome.pipePointsNearCorner.size()) {
          std::snprintf(text, sizeof text, ", %d within %.2f m", outcome.pipePointsNearCorner[k], outcome.cornerDistance);
          line += text;
        }
        line += ")";
      }
    }
    if (outcome.ownPoints >= 0) line += ", " + std::to_string(outcome.ownPoints) + " points on it";
    if (outcome.cause != MissCause::None) {
      line += "; " + toString(outcome.cause) + " (found near the corner:";
      for (const double share : outcome.pipeFoundNearCorner) {
        if (share < 0.0) {
          line += " -";
        } else {
          std::snprintf(text, sizeof text, " %.0f %%", 100.0 * share);
          line += text;
        }
      }
      line += ")";
    }
    std::printf("%s\n", line.c_str());
  }
  for (const SpuriousJoint& joint : figures.spurious) {
    std::printf("spurious %s %d, %s %.2f, at (%.2f, %.2f, %.2f)", toString(joint.type).c_str(), joint.id,
                toString(joint.status).c_str(), joint.confidence, joint.position.x(), joint.position.y(),
                joint.position.z());
    if (joint.nearestTruthId >= 0) {
      std::printf(", nearest truth joint %d %.2f m away", joint.nearestTruthId, joint.nearestTruthDistance);
    }
    std::printf("\n");
  }
}

}  // namespace

int runEval(const EvalOptions& options) {
  const PipeNetwork truth = readNetworkOrProject(options.truth);
  const PipeNetwork result = readNetworkOrProject(options.result);
  EvaluationParams params;
  params.fixedTolerance = options.tolerance;
  params.sampleStep = options.step;
  params.pipesOnly = options.pipesOnly;
  const NominalSizes sizes = NominalSizes::shipped();
  params.nominalSizes = &sizes;
  const PointCloud scan = options.scan.empty() ? PointCloud{} : readPointCloud(options.scan);
  const EvaluationResult figures = evaluateNetwork(truth, result, params, options.scan.empty() ? nullptr : &scan);
  if (options.json) {
    json out = {{"precision", figures.precision},
                      {"recall", figures.recall},
                      {"f1", figures.f1},
                      {"radius_err_mm", figures.radiusErrorMedian * 1000.0},
                      {"truth_samples", figures.truthSamples},
                      {"predicted_samples", figures.predictedSamples},
                      {"elbows_truth", figures.truthElbows},
                      {"elbows_found", figures.foundElbows},
                      {"tees_truth", figures.truthTees},
                      {"tees_found", figures.foundTees},
                      {"predicted_joints", figures.predictedJoints},
                      {"spurious_joints", figures.spuriousJoints},
                      {"bend_radius_err", figures.bendRadiusErrorMedian},
                      {"matched_truth_samples", figures.matchedTruthSamples},
                      {"nominal_size_right", figures.nominalSizeRight}};
    const auto byStatus = [](const ReviewShare& samples, const ReviewShare& spurious) {
      return json{{"samples", samples.total}, {"matched_samples", samples.part}, {"joints", spurious.total},
                  {"spurious_joints", spurious.part}};
    };
    out["accepted"] = byStatus(figures.acceptedSamples, figures.spuriousAccepted);
    out["proposed"] = byStatus(figures.proposedSamples, figures.spuriousProposed);
    if (figures.observableMeasured) {
      out["observable_share"] = figures.observableShare;
      out["recall_observable"] = figures.recallObservable;
      out["observable_elbows_truth"] = figures.observableElbows;
      out["observable_elbows_found"] = figures.foundObservableElbows;
      out["observable_tees_truth"] = figures.observableTees;
      out["observable_tees_found"] = figures.foundObservableTees;
      out["corner_seen_elbows_truth"] = figures.cornerSeenElbows;
      out["corner_seen_elbows_found"] = figures.foundCornerSeenElbows;
      out["corner_seen_tees_truth"] = figures.cornerSeenTees;
      out["corner_seen_tees_found"] = figures.foundCornerSeenTees;
      const auto misses = [](const MissCounts& missed) {
        return json{{"unseen", missed.unseen}, {"pipe_not_found", missed.pipeNotFound}, {"not_joined", missed.notJoined}};
      };
      out["missed_elbows"] = misses(figures.missedElbows);
      out["missed_tees"] = misses(figures.missedTees);
    }
    if (options.joints) {
      const auto point = [](const Eigen::Vector3d& p) { return json::array({p.x(), p.y(), p.z()}); };
      json outcomes = json::array();
      for (const JointOutcome& outcome : figures.jointOutcomes) {
        json entry = {{"truth_id", outcome.truthId},
                      {"type", toString(outcome.type)},
                      {"position", point(outcome.position)},
                      {"found", outcome.matchedId >= 0},
                      {"pipes", outcome.pipeIds}};
        if (outcome.matchedId >= 0) {
          entry["matched_id"] = outcome.matchedId;
          entry["distance"] = outcome.distance;
        }
        if (outcome.type == JointType::Elbow) {
          entry["bend_radius_truth"] = outcome.truthBendRadius;
          if (outcome.matchedId >= 0) entry["bend_radius_found"] = outcome.predictedBendRadius;
        }
        if (!outcome.pipePoints.empty()) entry["pipe_points"] = outcome.pipePoints;
        if (!outcome.pipePointsNearCorner.empty()) {
          entry["pipe_points_near_corner"] = outcome.pipePointsNearCorner;
          entry["corner_distance"] = outcome.cornerDistance;
        }
        if (outcome.ownPoints >= 0) entry["own_points"] = outcome.ownPoints;
        if (!outcome.pipeFoundNearCorner.empty()) entry["pipe_found_near_corner"] = outcome.pipeFoundNearCorner;
        if (outcome.cause != MissCause::None) entry["miss_cause"] = toString(outcome.cause);
        outcomes.push_back(std::move(entry));
      }
      json spurious = json::array();
      for (const SpuriousJoint& joint : figures.spurious) {
        json entry = {{"id", joint.id},
                      {"type", toString(joint.type)},
                      {"status", toString(joint.status)},
                      {"confidence", joint.confidence},
                      {"position", point(joint.position)}};
        if (joint.nearestTruthId >= 0) {
          entry["nearest_truth_id"] = joint.nearestTruthId;
          entry["nearest_truth_distance"] = joint.nearestTruthDistance;
        }
        spurious.push_back(std::move(entry));
      }
      out["joints"] = std::move(outcomes);
      out["spurious"] = std::move(spurious);
    }
    std::printf("%s\n", out.dump(2).c_str());
    return kExitOk;
  }
  if (options.joints) printJointOutcomes(figures);
  std::printf("truth: %s (%zu pipes, %zu joints, %zu samples)\n", options.truth.c_str(), truth.pipes.size(),
              truth.joints.size(), figures.truthSamples);
  std::printf("result: %s (%zu pipes, %zu joints, %zu samples)\n", options.result.c_str(), result.pipes.size(),
              result.joints.size(), figures.predictedSamples);
  std::printf("%s\n", formatEvaluation(figures).c_str());
  return kExitOk;
}

int runConvert(const ConvertOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  ProgressBar bar(options.quiet);
  auto reader = openPointReader(options.input, options.units);
  unsigned attributes = reader->info().attributes;
  if (options.noNormals) attributes &= ~kNormals;
  if (options.noColors) attributes &= ~kColors;
  if (options.noIntensity) attributes &= ~kIntensity;
  if (options.noLabels) attributes &= ~kLabels;
  auto writer = openPointWriter(options.output, attributes);

  // Stream chunk by chunk: memory stays bounded whatever the file size.
  PointChunk chunk;
  std::uint64_t written = 0;
  std::uint64_t dropped = 0;
  while (reader->read(chunk, 1u << 20) > 0) {
    dropped += dropNonFinite(chunk);
    chunk.keepAttributes(attributes);
    writer->write(chunk);
    written += chunk.size();
    bar.progress().report("convert", reader->progress());
  }
  writer->close();
  bar.finish();
  if (dropped > 0) {
    warn(options.input + ": dropped " + std::to_string(dropped) + " points with NaN or infinite coordinates");
  }
  std::printf("converted: %s (%s) -> %s\n", options.input.c_str(), reader->info().format.c_str(),
              options.output.c_str());
  const std::string units = unitsRead(*reader, options.units);
  if (units != "m") std::printf("units: %s, written in metres\n", unitsNote(reader->info(), options.units, units).c_str());
  std::printf("attributes: %s\n", joinNames(attributeNames(attributes)).c_str());
  std::printf("points=%llu dropped=%llu seconds=%.2f\n", static_cast<unsigned long long>(written),
              static_cast<unsigned long long>(dropped), secondsSince(start));
  return kExitOk;
}

/// "1 pipe", "3 pipes".
std::string counted(std::size_t count, const char* one, const char* many) {
  return std::to_string(count) + " " + (count == 1 ? one : many);
}

/// Under the joints line, what the stage added to the pipes the earlier stages found, merged and
/// left out: a line for each that happened, naming only what did.
void printJointsSteps(const JointsResult::Diagnostics& d) {
  std::vector<std::string> found, merged, leftOut;
  const auto add = [](std::vector<std::string>& list, std::size_t count, const char* one, const char* many,
                      const std::string& rest) {
    if (count > 0) list.push_back(counted(count, one, many) + " " + rest);
  };
  if (d.completedPipes > 0) {
    std::vector<std::string> kinds;
    if (d.legsBetweenEnds > 0) kinds.push_back(std::to_string(d.legsBetweenEnds) + " between two ends");
    if (d.carriedLegs > 0) kinds.push_back(std::to_string(d.carriedLegs) + " carried on past the completion length");
    found.push_back(counted(d.completedPipes, "pipe", "pipes") + " completed beyond free ends" +
                    (kinds.empty() ? "" : " (" + joinNames(kinds) + ")"));
  }
  add(found, d.branchPipes, "branch", "branches", "off pipes");
  add(found, d.splitKinks, "pair", "pairs", "split at gentle bends");
  add(found, d.kinkLegs, "leg", "legs", "at gentle bends");
  add(found, d.occludedElbows, "elbow", "elbows", "across hidden corners");
  add(found, d.thinRunElbows, "elbow", "elbows", "onto pipes running on thinly");
  add(found, d.hiddenRunElbows, "elbow", "elbows", "onto pipes hardly seen");
  add(found, d.legsBetweenBends, "leg", "legs", "between seen bends");
  add(found, d.hiddenLegs, "leg", "legs", "between unseen bends");
  add(found, d.hiddenBranches, "hidden leg", "hidden legs", "from an end to a main");
  add(merged, d.piecesAtEnds, "piece", "pieces",
      d.piecesAtEnds == 1 ? "into the pipe on whose line it lay" : "into the pipes on whose lines they lay");
  add(merged, d.mergedSplitBends, "piece", "pieces",
      d.mergedSplitBends == 1 ? "fitted across a bend, with its elbows, into one elbow"
                              : "fitted across bends, with their elbows, into one elbow each");
  add(leftOut, d.unjoinedPipes, "weakly supported pipe", "weakly supported pipes", "that took no joint");
  add(leftOut, d.piecesInsidePipes, "pipe", "pipes",
      d.piecesInsidePipes == 1 ? "lying inside another pipe" : "lying inside other pipes");
  add(leftOut, d.underGround, "pipe or leg", "pipes or legs", "reaching below the ground");
  add(leftOut, d.planeResidue, "pipe", "pipes", "over a removed plane's edge");
  for (const auto& [name, list] :
       {std::pair{"found", &found}, std::pair{"merged", &merged}, std::pair{"left out", &leftOut}}) {
    if (!list->empty()) std::printf("  %s: %s\n", name, joinNames(*list).c_str());
  }
}

int runReconstruct(const ReconstructOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  std::vector<ExportTarget> exports;
  for (const auto& spec : options.exports) exports.push_back(parseExportTarget(spec));
  PipelineParams params;
  if (!options.paramsFile.empty()) params = readParams(options.paramsFile);
  for (const auto& assignment : options.assignments) setParam(params, assignment);
  if (options.seed >= 0) params.seed = static_cast<std::uint64_t>(options.seed);
  if (!options.up.empty()) params.up = upAxisFromString(options.up);
  validateParams(params);  // before reading what may be a large scan
  // Likewise every file the run writes or reads at its end.
  requireWritableFile(options.output);
  for (const auto& target : exports) requireWritableFile(target.path);
  if (!options.dumpDirectory.empty()) requireWritableFolder(options.dumpDirectory);
  std::optional<PipeNetwork> truth;
  if (!options.truth.empty()) truth = readNetworkOrProject(options.truth);
  const int threads = options.threads > 0 ? options.threads : tbb::info::default_concurrency();
  tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));

  ProgressBar bar(options.quiet);
  ReadOptions readOptions;
  readOptions.progress = &bar.progress();
  readOptions.units = options.units;
  // The pipeline reads positions alone; labels only for an evaluation over what the scan shows.
  readOptions.attributes = options.truth.empty() ? kNoAttributes : kLabels;
  ReadReport report;
  auto cloud = std::make_shared<const PointCloud>(readPointCloud(options.input, readOptions, &report));
  const double readSeconds = secondsSince(start);
  const std::size_t inputPoints = cloud->size();
  bar.finish();
  for (const auto& warning : report.warnings) warn(warning);
  // Each stage's lines are printed as soon as it has run, so that a log shows how far a long run is.
  const auto flushed = [&] {
    bar.finish();
    std::fflush(stdout);
  };
  std::printf("input: %zu points from %s, %d thread(s)  [read %.2f s]\n", inputPoints, options.input.c_str(), threads,
              readSeconds);
  if (report.units != "m") {
    std::printf("units: %s, read as metres\n", unitsNote(report.info, options.units, report.units).c_str());
  }
  if (params.up != UpAxis::PlusZ) std::printf("up: %s\n", toString(params.up).c_str());
  flushed();

  // Past the voxel grid the scan is read only by an evaluation over its labels: freed otherwise
  // (12 bytes a point, the largest part of a site scan's run).
  std::shared_ptr<const PointCloud> labelledScan;
  if (!options.truth.empty() && cloud->hasLabels()) labelledScan = cloud;
  Pipeline pipeline(std::move(cloud), params);
  if (!labelledScan) pipeline.releaseInput();
  // What the tiles keep for views (sphere samples, stripes, circle candidates) is read here only
  // by the stage dump.
  if (options.dumpDirectory.empty()) pipeline.releaseTileDetails();

  pipeline.run(bar.progress(), Stage::Preprocess);
  bar.finish();
  const PreprocessResult& prepared = *pipeline.preprocessResult();
  const auto& d = prepared.diagnostics;
  if (const auto sparse = sparseScanWarning(d.inputSpacing)) warn(options.input + ": " + *sparse);
  std::printf("preprocess: %zu after voxel grid (leaf %.1f mm), %zu outliers removed, %zu plane points in %d planes, "
              "%zu kept, %zu tiles  [%.2f s]\n",
              d.afterVoxel, d.voxelSize * 1000.0, d.outliersRemoved, d.planePoints, d.planes, d.keptPoints, prepared.tiles.size(),
              pipeline.stageSeconds(Stage::Preprocess));
  std::printf("  steps: voxel grid %.2f s, outliers %.2f s, normals %.2f s%s, planes %.2f s, tiles %.2f s\n",
              d.voxelSeconds, d.outlierSeconds, d.normalSeconds,
              d.neighborSearches == 2 ? " (a second neighbour search)" : "", d.planeSeconds, d.tileSeconds);
  flushed();

  pipeline.run(bar.progress(), Stage::Merge);
  std::size_t directions = 0, cylinders = 0, segments = 0;
  for (const auto& tile : *pipeline.tileResults()) {
    for (const auto& round : tile.rounds) {
      directions += round.directions.directions.size();
      cylinders += round.placement.cylinders.size();
      segments += round.extents.segments.size();
    }
  }
  std::printf("directions: %zu over all tiles and rounds  [%.2f s]\n", directions,
              pipeline.stageSeconds(Stage::Directions));
  std::printf("placement: %zu cylinders  [%.2f s]\n", cylinders, pipeline.stageSeconds(Stage::Placement));
  std::printf("extents: %zu pipe pieces  [%.2f s]\n", segments, pipeline.stageSeconds(Stage::Extents));
  std::printf("(per-tile stage times are summed over tiles, which run in parallel)\n");
  const auto& merged = *pipeline.mergeResult();
  std::printf("merge: %zu pipes, %zu ends moved back off crossing pipes, %zu carried on over sparse points  [%.2f s]\n",
              merged.segments.size(), merged.diagnostics.retractedEnds, merged.diagnostics.extendedEnds,
              pipeline.stageSeconds(Stage::Merge));
  flushed();

  pipeline.run(bar.progress(), stageFromName(options.until).value_or(Stage::Joints));
  const PipeNetwork network = pipeline.network();
  const auto countJoints = [&](JointType type) {
    return static_cast<std::size_t>(
        std::count_if(network.joints.begin(), network.joints.end(), [&](const Joint& j) { return j.type == type; }));
  };
  const auto accepted = static_cast<std::size_t>(std::count_if(
      network.joints.begin(), network.joints.end(), [](const Joint& j) { return j.status == JointStatus::Accepted; }));
  if (pipeline.isFresh(Stage::Joints)) {
    std::printf("joints: %s, %s, %s (%zu accepted, %zu proposed), %s  [%.2f s]\n",
                counted(countJoints(JointType::Elbow), "elbow", "elbows").c_str(),
                counted(countJoints(JointType::Tee), "tee", "tees").c_str(),
                counted(countJoints(JointType::Boundary), "boundary joint", "boundary joints").c_str(),
                accepted, network.joints.size() - accepted,
                counted(network.runs.size(), "run", "runs").c_str(), pipeline.stageSeconds(Stage::Joints));
    printJointsSteps(pipeline.jointsResult()->diagnostics);
  }
  flushed();

  NetworkMetadata metadata = {{"generator", std::string("piperun reconstruct ") + PIPERUN_VERSION},
                              {"source", options.input},
                              {"source_units", report.units},
                              {"seed", std::to_string(params.seed)}};
  recordUpAxis(metadata, params.up);
  writeNetwork(options.output, network, metadata);
  ExportOptions exportOptions;
  exportOptions.pcfBore = pcfBoreFromString(options.pcfBore).value_or(PcfBore::Nominal);
  exportOptions.up = params.up;
  if (!exports.empty()) {
    const PipeNetwork exported = options.acceptedOnly ? acceptedPart(network) : network;
    for (const auto& target : exports) exportNetwork(exported, target.format, target.path, exportOptions);
  }
  int dumped = 0;
  if (!options.dumpDirectory.empty()) dumped = dumpStages(pipeline, options.dumpDirectory);
  bar.finish();

  std::printf("network: %s\n", options.output.c_str());
  const int proposedJoints = countJointReview(network).left;
  const int proposedPipes = countPipeReview(network).left;
  if (proposedJoints + proposedPipes > 0) {
    std::printf("review: %d %s and %d %s proposed (piperun-studio %s, then N steps through them)\n", proposedJoints,
                proposedJoints == 1 ? "joint" : "joints", proposedPipes, proposedPipes == 1 ? "pipe" : "pipes",
                options.output.c_str());
  }
  for (const auto& target : exports) {
    std::printf("export: %s (%s%s)\n", target.path.c_str(), toString(target.format).c_str(),
                options.acceptedOnly ? ", accepted only" : "");
  }
  if (dumped > 0) std::printf("stages: %d files in %s\n", dumped, options.dumpDirectory.c_str());
  if (!options.truth.empty()) {
    // A labelled scan (piperun generate --labels) also gives the recall over what it shows.
    const NominalSizes sizes = NominalSizes::shipped();
    EvaluationParams params;
    params.nominalSizes = &sizes;
    const EvaluationResult figures =
        evaluateNetwork(*truth, network, params, labelledScan.get());
    std::printf("evaluation against %s: %s\n", options.truth.c_str(), formatEvaluation(figures).c_str());
  }
  std::printf("points=%zu kept=%zu directions=%zu pipes=%zu joints=%zu runs=%zu seconds=%.2f peak_mb=%.0f\n",
              inputPoints, d.keptPoints, directions, network.pipes.size(), network.joints.size(), network.runs.size(),
              secondsSince(start), peakResidentMegabytes());
  return kExitOk;
}

int runExport(const ExportCommandOptions& options) {
  // --format is checked by the parser; without it the extension decides.
  const std::optional<ExportFormat> format =
      options.format.empty() ? exportFormatFromPath(options.output) : exportFormatFromString(options.format);
  if (!format) {
    throw std::invalid_argument("cannot tell the export format from \"" + options.output +
                                "\": name a " + exportFileKinds() + " file, or give --format");
  }
  NetworkMetadata metadata;
  const PipeNetwork read = readNetworkOrProject(options.input, &metadata);
  const PipeNetwork network = options.acceptedOnly ? acceptedPart(read) : read;
  ExportOptions exportOptions;
  exportOptions.chordTolerance = options.chordTolerance;
  exportOptions.pcfBore = pcfBoreFromString(options.pcfBore).value_or(PcfBore::Nominal);
  exportOptions.up = options.up.empty() ? recordedUpAxis(metadata, options.input) : upAxisFromString(options.up);
  exportNetwork(network, *format, options.output, exportOptions);

  int pipes = 0, elbows = 0, tees = 0, boundaries = 0, leftOut = 0;
  for (const auto& pipe : network.pipes) ++(pipe.status == PipeStatus::Deleted ? leftOut : pipes);
  for (const auto& joint : network.joints) {
    if (joint.status == JointStatus::Rejected) {
      ++leftOut;
      continue;
    }
    elbows += joint.type == JointType::Elbow;
    tees += joint.type == JointType::Tee;
    boundaries += joint.type == JointType::Boundary;
  }
  std::printf("exported: %s -> %s (%s%s)\n", options.input.c_str(), options.output.c_str(), toString(*format).c_str(),
              options.acceptedOnly ? ", accepted only" : "");
  std::printf("pipes=%d elbows=%d tees=%d boundary=%d left_out=%d\n", pipes, elbows, tees, boundaries, leftOut);
  return kExitOk;
}

int runParams(const ParamsOptions& options) {
  if (options.json) {
    std::printf("%s", paramsToJson(PipelineParams{}).c_str());
    return kExitOk;
  }
  const auto descriptions = describeParams();
  if (options.markdown) {
    std::printf("| parameter | default | unit | range | meaning |\n| --- | --- | --- | --- | --- |\n");
    for (const auto& p : descriptions) {
      std::printf("| `%s` | %s | %s | %s | %s |\n", p.key.c_str(), p.defaultValue.c_str(), p.unit.c_str(),
                  p.range.c_str(), p.description.c_str());
    }
    return kExitOk;
  }
  std::size_t width = 0;
  for (const auto& p : descriptions) width = std::max(width, p.key.size() + p.defaultValue.size() + 3);
  for (const auto& p : descriptions) {
    const std::string head = p.key + " = " + p.defaultValue;
    std::string suffix = p.unit.empty() ? "" : " [" + p.unit + "]";
    if (!p.range.empty()) suffix += (p.range[0] == '>' ? "  (" : "  (in ") + p.range + ")";
    std::printf("%-*s  %s%s\n", static_cast<int>(width), head.c_str(), p.description.c_str(), suffix.c_str());
  }
  return kExitOk;
}

}  // namespace piperun::cli
