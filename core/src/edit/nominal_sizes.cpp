#include "piperun/edit/nominal_sizes.h"

#include "piperun/error.h"
#include "piperun/resources.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

namespace piperun {

NominalSizes NominalSizes::read(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "", "cannot open the nominal size table");
  NominalSizes table;
  std::string line;
  bool header = true;
  for (std::uint64_t number = 1; std::getline(in, line); ++number) {
    if (line.empty() || line[0] == '#') continue;
    if (header) {
      if (line.rfind("nps,dn,od_mm", 0) != 0) throw InputError(path, lineLocation(number), "expected the header \"nps,dn,od_mm\"");
      header = false;
      continue;
    }
    std::istringstream fields(line);
    std::string nps, dn, od;
    std::getline(fields, nps, ',');
    std::getline(fields, dn, ',');
    std::getline(fields, od, ',');
    NominalSize size;
    size.nps = nps;
    try {
      size.dn = std::stoi(dn);
      size.outsideDiameter = std::stod(od) / 1000.0;
    } catch (const std::exception&) {
      throw InputError(path, lineLocation(number), "expected \"NPS,DN,OD in mm\", found \"" + line + "\"");
    }
    if (nps.empty() || !(size.outsideDiameter > 0.0)) {
      throw InputError(path, lineLocation(number), "expected \"NPS,DN,OD in mm\" with a positive OD, found \"" + line + "\"");
    }
    if (!table.sizes_.empty() && size.outsideDiameter <= table.sizes_.back().outsideDiameter) {
      throw InputError(path, lineLocation(number), "rows must ascend by outside diameter");
    }
    table.sizes_.push_back(size);
  }
  if (table.sizes_.empty()) throw InputError(path, "", "the nominal size table has no rows");
  return table;
}

NominalSizes NominalSizes::shipped() { return read(findResource("nominal_pipe_sizes.csv")); }

const NominalSize& NominalSizes::nearest(double radius) const {
  return *std::min_element(sizes_.begin(), sizes_.end(), [radius](const NominalSize& a, const NominalSize& b) {
    return std::abs(a.radius() - radius) < std::abs(b.radius() - radius);
  });
}

}  // namespace piperun
