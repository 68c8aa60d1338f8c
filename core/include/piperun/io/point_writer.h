#pragma once
// Writing point clouds: streaming writers that accept chunks, for bounded-memory conversion.

#include "piperun/point_cloud.h"

#include <filesystem>
#include <memory>

namespace piperun {

/// A streaming point writer. write() may be called any number of times; close() finishes the
/// file (PLY patches its vertex count) and is called by the destructor if needed (errors there
/// are swallowed, so call close() to see them). Failing writes throw OutputError naming the file.
class PointWriter {
 public:
  virtual ~PointWriter() = default;
  virtual void write(const PointChunk& chunk) = 0;
  virtual void close() = 0;
};

struct PointWriteOptions {
  unsigned attributes = kNormals | kColors | kIntensity | kLabels;  ///< Attributes to keep, when present.
  bool doublePositions = false;  ///< PLY: store x, y, z as double (automatic when far from the origin).
};

/// Binary little-endian PLY with float (or double) x y z, then as present: nx ny nz (float),
/// red green blue (uchar), intensity (float), label (int). `attributes` are the PointAttribute
/// bits the chunks will carry.
std::unique_ptr<PointWriter> openPlyWriter(const std::filesystem::path& path, unsigned attributes,
                                           bool doublePositions = false);

/// Text: one point per line, "x y z [nx ny nz] [r g b] [intensity] [label]" separated by spaces
/// (commas for .csv, with a header line).
std::unique_ptr<PointWriter> openTextWriter(const std::filesystem::path& path, unsigned attributes);

/// Opens a writer chosen by extension: .ply, or .xyz/.txt/.csv (text).
std::unique_ptr<PointWriter> openPointWriter(const std::filesystem::path& path, unsigned attributes,
                                             const PointWriteOptions& options = {});

/// Writes a whole cloud (attributes limited by options.attributes).
void writePointCloud(const std::filesystem::path& path, const PointCloud& cloud,
                     const PointWriteOptions& options = {});

}  // namespace piperun
