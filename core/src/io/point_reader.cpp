#include "piperun/io/point_reader.h"

#include "io/file_extension.h"
#include "io/readers.h"
#include "piperun/error.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <stdexcept>

namespace piperun {

using io::lowerExtension;

namespace {

[[noreturn]] void failLaz(const std::filesystem::path& path) {
  throw InputError(path, "",
                   "LAZ (compressed LAS) is not supported; decompress it first, e.g. "
                   "`laszip -i in.laz -o out.las` or `pdal translate in.laz out.las`");
}

PointFormat formatFromContent(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", std::string("cannot open: ") + std::strerror(errno));
  char head[16] = {};
  in.read(head, sizeof head);
  const std::string_view start(head, static_cast<std::size_t>(in.gcount()));
  if (start.substr(0, 4) == "ply\n" || start.substr(0, 5) == "ply\r\n") return PointFormat::Ply;
  if (start.substr(0, 4) == "LASF") return PointFormat::Las;
  if (start.substr(0, 8) == "ASTM-E57") return PointFormat::E57;
  if (start.substr(0, 6) == "# .PCD" || start.substr(0, 7) == "VERSION") return PointFormat::Pcd;
  throw InputError(path, "",
                   "unknown point-cloud format: expected a file ending in .ply, .pcd, .xyz, .txt, .csv, "
                   ".asc, .pts, .las or .e57 (or starting with a PLY, PCD, LAS or E57 signature)");
}

// Positions are stored as float offsets from the origin: beyond this distance from (0, 0, 0) the
// origin moves to the first point so that float keeps sub-millimetre precision.
constexpr double kFarFromOrigin = 1000.0;

Eigen::Vector3d chooseOrigin(const PointChunk& chunk) {
  for (const auto& p : chunk.positions) {
    if (!p.allFinite()) continue;
    if (p.cwiseAbs().maxCoeff() <= kFarFromOrigin) return Eigen::Vector3d::Zero();
    return p.array().round().matrix();
  }
  return Eigen::Vector3d::Zero();
}

template <class T>
void compact(std::vector<T>& values, const std::vector<char>& keep) {
  if (values.empty()) return;
  std::size_t out = 0;
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (keep[i]) values[out++] = values[i];
  }
  values.resize(out);
}

template <class T>
void reserveTotal(std::vector<T>& values, std::size_t total) {
  if (total > values.capacity()) values.reserve(total);
}

/// A reader whose coordinates are in another unit than metres: each chunk scaled as it is read.
class ScaledReader final : public PointReader {
 public:
  ScaledReader(std::unique_ptr<PointReader> reader, double metresPerUnit)
      : reader_(std::move(reader)), scale_(metresPerUnit) {}
  const CloudInfo& info() const override { return reader_->info(); }
  std::size_t read(PointChunk& chunk, std::size_t maxPoints) override {
    const std::size_t count = reader_->read(chunk, maxPoints);
    for (Eigen::Vector3d& p : chunk.positions) p *= scale_;
    return count;
  }
  double progress() const override { return reader_->progress(); }

 private:
  std::unique_ptr<PointReader> reader_;
  double scale_;
};

std::unique_ptr<PointReader> openFormatReader(const std::filesystem::path& path) {
  switch (detectPointFormat(path)) {
    case PointFormat::Ply: return io::openPlyReader(path);
    case PointFormat::Pcd: return io::openPcdReader(path);
    case PointFormat::Xyz: return io::openXyzReader(path);
    case PointFormat::Pts: return io::openPtsReader(path);
    case PointFormat::Las: return io::openLasReader(path);
    case PointFormat::E57: return io::openE57Reader(path);
  }
  throw InputError(path, "", "unknown point-cloud format");
}

void reserveCloud(PointCloud& cloud, std::size_t total) {
  reserveTotal(cloud.positions, total);
  if (cloud.hasNormals()) reserveTotal(cloud.normals, total);
  if (cloud.hasColors()) reserveTotal(cloud.colors, total);
  if (cloud.hasIntensity()) reserveTotal(cloud.intensities, total);
  if (cloud.hasLabels()) reserveTotal(cloud.labels, total);
}

}  // namespace

PointFormat detectPointFormat(const std::filesystem::path& path) {
  const std::string extension = lowerExtension(path);
  if (extension == ".laz") failLaz(path);
  if (extension == ".ply") return PointFormat::Ply;
  if (extension == ".pcd") return PointFormat::Pcd;
  if (extension == ".xyz" || extension == ".txt" || extension == ".csv" || extension == ".asc") return PointFormat::Xyz;
  if (extension == ".pts") return PointFormat::Pts;
  if (extension == ".las") return PointFormat::Las;
  if (extension == ".e57") return PointFormat::E57;
  return formatFromContent(path);
}

namespace {

struct LengthUnit {
  const char* name;
  double metres;
};
constexpr std::array<LengthUnit, 6> kLengthUnits = {{
    {"m", 1.0}, {"cm", 0.01}, {"mm", 0.001}, {"in", 0.0254}, {"ft", 0.3048}, {"us-ft", 1200.0 / 3937.0}}};

}  // namespace

const std::vector<std::string>& lengthUnitNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> all;
    for (const LengthUnit& unit : kLengthUnits) all.emplace_back(unit.name);
    return all;
  }();
  return names;
}

std::optional<double> metresPerUnit(std::string_view unit) {
  for (const LengthUnit& known : kLengthUnits) {
    if (unit == known.name) return known.metres;
  }
  return std::nullopt;
}

std::string unitsRead(const PointReader& reader, const std::string& units) {
  if (!units.empty()) return units;
  return reader.info().declaredUnits.empty() ? "m" : reader.info().declaredUnits;
}

std::unique_ptr<PointReader> openPointReader(const std::filesystem::path& path, const std::string& units) {
  if (!units.empty() && !metresPerUnit(units)) throw std::invalid_argument("unknown length unit \"" + units + "\"");
  std::error_code error;
  if (!std::filesystem::exists(path, error)) throw InputError(path, "", "no such file");
  std::unique_ptr<PointReader> reader = openFormatReader(path);
  const double scale = *metresPerUnit(unitsRead(*reader, units));
  if (scale == 1.0) return reader;
  return std::make_unique<ScaledReader>(std::move(reader), scale);
}

std::size_t dropNonFinite(PointChunk& chunk) {
  chunk.checkConsistent();
  std::vector<char> keep(chunk.size());
  std::size_t dropped = 0;
  for (std::size_t i = 0; i < chunk.size(); ++i) {
    keep[i] = chunk.positions[i].allFinite();
    if (!keep[i]) ++dropped;
  }
  if (dropped == 0) return 0;
  compact(chunk.positions, keep);
  compact(chunk.normals, keep);
  compact(chunk.colors, keep);
  compact(chunk.intensities, keep);
  compact(chunk.labels, keep);
  return dropped;
}

PointCloud readPointCloud(const std::filesystem::path& path, const ReadOptions& options, ReadReport* report) {
  auto reader = openPointReader(path, options.units);
  const CloudInfo& info = reader->info();
  Progress& progress = options.progress ? *options.progress : Progress::none();

  PointCloud cloud;
  PointChunk chunk;
  std::uint64_t dropped = 0;
  bool first = true;
  while (reader->read(chunk, std::max<std::size_t>(1, options.chunkPoints)) > 0) {
    progress.checkCancelled();
    dropped += dropNonFinite(chunk);
    chunk.keepAttributes(options.attributes);
    if (chunk.empty()) continue;
    if (first) {
      cloud.origin = chooseOrigin(chunk);
      cloud.append(chunk);
      // Reserve the whole cloud once, so growth never holds two copies: from the header's count,
      // or estimated from the share of the file this first chunk used.
      std::size_t expected = 0;
      if (info.declaredPoints) {
        expected = static_cast<std::size_t>(*info.declaredPoints);
      } else if (reader->progress() > 0.0) {
        expected = static_cast<std::size_t>(static_cast<double>(cloud.size()) / reader->progress() * 1.02) + 16;
      }
      reserveCloud(cloud, expected);
      first = false;
    } else {
      cloud.append(chunk);
    }
    progress.report("read", reader->progress());
  }
  progress.report("read", 1.0);

  if (report) {
    report->info = info;
    report->units = unitsRead(*reader, options.units);
    report->pointsRead = cloud.size();
    report->nonFiniteDropped = dropped;
    report->warnings.clear();
    if (dropped > 0) {
      report->warnings.push_back(path.string() + ": dropped " + std::to_string(dropped) +
                                 " points with NaN or infinite coordinates");
    }
  }
  return cloud;
}

}  // namespace piperun
