#include "piperun/ui/document.h"

#include "piperun/io/point_reader.h"

#include <algorithm>
#include <cctype>

namespace piperun::ui {

namespace {

bool isNetworkFile(const std::filesystem::path& path) {
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension == ".json";
}

}  // namespace

Document Document::open(const std::filesystem::path& path, Progress& progress) {
  if (isNetworkFile(path)) return fromNetwork(readNetwork(path), path);
  ReadOptions options;
  options.progress = &progress;
  auto cloud = std::make_shared<PointCloud>(readPointCloud(path, options));
  return fromScan(std::move(cloud), path);
}

Document Document::fromScan(std::shared_ptr<const PointCloud> cloud, const std::filesystem::path& path) {
  Document document;
  document.path_ = path;
  document.input_ = cloud;
  document.pipeline_ = std::make_shared<Pipeline>(std::move(cloud));
  return document;
}

Document Document::fromNetwork(PipeNetwork network, const std::filesystem::path& path) {
  Document document;
  document.path_ = path;
  document.network_ = std::move(network);
  return document;
}

void Document::refreshNetwork() {
  if (pipeline_) network_ = pipeline_->network();
}

}  // namespace piperun::ui
