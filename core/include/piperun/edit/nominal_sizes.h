#pragma once
// Nominal pipe sizes (ASME B36.10 NPS with DN equivalents): the outside diameters a fitted radius
// snaps to.

#include <filesystem>
#include <string>
#include <vector>

namespace piperun {

struct NominalSize {
  std::string nps;               ///< Nominal pipe size in inches as written in the table: "1/2", "1-1/4", "24".
  int dn = 0;                    ///< Diamètre nominal (mm).
  double outsideDiameter = 0.0;  ///< Metres.

  double radius() const { return 0.5 * outsideDiameter; }
};

class NominalSizes {
 public:
  /// Reads a CSV table "nps,dn,od_mm" (a header line, `#` comment lines); rows ascend by diameter.
  /// Throws InputError naming the file and line of a malformed row.
  static NominalSizes read(const std::filesystem::path& path);
  /// The shipped table resources/nominal_pipe_sizes.csv (see findResource()).
  static NominalSizes shipped();

  const std::vector<NominalSize>& sizes() const { return sizes_; }
  /// The size whose outside radius is nearest to `radius` (m). The table is never empty.
  const NominalSize& nearest(double radius) const;

 private:
  std::vector<NominalSize> sizes_;
};

}  // namespace piperun
