#pragma once
// Parsing the command line the same way in every PipeRun program.

#include <CLI/CLI.hpp>

#include <cstdio>
#include <optional>

namespace piperun::app {

/// Parses `argv` into `app`. Returns the exit code when the program is done: 0 after --help or
/// --version, 1 after a usage error, reported in one line "PROGRAM: error: WHAT (see PROGRAM
/// --help)"; nullopt when it goes on.
inline std::optional<int> parseArguments(CLI::App& app, int argc, char** argv, const char* program) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& help) {
    return app.exit(help);
  } catch (const CLI::CallForAllHelp& help) {
    return app.exit(help);
  } catch (const CLI::CallForVersion& version) {
    return app.exit(version);
  } catch (const CLI::ParseError& error) {
    std::fprintf(stderr, "%s: error: %s (see %s --help)\n", program, error.what(), program);
    return 1;
  }
  return std::nullopt;
}

}  // namespace piperun::app
