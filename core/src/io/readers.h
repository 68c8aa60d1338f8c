#pragma once
// Factory functions of the format-specific readers (internal to core).

#include "piperun/io/point_reader.h"

namespace piperun::io {

std::unique_ptr<PointReader> openPlyReader(const std::filesystem::path& path);
std::unique_ptr<PointReader> openPcdReader(const std::filesystem::path& path);
/// XYZ/TXT/CSV/ASC: columns x y z, then optional columns (see docs/FORMATS.md).
std::unique_ptr<PointReader> openXyzReader(const std::filesystem::path& path);
/// Leica PTS: a count line, then x y z [intensity [r g b]] per line (possibly several blocks).
std::unique_ptr<PointReader> openPtsReader(const std::filesystem::path& path);
std::unique_ptr<PointReader> openLasReader(const std::filesystem::path& path);
std::unique_ptr<PointReader> openE57Reader(const std::filesystem::path& path);

}  // namespace piperun::io
