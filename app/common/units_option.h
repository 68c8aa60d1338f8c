#pragma once
// `--units`: the length unit of a scan's coordinates, for every tool that reads scans.

#include "piperun/io/point_reader.h"

#include <CLI/CLI.hpp>

#include <string>

namespace piperun::app {

/// `--units UNIT` (one of lengthUnitNames()), read into `unit`; left empty when not given, for the
/// unit the file declares (LAS) or else metres.
inline void addUnitsOption(CLI::App& app, std::string& unit) {
  std::string names;
  for (const std::string& name : lengthUnitNames()) names += (names.empty() ? "" : ", ") + name;
  app.add_option("--units", unit,
                 "Unit of the scan's coordinates (" + names +
                     "; ft is the international foot, us-ft the US survey foot; default: the unit a LAS file "
                     "declares, else m): they are read as metres, which everything written is in")
      ->check(CLI::IsMember(lengthUnitNames()));
}

}  // namespace piperun::app
