#pragma once
// Console output of the command-line tool: a progress bar on stderr, quiet mode.

#include "piperun/progress.h"

#include <chrono>
#include <string>

namespace piperun::cli {

/// Draws "task [#####.....]  45%" on stderr when stderr is a terminal and quiet mode is off;
/// otherwise draws nothing. One instance per long operation.
class ProgressBar {
 public:
  explicit ProgressBar(bool quiet);
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  Progress& progress() { return progress_; }
  /// Clears the bar line (before printing anything else on stderr).
  void finish();

 private:
  void draw(const std::string& task, double fraction);

  bool enabled_;
  bool drawn_ = false;
  std::chrono::steady_clock::time_point lastDraw_;
  Progress progress_;
};

/// Prints "piperun: warning: <message>" on stderr.
void warn(const std::string& message);

}  // namespace piperun::cli
