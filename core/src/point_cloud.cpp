#include "piperun/point_cloud.h"

#include "bounds.h"

#include <stdexcept>
#include <string>

namespace piperun {

namespace {
template <class T>
void checkLength(const std::vector<T>& array, std::size_t n, const char* name) {
  if (!array.empty() && array.size() != n) {
    throw std::logic_error(std::string("point attribute '") + name + "' has " + std::to_string(array.size()) +
                           " values for " + std::to_string(n) + " points");
  }
}

template <class T>
std::size_t capacityBytes(const std::vector<T>& array) {
  return array.capacity() * sizeof(T);
}
}  // namespace

unsigned PointChunk::attributes() const {
  unsigned bits = kNoAttributes;
  if (!normals.empty()) bits |= kNormals;
  if (!colors.empty()) bits |= kColors;
  if (!intensities.empty()) bits |= kIntensity;
  if (!labels.empty()) bits |= kLabels;
  return bits;
}

void PointChunk::clear() {
  positions.clear();
  normals.clear();
  colors.clear();
  intensities.clear();
  labels.clear();
}

void PointChunk::keepAttributes(unsigned kept) {
  if (!(kept & kNormals)) normals.clear();
  if (!(kept & kColors)) colors.clear();
  if (!(kept & kIntensity)) intensities.clear();
  if (!(kept & kLabels)) labels.clear();
}

void PointChunk::checkConsistent() const {
  const std::size_t n = positions.size();
  checkLength(normals, n, "normals");
  checkLength(colors, n, "colors");
  checkLength(intensities, n, "intensity");
  checkLength(labels, n, "labels");
}

PointCloud PointCloud::clone() const {
  PointCloud copy;
  copy.origin = origin;
  copy.positions = positions;
  copy.normals = normals;
  copy.colors = colors;
  copy.intensities = intensities;
  copy.labels = labels;
  return copy;
}

unsigned PointCloud::attributes() const {
  unsigned bits = kNoAttributes;
  if (hasNormals()) bits |= kNormals;
  if (hasColors()) bits |= kColors;
  if (hasIntensity()) bits |= kIntensity;
  if (hasLabels()) bits |= kLabels;
  return bits;
}

BoundingBox PointCloud::boundingBox() const {
  const BoundingBox offsets = finiteBounds(positions).box;
  if (offsets.empty()) return {};
  BoundingBox box;
  box.extend(origin + offsets.min);
  box.extend(origin + offsets.max);
  return box;
}

void PointCloud::append(const PointChunk& chunk) {
  chunk.checkConsistent();
  if (chunk.empty()) return;
  if (!empty() && chunk.attributes() != attributes()) {
    throw std::logic_error("appended points carry other attributes than the cloud");
  }
  const std::size_t n = chunk.size();
  positions.reserve(positions.size() + n);
  for (const auto& p : chunk.positions) positions.push_back((p - origin).cast<float>());
  normals.insert(normals.end(), chunk.normals.begin(), chunk.normals.end());
  colors.insert(colors.end(), chunk.colors.begin(), chunk.colors.end());
  intensities.insert(intensities.end(), chunk.intensities.begin(), chunk.intensities.end());
  labels.insert(labels.end(), chunk.labels.begin(), chunk.labels.end());
}

void PointCloud::copyTo(PointChunk& chunk, std::size_t first, std::size_t count) const {
  if (first > size() || count > size() - first) throw std::out_of_range("PointCloud::copyTo range");
  chunk.clear();
  const std::size_t last = first + count;
  chunk.positions.reserve(count);
  for (std::size_t i = first; i < last; ++i) chunk.positions.push_back(worldPosition(i));
  const auto slice = [first, last](const auto& source, auto& target) {
    if (!source.empty()) target.assign(source.begin() + first, source.begin() + last);
  };
  slice(normals, chunk.normals);
  slice(colors, chunk.colors);
  slice(intensities, chunk.intensities);
  slice(labels, chunk.labels);
}

std::size_t PointCloud::memoryBytes() const {
  return capacityBytes(positions) + capacityBytes(normals) + capacityBytes(colors) + capacityBytes(intensities) +
         capacityBytes(labels);
}

void PointCloud::checkConsistent() const {
  const std::size_t n = positions.size();
  checkLength(normals, n, "normals");
  checkLength(colors, n, "colors");
  checkLength(intensities, n, "intensity");
  checkLength(labels, n, "labels");
}

std::vector<const char*> attributeNames(unsigned attributes) {
  std::vector<const char*> names;
  if (attributes & kNormals) names.push_back("normals");
  if (attributes & kColors) names.push_back("colors");
  if (attributes & kIntensity) names.push_back("intensity");
  if (attributes & kLabels) names.push_back("labels");
  return names;
}

}  // namespace piperun
