#pragma once
// Reading point clouds: one streaming reader per format, chosen by extension or content.

#include "piperun/point_cloud.h"
#include "piperun/progress.h"

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace piperun {

/// What a reader learned from a file's header.
struct CloudInfo {
  std::string format;                     ///< e.g. "PLY binary_little_endian 1.0", "E57", "LAS 1.4 format 6".
  std::vector<std::string> fields;        ///< Field names as the file declares them.
  std::optional<std::uint64_t> declaredPoints;  ///< Point count from the header, when it has one.
  unsigned attributes = kNoAttributes;    ///< PointAttribute bits the reader delivers.
  /// The unit of the coordinates as the file declares it, one of lengthUnitNames(); empty when it
  /// declares none this reader knows (only LAS files declare one: their GeoTIFF keys or WKT).
  std::string declaredUnits;
  std::string declaredUnitsSource;        ///< Where, e.g. "GeoTIFF key ProjLinearUnitsGeoKey = 9003".
};

/// A streaming point reader. Each call to read() fills `chunk` (cleared first) with up to
/// `maxPoints` points in world coordinates and returns how many; 0 means the end of the data.
/// Points are delivered as stored, non-finite ones included (readPointCloud drops those).
/// Errors throw InputError naming the file, the byte offset or line, and what was expected.
class PointReader {
 public:
  virtual ~PointReader() = default;
  virtual const CloudInfo& info() const = 0;
  virtual std::size_t read(PointChunk& chunk, std::size_t maxPoints) = 0;
  /// Fraction of the input consumed so far, in [0, 1].
  virtual double progress() const = 0;
};

enum class PointFormat { Ply, Pcd, Xyz, Pts, Las, E57 };

/// The format of a file by its extension (.ply .pcd .xyz .txt .csv .asc .pts .las .e57), or by its
/// first bytes when the extension says nothing. Throws InputError for LAZ (compressed LAS,
/// with how to decompress it) and for unknown formats.
PointFormat detectPointFormat(const std::filesystem::path& path);

/// The length units a scan's coordinates may be given in (everything PipeRun computes is in
/// metres): "m", "cm", "mm", "in", "ft" (the international foot, 0.3048 m) and "us-ft" (the US
/// survey foot, 1200/3937 m, of many state-plane LAS files).
const std::vector<std::string>& lengthUnitNames();
/// Metres per one of those units; nullopt for any other name.
std::optional<double> metresPerUnit(std::string_view unit);

/// Opens a streaming reader for `path`; throws InputError when the file cannot be opened or its
/// header is malformed. The coordinates are in `units` (one of lengthUnitNames(); empty: in the
/// unit the file declares, else metres) and are delivered scaled to metres. Throws
/// std::invalid_argument for a unit that is not one of lengthUnitNames().
std::unique_ptr<PointReader> openPointReader(const std::filesystem::path& path, const std::string& units = "");
/// The unit `reader` delivers its points from: `units`, or when empty the one its file declares,
/// else "m".
std::string unitsRead(const PointReader& reader, const std::string& units);

struct ReadOptions {
  std::size_t chunkPoints = 1u << 20;   ///< Points per read() call.
  Progress* progress = nullptr;         ///< Reports "read" progress and allows cancelling.
  /// Attributes kept (PointAttribute bits, where the file has them); the others are dropped chunk
  /// by chunk, so they never take memory.
  unsigned attributes = kNormals | kColors | kIntensity | kLabels;
  std::string units;                    ///< The coordinates' unit (openPointReader): empty, the file's own or metres.
};

struct ReadReport {
  CloudInfo info;
  std::string units;                     ///< The unit the coordinates were read in (unitsRead()).
  std::uint64_t pointsRead = 0;          ///< Points kept.
  std::uint64_t nonFiniteDropped = 0;    ///< Points with NaN or infinite coordinates, dropped.
  std::vector<std::string> warnings;     ///< One line each, e.g. the dropped-point count.
};

/// Reads a whole file into memory, chunk by chunk (the file is never held twice): drops points
/// with non-finite coordinates and counts them in a warning; chooses the cloud's origin from the
/// first point so that float positions keep sub-millimetre precision far from (0, 0, 0).
PointCloud readPointCloud(const std::filesystem::path& path, const ReadOptions& options = {},
                          ReadReport* report = nullptr);

/// Removes points with a non-finite coordinate from a chunk; returns how many were removed.
std::size_t dropNonFinite(PointChunk& chunk);

}  // namespace piperun
