#include "piperun/io/network_export.h"

#include "angles.h"
#include "io/atomic_file.h"
#include "io/export_elements.h"
#include "io/file_extension.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>

namespace piperun {

namespace {

constexpr ExportFormat kFormats[] = {ExportFormat::Obj, ExportFormat::Ply, ExportFormat::Csv, ExportFormat::Dxf,
                                     ExportFormat::Pcf, ExportFormat::Ifc};

void checkOptions(const ExportOptions& options) {
  if (!(options.chordTolerance > 0.0)) throw std::invalid_argument("export: the chord tolerance must be positive");
  if (options.minSegments < 3) throw std::invalid_argument("export: a tube needs at least 3 sides");
  if (options.maxSegments < options.minSegments) {
    throw std::invalid_argument("export: the most sides around a tube is below the fewest");
  }
}

}  // namespace

std::string toString(ExportFormat format) {
  switch (format) {
    case ExportFormat::Obj: return "obj";
    case ExportFormat::Ply: return "ply";
    case ExportFormat::Csv: return "csv";
    case ExportFormat::Dxf: return "dxf";
    case ExportFormat::Pcf: return "pcf";
    case ExportFormat::Ifc: return "ifc";
  }
  return "obj";
}

const std::vector<std::string>& exportFormatNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> all;
    for (ExportFormat format : kFormats) all.push_back(toString(format));
    return all;
  }();
  return names;
}

std::string exportFileKinds() {
  const auto& names = exportFormatNames();
  std::string kinds;
  for (std::size_t i = 0; i < names.size(); ++i) {
    kinds += (i == 0 ? "." : i + 1 == names.size() ? " or ." : " .") + names[i];
  }
  return kinds;
}

std::string toString(PcfBore bore) { return bore == PcfBore::Nominal ? "nominal" : "outside"; }

std::optional<PcfBore> pcfBoreFromString(const std::string& name) {
  const std::string lower = io::lowercase(name);
  for (PcfBore bore : {PcfBore::Nominal, PcfBore::OutsideDiameter}) {
    if (toString(bore) == lower) return bore;
  }
  return std::nullopt;
}

std::optional<ExportFormat> exportFormatFromString(const std::string& name) {
  const std::string lower = io::lowercase(name);
  for (ExportFormat format : kFormats) {
    if (toString(format) == lower) return format;
  }
  return std::nullopt;
}

std::optional<ExportFormat> exportFormatFromPath(const std::filesystem::path& path) {
  const std::string extension = io::lowerExtension(path);
  if (extension.size() < 2) return std::nullopt;
  return exportFormatFromString(extension.substr(1));
}

int meshSegments(double radius, const ExportOptions& options) {
  // A chord of a regular n-gon of radius r stands r (1 - cos(π / n)) off the circle.
  const double ratio = 1.0 - options.chordTolerance / radius;
  const double ideal = ratio <= -1.0 ? 3.0 : kPi / std::acos(ratio);
  const int multipleOfFour = 4 * static_cast<int>(std::ceil(std::min(ideal, 1e6) / 4.0));
  return std::clamp(multipleOfFour, options.minSegments, options.maxSegments);
}

void exportNetwork(const PipeNetwork& network, ExportFormat format, const std::filesystem::path& path,
                   const ExportOptions& options) {
  checkOptions(options);
  std::optional<PipeNetwork> upright;
  const bool zUp = format == ExportFormat::Pcf || format == ExportFormat::Ifc;
  if (zUp && options.up != UpAxis::PlusZ) {
    upright = network;
    upright->turn(turnZUpTo(options.up).transpose());
  }
  const auto elements = io::exportedElements(upright ? *upright : network);
  std::optional<NominalSizes> sizes;
  if (format == ExportFormat::Csv || format == ExportFormat::Ifc ||
      (format == ExportFormat::Pcf && options.pcfBore == PcfBore::Nominal)) {
    sizes = NominalSizes::shipped();
  }
  std::string document;
  switch (format) {
    case ExportFormat::Obj: document = io::objDocument(elements, options); break;
    case ExportFormat::Ply: document = io::plyDocument(elements, options); break;
    case ExportFormat::Csv: document = io::csvDocument(elements, *sizes, options.up); break;
    case ExportFormat::Dxf: document = io::dxfDocument(elements); break;
    case ExportFormat::Pcf: document = io::pcfDocument(elements, sizes ? &*sizes : nullptr); break;
    case ExportFormat::Ifc: document = io::ifcDocument(elements, *sizes, path.filename().string()); break;
  }
  io::writeFileAtomically(path, document);
}

}  // namespace piperun
