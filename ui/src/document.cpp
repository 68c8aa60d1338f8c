#include "piperun/ui/document.h"

#include "piperun/error.h"
#include "piperun/io/point_reader.h"
#include "piperun/spacing.h"

namespace piperun::ui {

namespace {

/// The studio's pipeline: its tiles drop their sphere samples and circle candidates, which the
/// views make again for the one tile they show (most of a site scan's per-tile results).
std::shared_ptr<Pipeline> studioPipeline(std::shared_ptr<const PointCloud> cloud, const PipelineParams& params) {
  auto pipeline = std::make_shared<Pipeline>(std::move(cloud), params);
  pipeline->releaseTileDetails(TileDetails::ViewSamples);
  return pipeline;
}

/// Reads the scan at `path` in `units` (empty: the file's own, else metres) and sets `units` to the
/// unit read; what reading reported, and a spacing that says the unit is wrong, go to `warnings`.
std::shared_ptr<const PointCloud> readScan(const std::filesystem::path& path, std::string& units, Progress& progress,
                                           std::vector<std::string>& warnings) {
  if (!units.empty() && !metresPerUnit(units)) throw InputError(path, "", "unknown length unit \"" + units + "\"");
  ReadOptions options;
  options.progress = &progress;
  options.units = units;
  ReadReport report;
  auto cloud = std::make_shared<PointCloud>(readPointCloud(path, options, &report));
  units = report.units;
  warnings.insert(warnings.end(), report.warnings.begin(), report.warnings.end());
  if (const auto sparse = sparseScanWarning(estimatePointSpacing(*cloud))) warnings.push_back(path.string() + ": " + *sparse);
  return cloud;
}

}  // namespace

Document Document::open(const std::filesystem::path& path, Progress& progress, const std::string& scanUnits,
                        std::optional<UpAxis> up) {
  if (isProjectFile(path)) return fromProject(openProject(path), path, progress);
  if (isNetworkFile(path)) {
    NetworkMetadata metadata;
    PipeNetwork network = readNetwork(path, &metadata);
    const UpAxis recorded = recordedUpAxis(metadata, path);
    return fromNetwork(std::move(network), path, up.value_or(recorded));
  }
  std::vector<std::string> warnings;
  std::string units = scanUnits;
  auto cloud = readScan(path, units, progress, warnings);
  Document document = fromScan(std::move(cloud), path, units, up.value_or(UpAxis::PlusZ));
  document.warnings_ = std::move(warnings);
  return document;
}

Document Document::fromScan(std::shared_ptr<const PointCloud> cloud, const std::filesystem::path& path,
                            const std::string& scanUnits, UpAxis up) {
  Document document;
  document.path_ = path;
  document.input_ = cloud;
  PipelineParams params;
  params.up = up;
  document.pipeline_ = studioPipeline(std::move(cloud), params);
  document.project_ = newProject(path, *document.pipeline_, scanUnits);
  return document;
}

Document Document::fromNetwork(PipeNetwork network, const std::filesystem::path& path, UpAxis up) {
  Document document;
  document.path_ = path;
  document.project_.params.up = up;
  document.project_.edits = EditSession(std::move(network));
  return document;
}

Document Document::fromProject(OpenedProject opened, const std::filesystem::path& path, Progress& progress) {
  Document document;
  document.path_ = path;
  document.project_ = std::move(opened.project);
  document.warnings_ = std::move(opened.warnings);
  document.newerAutosave_ = std::move(opened.newerAutosave);
  const std::filesystem::path& scan = document.project_.scanPath;
  std::error_code error;
  if (!scan.empty() && std::filesystem::is_regular_file(scan, error)) {
    document.input_ = readScan(scan, document.project_.scanUnits, progress, document.warnings_);
    document.pipeline_ = studioPipeline(document.input_, document.project_.params);
  }
  return document;
}

std::optional<Stage> Document::freshThrough() const {
  if (!pipeline_) return std::nullopt;
  std::optional<Stage> last;
  for (Stage stage : kAllStages) {
    if (!project_.freshStages[static_cast<std::size_t>(stage)]) break;
    last = stage;
  }
  return last;
}

}  // namespace piperun::ui
