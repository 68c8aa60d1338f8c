#include "console.h"

#include <cstdio>
#include <unistd.h>

namespace piperun::cli {

namespace {
constexpr int kBarWidth = 30;
constexpr auto kRedrawInterval = std::chrono::milliseconds(100);
}  // namespace

ProgressBar::ProgressBar(bool quiet)
    : enabled_(!quiet && ::isatty(STDERR_FILENO)),
      progress_([this](const std::string& task, double fraction) { draw(task, fraction); }) {}

ProgressBar::~ProgressBar() { finish(); }

void ProgressBar::draw(const std::string& task, double fraction) {
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (drawn_ && fraction < 1.0 && now - lastDraw_ < kRedrawInterval) return;
  lastDraw_ = now;
  const int filled = static_cast<int>(fraction * kBarWidth + 0.5);
  std::string bar(static_cast<std::size_t>(filled), '#');
  bar.resize(kBarWidth, '.');
  std::fprintf(stderr, "\r%-10s [%s] %3d%%", task.c_str(), bar.c_str(), static_cast<int>(fraction * 100.0 + 0.5));
  std::fflush(stderr);
  drawn_ = true;
}

void ProgressBar::finish() {
  if (!drawn_) return;
  std::fprintf(stderr, "\r%*s\r", kBarWidth + 20, "");
  std::fflush(stderr);
  drawn_ = false;
}

void warn(const std::string& message) { std::fprintf(stderr, "piperun: warning: %s\n", message.c_str()); }

}  // namespace piperun::cli
