#pragma once
// What the studio shows: a project under review — a scan with its reconstruction pipeline, a pipe
// network read from a file, or a saved `.piperun` project. No VTK here: the document is plain core
// data; ui/src turns it into layers.

#include "piperun/edit/project.h"
#include "piperun/io/network_io.h"
#include "piperun/pipe_network.h"
#include "piperun/pipeline.h"
#include "piperun/point_cloud.h"
#include "piperun/progress.h"

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace piperun::ui {

class Document {
 public:
  /// An empty document (nothing open).
  Document() = default;

  /// Opens a scan (any point format core reads) whose coordinates are in `scanUnits`
  /// (lengthUnitNames(); empty: the unit the file declares, else metres), a network (.json) or a
  /// project (.piperun, whose scan is read in the unit it records). A scan or network has `up` as
  /// its up direction (the parameter up; none given: the one a network records, else z); a project
  /// keeps its own. Throws InputError.
  static Document open(const std::filesystem::path& path, Progress& progress = Progress::none(),
                       const std::string& scanUnits = "", std::optional<UpAxis> up = std::nullopt);
  /// `cloud`, read from `path` in `scanUnits`, with a new pipeline whose up direction is `up`.
  static Document fromScan(std::shared_ptr<const PointCloud> cloud, const std::filesystem::path& path,
                           const std::string& scanUnits = "m", UpAxis up = UpAxis::PlusZ);
  static Document fromNetwork(PipeNetwork network, const std::filesystem::path& path, UpAxis up = UpAxis::PlusZ);
  /// A project as openProject() gave it; its scan is read when it is there (else the network
  /// opens alone, with a warning). `path` is the file it came from.
  static Document fromProject(OpenedProject opened, const std::filesystem::path& path,
                              Progress& progress = Progress::none());

  /// The file opened (a scan, network or project).
  const std::filesystem::path& path() const { return path_; }
  bool empty() const { return !input_ && network().pipes.empty() && network().joints.empty(); }
  bool hasPipeline() const { return pipeline_ != nullptr; }

  /// The scan (null without one).
  std::shared_ptr<const PointCloud> input() const { return input_; }
  /// The pipeline of a document with a scan (null otherwise). Not thread-safe: while a background
  /// run uses it, only that thread may touch it.
  Pipeline* pipeline() { return pipeline_.get(); }
  const Pipeline* pipeline() const { return pipeline_.get(); }

  /// The review: parameters, stage freshness, the edited network and its history.
  Project& project() { return project_; }
  const Project& project() const { return project_; }
  /// The network shown: the reviewed (edited) one, world coordinates.
  const PipeNetwork& network() const { return project_.edits.network(); }

  /// What opening reported (a changed or missing scan, a dropped history, points dropped in reading,
  /// a scan too sparse for its unit), one line each.
  const std::vector<std::string>& warnings() const { return warnings_; }
  /// An autosave of the project newer than its file, to offer for recovery.
  const std::optional<std::filesystem::path>& newerAutosave() const { return newerAutosave_; }
  /// For a project with its scan: the last stage that was fresh when it was saved. Running the
  /// pipeline up to it recomputes the stages' views (same scan, parameters and seed); the reviewed
  /// network stays as saved.
  std::optional<Stage> freshThrough() const;

 private:
  std::filesystem::path path_;
  std::shared_ptr<const PointCloud> input_;
  std::shared_ptr<Pipeline> pipeline_;
  Project project_;
  std::vector<std::string> warnings_;
  std::optional<std::filesystem::path> newerAutosave_;
};

}  // namespace piperun::ui
