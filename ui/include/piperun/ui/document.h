#pragma once
// What the studio shows: a scan with its reconstruction pipeline, or a pipe network read from a file.
// No VTK here: the document is plain core data; ui/src turns it into layers.

#include "piperun/io/network_io.h"
#include "piperun/pipe_network.h"
#include "piperun/pipeline.h"
#include "piperun/point_cloud.h"
#include "piperun/progress.h"

#include <filesystem>
#include <memory>

namespace piperun::ui {

class Document {
 public:
  /// An empty document (nothing open).
  Document() = default;

  /// Opens a scan (any point format core reads) or a network (.json). Throws InputError.
  static Document open(const std::filesystem::path& path, Progress& progress = Progress::none());
  static Document fromScan(std::shared_ptr<const PointCloud> cloud, const std::filesystem::path& path);
  static Document fromNetwork(PipeNetwork network, const std::filesystem::path& path);

  const std::filesystem::path& path() const { return path_; }
  bool empty() const { return !input_ && network_.pipes.empty() && network_.joints.empty(); }
  bool hasPipeline() const { return pipeline_ != nullptr; }

  /// The scan (null for a network document).
  std::shared_ptr<const PointCloud> input() const { return input_; }
  /// The pipeline of a scan document (null for a network document). Not thread-safe: while a
  /// background run uses it, only that thread may touch it.
  Pipeline* pipeline() { return pipeline_.get(); }
  const Pipeline* pipeline() const { return pipeline_.get(); }

  /// The network shown: read from the file, or the pipeline's latest (world coordinates).
  const PipeNetwork& network() const { return network_; }
  PipeNetwork& network() { return network_; }
  /// Takes the pipeline's network after a run (review edits of the previous one are replaced).
  void refreshNetwork();

 private:
  std::filesystem::path path_;
  std::shared_ptr<const PointCloud> input_;
  std::shared_ptr<Pipeline> pipeline_;
  PipeNetwork network_;
};

}  // namespace piperun::ui
