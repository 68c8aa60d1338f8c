#pragma once
// Progress reporting and cancellation for long operations (reading, generating, stages).

#include <atomic>
#include <functional>
#include <mutex>
#include <string>

namespace piperun {

/// Receives progress from a long operation and carries its cancellation flag.
///
/// Operations call report(task, fraction) now and then, with fraction in [0, 1], and
/// checkCancelled() at safe points; cancel() may be called from any thread.
/// report() may be called from several threads: calls are serialised, and the callback runs on the
/// reporting thread, throttled to changes of at least 0.1 %.
class Progress {
 public:
  using Callback = std::function<void(const std::string& task, double fraction)>;

  Progress() = default;
  explicit Progress(Callback callback) : callback_(std::move(callback)) {}
  /// A progress for part of a job: cancelled when `parent` is, reporting to `callback` (if any).
  /// Used where parallel tasks would otherwise interleave their fractions in one bar.
  Progress(const Progress& parent, Callback callback) : callback_(std::move(callback)), parent_(&parent) {}
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void report(const std::string& task, double fraction);
  void cancel() { cancelled_.store(true); }
  bool cancelled() const { return cancelled_.load() || (parent_ && parent_->cancelled()); }
  /// Throws Cancelled when cancel() was called.
  void checkCancelled() const;

  /// A Progress that reports nothing and is never cancelled, for callers that do not care.
  static Progress& none();

 private:
  Callback callback_;
  std::atomic<bool> cancelled_{false};
  std::mutex mutex_;
  const Progress* parent_ = nullptr;
  std::string lastTask_;
  double lastFraction_ = -1.0;
};

}  // namespace piperun
