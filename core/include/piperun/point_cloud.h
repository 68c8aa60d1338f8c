#pragma once
// Point clouds: structure-of-arrays storage, float positions relative to a double origin.

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

namespace piperun {

using Color = Eigen::Matrix<std::uint8_t, 3, 1>;  // 8-bit RGB

/// Axis-aligned box in world coordinates (metres). Empty until the first extend().
struct BoundingBox {
  Eigen::Vector3d min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d max = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());

  bool empty() const { return (min.array() > max.array()).any(); }
  Eigen::Vector3d size() const { return empty() ? Eigen::Vector3d::Zero() : Eigen::Vector3d(max - min); }
  Eigen::Vector3d center() const { return 0.5 * (min + max); }
  void extend(const Eigen::Vector3d& p) {
    min = min.cwiseMin(p);
    max = max.cwiseMax(p);
  }
  void extend(const BoundingBox& other) {
    if (!other.empty()) {
      extend(other.min);
      extend(other.max);
    }
  }
};

/// Optional per-point attributes, as a bit set.
enum PointAttribute : unsigned {
  kNoAttributes = 0,
  kNormals = 1u << 0,
  kColors = 1u << 1,
  kIntensity = 1u << 2,
  kLabels = 1u << 3,
};

/// A batch of points in world coordinates (double), as readers produce them and writers consume them.
/// Each attribute array is either empty or exactly as long as `positions`.
struct PointChunk {
  std::vector<Eigen::Vector3d> positions;
  std::vector<Eigen::Vector3f> normals;
  std::vector<Color> colors;
  std::vector<float> intensities;
  std::vector<std::int32_t> labels;

  std::size_t size() const { return positions.size(); }
  bool empty() const { return positions.empty(); }
  unsigned attributes() const;
  /// Empties every array, keeping capacity so a reader can refill the chunk without reallocating.
  void clear();
  /// Empties the attribute arrays not in the PointAttribute bit set `kept`.
  void keepAttributes(unsigned kept);
  /// Throws std::logic_error when an attribute array's length differs from the position count.
  void checkConsistent() const;
};

/// A point cloud held in memory.
///
/// Positions are float offsets from a double `origin` (world = origin + position), so scans in
/// georeferenced coordinates (hundreds of kilometres) keep millimetre precision at 12 bytes a point.
/// Each attribute array is either empty (attribute absent) or exactly as long as `positions`.
/// `labels` holds a per-point integer written by stages (segment, element id; -1 = none).
///
/// Copying is explicit (`clone()`): the copy constructor is deleted so that a 100-million-point
/// cloud is never duplicated by accident. Moving is cheap.
class PointCloud {
 public:
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3f> positions;
  std::vector<Eigen::Vector3f> normals;
  std::vector<Color> colors;
  std::vector<float> intensities;
  std::vector<std::int32_t> labels;

  PointCloud() = default;
  PointCloud(PointCloud&&) noexcept = default;
  PointCloud& operator=(PointCloud&&) noexcept = default;
  PointCloud(const PointCloud&) = delete;
  PointCloud& operator=(const PointCloud&) = delete;
  ~PointCloud() = default;

  /// A deep copy.
  PointCloud clone() const;

  std::size_t size() const { return positions.size(); }
  bool empty() const { return positions.empty(); }
  bool hasNormals() const { return !normals.empty(); }
  bool hasColors() const { return !colors.empty(); }
  bool hasIntensity() const { return !intensities.empty(); }
  bool hasLabels() const { return !labels.empty(); }
  /// The PointAttribute bits of the attributes present.
  unsigned attributes() const;

  /// World coordinates of point i.
  Eigen::Vector3d worldPosition(std::size_t i) const { return origin + positions[i].cast<double>(); }

  /// Bounding box of all points in world coordinates (computed on each call: O(n)).
  BoundingBox boundingBox() const;

  /// Appends a chunk of world-coordinate points. The attribute set of the first non-empty append
  /// decides which attributes the cloud keeps; later chunks must carry the same set.
  void append(const PointChunk& chunk);

  /// Copies points [first, first + count) into `chunk` in world coordinates.
  void copyTo(PointChunk& chunk, std::size_t first, std::size_t count) const;

  /// Bytes held by the arrays (capacity, not size).
  std::size_t memoryBytes() const;

  /// Throws std::logic_error when an attribute array's length differs from the position count.
  void checkConsistent() const;
};

/// Human-readable names of the attributes in a PointAttribute bit set, e.g. "normals, colors".
std::vector<const char*> attributeNames(unsigned attributes);

}  // namespace piperun
