#pragma once
// Command-line options shared by the studio's two front ends, piperun-studio and piperun-render.

#include "piperun/ui/studio.h"
#include "units_option.h"
#include "up_option.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <string>

namespace piperun::app {

/// The options both front ends read into StudioOptions: `--point-budget N`, `--units UNIT` and
/// `--up AXIS`.
struct StudioCommandLine {
  long long pointBudget = static_cast<long long>(piperun::ui::StudioOptions{}.pointBudget);
  std::string scanUnits;  ///< Empty: the unit a file declares, else metres.
  std::string up;         ///< Empty: z.

  void addTo(CLI::App& app) {
    app.add_option("--point-budget", pointBudget,
                   "Most points the 3-D scene's point layers draw when the camera is still; over it they draw "
                   "those in view, the near ones densest (the points budget command changes it)")
        ->capture_default_str();
    addUnitsOption(app, scanUnits);
    addUpOption(app, up);
  }

  /// Whether the values read are usable; prints `program`'s error otherwise.
  bool check(const char* program) const {
    if (pointBudget >= 1) return true;
    std::fprintf(stderr, "%s: error: --point-budget: expected at least 1 point\n", program);
    return false;
  }

  void applyTo(piperun::ui::StudioOptions& options) const {
    options.pointBudget = static_cast<std::size_t>(pointBudget);
    options.scanUnits = scanUnits;
    if (!up.empty()) options.up = upAxisFromString(up);
  }
};

}  // namespace piperun::app
