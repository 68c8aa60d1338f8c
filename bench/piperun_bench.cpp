// piperun-bench: speed, memory and accuracy of PipeRun against a PCL RANSAC baseline on generated
// scenes (issue 3).
//
// Every (preset, seed, method) measurement runs in a child process: this program re-executed with
// --worker. The child generates the scene in memory, drops the truth labels, resets the kernel's
// peak-RSS mark (/proc/self/clear_refs), runs one method and reports VmHWM from /proc/self/status,
// so one method's peak is never inflated by the other or by the generator. The child prints one
// JSON line; the parent tabulates.

#include "pcl_baseline.h"

#include "piperun/eval/evaluation.h"
#include "piperun/io/network_io.h"
#include "piperun/pipeline.h"
#include "piperun/synth/scene_generator.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include <malloc.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

extern char** environ;

namespace piperun::bench {
namespace {

using nlohmann::json;

constexpr double kMegabyte = 1024.0 * 1024.0;

struct SceneOptions {
  double noise = 0.002;
  double outliers = 0.01;
};

struct Measurement {
  std::string preset;
  std::uint64_t seed = 0;
  std::string method;  ///< "ours" or "pcl".
  int threads = 0;
  SceneOptions scene;
  bool pclRemovePlanes = true;
  std::string networkDir;  ///< When set, the predicted and truth networks are written here.
};

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/// User + system CPU time of this process and its threads so far. On a machine shared with other
/// jobs it moves far less than wall time.
double cpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const auto seconds = [](const timeval& t) { return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec); };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

/// A "VmHWM:"-style field of /proc/self/status, in bytes.
double statusBytes(const std::string& field) {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind(field + ":", 0) == 0) return 1024.0 * std::stod(line.substr(field.size() + 1));
  }
  throw std::runtime_error("/proc/self/status has no " + field);
}

/// Lowers the peak-RSS mark to the current RSS (Linux ≥ 4.0); false when the kernel refuses.
bool resetPeakMemory() {
  std::ofstream clearRefs("/proc/self/clear_refs");
  clearRefs << "5";
  clearRefs.flush();
  return static_cast<bool>(clearRefs);
}

// ---------------------------------------------------------------------------------------------
// The child: one method on one scene.

json runMeasurement(const Measurement& request) {
  std::optional<tbb::global_control> threadLimit;
  if (request.threads > 0) {
    threadLimit.emplace(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(request.threads));
  }
  SceneParams sceneParams;
  sceneParams.preset = scenePresetFromString(request.preset);
  sceneParams.seed = request.seed;
  sceneParams.noiseSigma = request.scene.noise;
  sceneParams.outlierFraction = request.scene.outliers;
  const auto generateStart = std::chrono::steady_clock::now();
  GeneratedScene scene = generateScene(sceneParams);
  const double generateSeconds = secondsSince(generateStart);
  // The labels are the answer; neither method may see them.
  std::vector<std::int32_t>().swap(scene.cloud.labels);
  const auto points = static_cast<double>(scene.cloud.size());

  malloc_trim(0);  // Hand the generator's freed chunks back so they do not count as resident.
  const bool peakReset = resetPeakMemory();
  const double residentBefore = statusBytes("VmRSS");

  PipeNetwork network;
  json stages = json::array();
  json diagnostics = json::object();
  const double cpuStart = cpuSeconds();
  const auto start = std::chrono::steady_clock::now();
  if (request.method == "ours") {
    Pipeline pipeline(std::make_shared<const PointCloud>(std::move(scene.cloud)));
    pipeline.run();
    network = pipeline.network();
    for (Stage stage : kAllStages) stages.push_back({{"name", stageName(stage)}, {"seconds", pipeline.stageSeconds(stage)}});
  } else if (request.method == "pcl") {
    PclBaselineParams params;
    params.threads = request.threads;
    params.removePlanes = request.pclRemovePlanes;
    const PclBaselineResult result = runPclBaseline(scene.cloud, params);
    network = result.network;
    const auto& d = result.diagnostics;
    for (const auto& [name, seconds] : {std::pair{"convert", d.convertSeconds}, {"voxel", d.voxelSeconds},
                                        {"normals", d.normalSeconds}, {"planes", d.planeSeconds},
                                        {"clusters", d.clusterSeconds}, {"cylinders", d.cylinderSeconds}}) {
      stages.push_back({{"name", name}, {"seconds", seconds}});
    }
    diagnostics = {{"after_voxel", d.afterVoxel}, {"planes", d.planes},     {"plane_points", d.planePoints},
                   {"clusters", d.clusters},      {"cylinders", d.cylinders}};
  } else {
    throw std::invalid_argument("unknown method '" + request.method + "', expected ours or pcl");
  }
  const double seconds = secondsSince(start);
  const double cpu = cpuSeconds() - cpuStart;
  const double peak = statusBytes("VmHWM");

  const EvaluationResult evaluation = evaluateNetwork(scene.truth, network);
  if (!request.networkDir.empty()) {
    const std::filesystem::path stem =
        std::filesystem::path(request.networkDir) / (request.preset + "-" + std::to_string(request.seed));
    writeNetwork(stem.string() + "-" + request.method + ".json", network);
    writeNetwork(stem.string() + "-truth.json", scene.truth);
  }
  return {{"preset", request.preset},
          {"seed", request.seed},
          {"method", request.method},
          {"threads", tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)},
          {"noise", request.scene.noise},
          {"outliers", request.scene.outliers},
          {"points", scene.summary.points},
          {"generate_seconds", generateSeconds},
          {"seconds", seconds},
          {"points_per_second", points / seconds},
          {"cpu_seconds", cpu},
          {"stages", stages},
          {"diagnostics", diagnostics},
          {"peak_mb", peak / kMegabyte},
          {"resident_before_mb", residentBefore / kMegabyte},
          {"peak_bytes_per_point", peak / points},
          {"working_bytes_per_point", (peak - residentBefore) / points},
          {"peak_reset", peakReset},
          {"pipes", network.pipes.size()},
          {"truth_pipes", scene.truth.pipes.size()},
          {"f1", evaluation.f1},
          {"precision", evaluation.precision},
          {"recall", evaluation.recall},
          {"radius_error_mm", 1000.0 * evaluation.radiusErrorMedian}};
}

// ---------------------------------------------------------------------------------------------
// The parent: spawns one child per measurement and tabulates.

/// Runs this executable with --worker for `request`; the child's last stdout line is its JSON.
json measureInChild(const char* argv0, const Measurement& request) {
  std::vector<std::string> arguments = {argv0,           "--worker",
                                        "--preset",      request.preset,
                                        "--seed",        std::to_string(request.seed),
                                        "--method",      request.method,
                                        "--threads",     std::to_string(request.threads),
                                        "--noise",       std::to_string(request.scene.noise),
                                        "--outliers",    std::to_string(request.scene.outliers)};
  if (!request.pclRemovePlanes) arguments.emplace_back("--pcl-keep-planes");
  if (!request.networkDir.empty()) arguments.insert(arguments.end(), {"--save-networks", request.networkDir});
  std::vector<char*> argv;
  for (auto& argument : arguments) argv.push_back(argument.data());
  argv.push_back(nullptr);

  int output[2];
  if (pipe(output) != 0) throw std::runtime_error("cannot create a pipe to the worker");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, output[1], STDOUT_FILENO);
  posix_spawn_file_actions_addclose(&actions, output[0]);
  pid_t child = 0;
  const int spawnError = posix_spawn(&child, "/proc/self/exe", &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(output[1]);
  if (spawnError != 0) {
    close(output[0]);
    throw std::runtime_error("cannot start the worker process");
  }
  std::string text;
  char buffer[4096];
  for (ssize_t n; (n = read(output[0], buffer, sizeof buffer)) > 0;) text.append(buffer, static_cast<std::size_t>(n));
  close(output[0]);
  int status = 0;
  waitpid(child, &status, 0);

  std::string lastLine;
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    if (!line.empty()) lastLine = line;
  }
  json row = {{"preset", request.preset}, {"seed", request.seed}, {"method", request.method}};
  const json reported = json::parse(lastLine, nullptr, /*allow_exceptions=*/false);
  if (reported.is_object()) row.update(reported);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    if (!row.contains("error")) {
      row["error"] = WIFSIGNALED(status) ? "worker killed by signal " + std::to_string(WTERMSIG(status))
                                         : "worker exited with status " + std::to_string(WEXITSTATUS(status));
    }
  }
  return row;
}

void printTableHeader() {
  std::printf("%-7s %5s %-5s %9s %8s %8s %10s %8s %6s %6s %6s %6s %6s %8s %8s\n", "preset", "seed", "meth", "points",
              "seconds", "cpu_s", "points/s", "MB_peak", "B/pt", "+B/pt", "F1", "prec", "recall", "r_err_mm",
              "speedup");
}

void printRow(const json& row, std::optional<double> speedup) {
  if (row.contains("error")) {
    std::printf("%-7s %5s %-5s  failed: %s\n", row["preset"].get<std::string>().c_str(),
                std::to_string(row["seed"].get<std::uint64_t>()).c_str(), row["method"].get<std::string>().c_str(),
                row["error"].get<std::string>().c_str());
    return;
  }
  std::printf("%-7s %5llu %-5s %9llu %8.2f %8.2f %10.0f %8.0f %6.0f %6.0f %6.3f %6.3f %6.3f %8.2f ",
              row["preset"].get<std::string>().c_str(), static_cast<unsigned long long>(row["seed"].get<std::uint64_t>()),
              row["method"].get<std::string>().c_str(), static_cast<unsigned long long>(row["points"].get<std::uint64_t>()),
              row["seconds"].get<double>(), row["cpu_seconds"].get<double>(), row["points_per_second"].get<double>(),
              row["peak_mb"].get<double>(),
              row["peak_bytes_per_point"].get<double>(), row["working_bytes_per_point"].get<double>(),
              row["f1"].get<double>(), row["precision"].get<double>(), row["recall"].get<double>(),
              row["radius_error_mm"].get<double>());
  if (speedup) {
    std::printf("%7.1fx\n", *speedup);
  } else {
    std::printf("%8s\n", "-");
  }
  std::printf("%21s", "stages:");
  for (const auto& stage : row["stages"]) {
    std::printf(" %s %.2f", stage["name"].get<std::string>().c_str(), stage["seconds"].get<double>());
  }
  std::printf("  (pipes %zu, truth %zu)\n", row["pipes"].get<std::size_t>(), row["truth_pipes"].get<std::size_t>());
  std::fflush(stdout);
}

bool succeeded(const json& row) { return !row.contains("error"); }

double mean(const std::vector<json>& rows, const char* key) {
  double sum = 0.0;
  for (const auto& row : rows) sum += row[key].get<double>();
  return sum / static_cast<double>(rows.size());
}

/// "1", "1-10", "1,3,7-9".
std::vector<std::uint64_t> parseSeeds(const std::string& text) {
  std::vector<std::uint64_t> seeds;
  std::istringstream items(text);
  for (std::string item; std::getline(items, item, ',');) {
    const auto dash = item.find('-');
    try {
      const std::uint64_t first = std::stoull(item.substr(0, dash));
      const std::uint64_t last = dash == std::string::npos ? first : std::stoull(item.substr(dash + 1));
      if (last < first) throw std::invalid_argument(item);
      for (std::uint64_t seed = first; seed <= last; ++seed) seeds.push_back(seed);
    } catch (const std::logic_error&) {
      throw CLI::ValidationError("--seeds", "'" + item + "' is not a seed or a range like 1-10");
    }
  }
  if (seeds.empty()) throw CLI::ValidationError("--seeds", "no seed given");
  return seeds;
}

/// The run of median wall time (of an even count, the faster of the middle two).
json medianRun(std::vector<json> rows) {
  const auto middle = rows.begin() + static_cast<std::ptrdiff_t>((rows.size() - 1) / 2);
  std::nth_element(rows.begin(), middle, rows.end(), [](const json& a, const json& b) {
    return a["seconds"].get<double>() < b["seconds"].get<double>();
  });
  return *middle;
}

std::vector<std::string> parsePresets(const std::string& text) {
  std::vector<std::string> presets;
  std::istringstream items(text);
  for (std::string item; std::getline(items, item, ',');) {
    try {
      presets.push_back(toString(scenePresetFromString(item)));
    } catch (const std::invalid_argument& error) {
      throw CLI::ValidationError("--presets", error.what());
    }
  }
  return presets;
}

struct BenchOptions {
  std::string presets = "small,medium";
  std::string seeds = "1";
  int repeat = 1;
  bool baseline = false;
  bool scaling = false;
  int threads = 0;
  std::string jsonPath;
  SceneOptions scene;
  bool pclRemovePlanes = true;
  std::string networkDir;

  Measurement request(std::string preset, std::uint64_t seed, std::string method) const {
    return {std::move(preset), seed, std::move(method), threads, scene, pclRemovePlanes, networkDir};
  }
};

json runComparison(const char* argv0, const BenchOptions& options) {
  const auto presets = parsePresets(options.presets);
  const auto seeds = parseSeeds(options.seeds);
  json runs = json::array();
  json summaries = json::array();
  std::vector<std::string> summaryLines;
  printTableHeader();
  for (const auto& preset : presets) {
    std::vector<json> ours, pcl;  // per seed: its median run (by wall time) of each method
    for (const auto seed : seeds) {
      // The two methods alternate, so that a machine slowing down or speeding up over the runs
      // weighs on both alike; each seed counts with the median of its runs.
      std::vector<json> ourRuns, pclRuns;
      for (int repetition = 0; repetition < options.repeat; ++repetition) {
        const json ourRow = measureInChild(argv0, options.request(preset, seed, "ours"));
        std::optional<json> pclRow;
        if (options.baseline) pclRow = measureInChild(argv0, options.request(preset, seed, "pcl"));
        std::optional<double> speedup;
        if (pclRow && succeeded(*pclRow) && succeeded(ourRow)) {
          speedup = (*pclRow)["seconds"].get<double>() / ourRow["seconds"].get<double>();
        }
        printRow(ourRow, speedup);
        runs.push_back(ourRow);
        if (succeeded(ourRow)) ourRuns.push_back(ourRow);
        if (pclRow) {
          printRow(*pclRow, std::nullopt);
          runs.push_back(*pclRow);
          if (succeeded(*pclRow)) pclRuns.push_back(*pclRow);
        }
      }
      if (!ourRuns.empty()) ours.push_back(medianRun(std::move(ourRuns)));
      if (!pclRuns.empty()) pcl.push_back(medianRun(std::move(pclRuns)));
    }
    if (ours.empty()) continue;
    json summary = {{"preset", preset},
                    {"seeds", ours.size()},
                    {"points", mean(ours, "points")},
                    {"ours_s", mean(ours, "seconds")},
                    {"ours_cpu_s", mean(ours, "cpu_seconds")},
                    {"ours_f1", mean(ours, "f1")},
                    {"ours_peak_mb", mean(ours, "peak_mb")}};
    char line[512];
    int length = std::snprintf(line, sizeof line, "preset=%s points=%.0f ours_s=%.2f", preset.c_str(),
                               summary["points"].get<double>(), summary["ours_s"].get<double>());
    if (!pcl.empty()) {
      summary["pcl_s"] = mean(pcl, "seconds");
      summary["pcl_cpu_s"] = mean(pcl, "cpu_seconds");
      summary["pcl_f1"] = mean(pcl, "f1");
      summary["pcl_peak_mb"] = mean(pcl, "peak_mb");
      summary["speedup"] = summary["pcl_s"].get<double>() / summary["ours_s"].get<double>();
      length += std::snprintf(line + length, sizeof line - static_cast<std::size_t>(length),
                              " pcl_s=%.2f speedup=%.1f", summary["pcl_s"].get<double>(),
                              summary["speedup"].get<double>());
    }
    length += std::snprintf(line + length, sizeof line - static_cast<std::size_t>(length), " ours_f1=%.3f",
                            summary["ours_f1"].get<double>());
    if (!pcl.empty()) {
      std::snprintf(line + length, sizeof line - static_cast<std::size_t>(length), " pcl_f1=%.3f",
                    summary["pcl_f1"].get<double>());
    }
    summaryLines.emplace_back(line);
    summaries.push_back(summary);
  }
  std::printf("\n");
  for (const auto& line : summaryLines) std::printf("%s\n", line.c_str());
  return {{"runs", runs}, {"summary", summaries}};
}

/// PipeRun alone on small, medium and large: time per point should stay flat if the pipeline is linear.
json runScaling(const char* argv0, const BenchOptions& options) {
  const std::uint64_t seed = parseSeeds(options.seeds).front();
  json rows = json::array();
  std::optional<double> smallTimePerPoint;
  std::printf("%-7s %5s %10s %8s %10s %8s %12s\n", "preset", "seed", "points", "seconds", "us/point", "MB_peak",
              "vs_small");
  for (const char* preset : {"small", "medium", "large"}) {
    const json row = measureInChild(argv0, options.request(preset, seed, "ours"));
    rows.push_back(row);
    if (!succeeded(row)) {
      std::printf("%-7s %5llu  failed: %s\n", preset, static_cast<unsigned long long>(seed),
                  row["error"].get<std::string>().c_str());
      continue;
    }
    const double timePerPoint = row["seconds"].get<double>() / row["points"].get<double>();
    if (!smallTimePerPoint && std::string(preset) == "small") smallTimePerPoint = timePerPoint;
    std::printf("%-7s %5llu %10llu %8.2f %10.3f %8.0f", preset, static_cast<unsigned long long>(seed),
                static_cast<unsigned long long>(row["points"].get<std::uint64_t>()), row["seconds"].get<double>(),
                1e6 * timePerPoint, row["peak_mb"].get<double>());
    if (smallTimePerPoint) {
      std::printf(" %11.2fx\n", timePerPoint / *smallTimePerPoint);
    } else {
      std::printf(" %12s\n", "-");
    }
    std::fflush(stdout);
  }
  return {{"scaling", rows}};
}

int run(int argc, char** argv) {
  CLI::App app{"Speed, memory and accuracy of PipeRun against a PCL RANSAC baseline on generated scenes"};
  BenchOptions options;
  app.add_option("--presets", options.presets, "Comma-separated scene presets: small, medium, large")
      ->capture_default_str();
  app.add_option("--seeds", options.seeds, "Scene seeds: 1, 1-10 or 1,4,7")->capture_default_str();
  app.add_option("--repeat", options.repeat,
                 "Runs of each method per scene, alternating; the summary takes each scene's median run")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_flag("--baseline", options.baseline, "Also run the PCL RANSAC baseline on every scene");
  app.add_flag("--scaling", options.scaling, "Run PipeRun alone on small, medium and large (first seed)");
  app.add_option("--threads", options.threads, "Worker threads (0: all cores)")->check(CLI::NonNegativeNumber);
  app.add_option("--json", options.jsonPath, "Write every measurement to this JSON file");
  app.add_option("--noise", options.scene.noise, "Scene noise sigma (m)")->capture_default_str();
  app.add_option("--outliers", options.scene.outliers, "Scene outlier share")->capture_default_str();
  app.add_option("--save-networks", options.networkDir,
                 "Write each network as <preset>-<seed>-<method>.json, and the truth, into this existing folder")
      ->check(CLI::ExistingDirectory);
  bool keepPlanes = false;
  app.add_flag("--pcl-keep-planes", keepPlanes, "Baseline: skip the RANSAC plane removal before clustering");

  // One measurement in this process, one JSON line on stdout (what the parent spawns; also handy
  // under a profiler).
  bool worker = false;
  Measurement request;
  app.add_flag("--worker", worker, "Run one measurement in this process and print it as JSON");
  app.add_option("--preset", request.preset, "Worker: scene preset");
  app.add_option("--seed", request.seed, "Worker: scene seed");
  app.add_option("--method", request.method, "Worker: ours or pcl")->check(CLI::IsMember({"ours", "pcl"}));
  CLI11_PARSE(app, argc, argv);
  options.pclRemovePlanes = !keepPlanes;

  if (worker) {
    request = options.request(request.preset, request.seed, request.method);
    try {
      std::printf("%s\n", runMeasurement(request).dump().c_str());
      return 0;
    } catch (const std::exception& error) {
      std::printf("%s\n", json{{"error", error.what()}}.dump().c_str());
      return 1;
    }
  }

  json results = options.scaling ? runScaling(argv[0], options) : runComparison(argv[0], options);
  if (!options.jsonPath.empty()) {
    std::ofstream file(options.jsonPath);
    file << results.dump(2) << "\n";
    if (!file) {
      std::fprintf(stderr, "cannot write %s\n", options.jsonPath.c_str());
      return 2;
    }
  }
  return 0;
}

}  // namespace
}  // namespace piperun::bench

int main(int argc, char** argv) {
  try {
    return piperun::bench::run(argc, argv);
  } catch (const CLI::ValidationError& error) {
    std::fprintf(stderr, "%s\n", error.what());
    return 1;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "piperun-bench: %s\n", error.what());
    return 3;
  }
}
