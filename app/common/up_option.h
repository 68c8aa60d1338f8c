#pragma once
// `--up`: the scan's up direction, for every tool that reconstructs or shows scans.

#include "piperun/up_axis.h"

#include <CLI/CLI.hpp>

#include <string>

namespace piperun::app {

/// `--up AXIS` (x, y, z, -x, -y, -z), read into `up`; left empty when not given, for the parameter
/// document's, a network's or a project's (default z). `help` says what the axis does for the tool.
inline CLI::Option* addUpOption(CLI::App& app, std::string& up,
                                const std::string& help = "The scan's up direction: x, y, z, -x, -y or -z (sets the "
                                                          "parameter up; default z, as scanners, LAS and E57 have it)") {
  return app.add_option("--up", up, help)->check(CLI::IsMember(upAxisNames()));
}

}  // namespace piperun::app
