#pragma once
// Exports of a pipe network for CAD, viewers, spreadsheets and piping isometric tools
// (docs/FORMATS.md, "Network exports").
//
// Every format leaves deleted pipes and rejected joints out. Pipes and joints have separate id
// spaces, so an element is named by its type and id: "pipe-12", "elbow-3", "tee-4", "boundary-5".

#include "piperun/pipe_network.h"
#include "piperun/up_axis.h"

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace piperun {

enum class ExportFormat {
  Obj,  ///< Wavefront OBJ mesh: capped tubes, one object and group per element.
  Ply,  ///< Binary little-endian PLY mesh with a per-face element id and type.
  Csv,  ///< One row per element (RFC 4180).
  Dxf,  ///< ASCII DXF R12: 3-D polylines of the centre lines, properties in XDATA.
  Pcf,  ///< Piping Component File (ISOGEN): one pipeline per run, millimetres.
  Ifc,  ///< IFC4 STEP file (BIM): pipe segments and fittings as swept disks, runs as systems.
};

/// What a PCF END-POINT's bore says.
enum class PcfBore {
  Nominal,          ///< The nominal size (DN, mm) whose outside diameter is nearest the fitted one
                    ///< (ASME B36.10, resources/nominal_pipe_sizes.csv): what isometric tools look up.
  OutsideDiameter,  ///< The fitted outside diameter (mm), as measured.
};

struct ExportOptions {
  /// Meshes: the largest distance (m) allowed between a tube's polygonal cross-section and its
  /// circle. It sets the number of sides around each tube, so thick pipes get more of them.
  double chordTolerance = 0.001;
  int minSegments = 8;    ///< Meshes: fewest sides around a tube.
  int maxSegments = 128;  ///< Meshes: most sides around a tube.
  PcfBore pcfBore = PcfBore::Nominal;  ///< PCF: the bores written.
  /// The network's up direction. PCF co-ordinates are East, North, Up (isometrics draw elevations
  /// along z) and an IFC model's z is up, so for those a network with another axis up is turned so
  /// that it is z; the other formats keep the network's co-ordinates, those of its scan.
  UpAxis up = UpAxis::PlusZ;
};

/// "nominal", "outside".
std::string toString(PcfBore bore);
/// Parses "nominal" or "outside" (case-insensitive); nullopt otherwise.
std::optional<PcfBore> pcfBoreFromString(const std::string& name);

/// "obj", "ply", "csv", "dxf", "pcf", "ifc".
std::string toString(ExportFormat format);
/// Every format's name, in the order above.
const std::vector<std::string>& exportFormatNames();
/// The file names the formats take, for messages: ".obj .ply .csv .dxf .pcf or .ifc".
std::string exportFileKinds();
/// Parses a format name (case-insensitive); nullopt for an unknown name.
std::optional<ExportFormat> exportFormatFromString(const std::string& name);
/// The format a file name's extension asks for (".obj" → Obj, case-insensitive); nullopt otherwise.
std::optional<ExportFormat> exportFormatFromPath(const std::filesystem::path& path);

/// Sides around a tube of `radius` metres: enough to keep within options.chordTolerance, rounded up
/// to a multiple of four (so an axis-aligned tube's mesh reaches exactly ±radius), then clamped to
/// [minSegments, maxSegments].
int meshSegments(double radius, const ExportOptions& options);

/// Writes `network` to `path` in `format`, atomically (a temporary file beside `path` is renamed
/// over it). Throws OutputError when the file cannot be written, InputError when nominal sizes are
/// needed (CSV, IFC, PCF's nominal bores) and their table is not found, and std::invalid_argument
/// for options out of range (chordTolerance ≤ 0, minSegments < 3, maxSegments < minSegments).
void exportNetwork(const PipeNetwork& network, ExportFormat format, const std::filesystem::path& path,
                   const ExportOptions& options = {});

}  // namespace piperun
