#pragma once
// Command-line options shared by the studio's two front ends, piperun-studio and piperun-render.

#include "piperun/ui/studio.h"

#include <CLI/CLI.hpp>

#include <cstdio>

namespace piperun::app {

/// `--point-budget N` (StudioOptions::pointBudget), read into `budget`.
inline void addPointBudgetOption(CLI::App& app, long long& budget) {
  budget = static_cast<long long>(piperun::ui::StudioOptions{}.pointBudget);
  app.add_option("--point-budget", budget,
                 "Most points the 3-D scene's point layers draw when the camera is still; over it they draw "
                 "those in view, the near ones densest (the points budget command changes it)")
      ->capture_default_str();
}

/// Whether the budget read is at least one point; prints `program`'s error otherwise.
inline bool checkPointBudget(long long budget, const char* program) {
  if (budget >= 1) return true;
  std::fprintf(stderr, "%s: error: --point-budget: expected at least 1 point\n", program);
  return false;
}

}  // namespace piperun::app
