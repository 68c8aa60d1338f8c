#include "piperun/progress.h"

#include "piperun/error.h"

#include <cmath>

namespace piperun {

void Progress::report(const std::string& task, double fraction) {
  if (!callback_) return;
  const std::lock_guard<std::mutex> lock(mutex_);
  fraction = std::fmin(1.0, std::fmax(0.0, fraction));
  if (task == lastTask_ && std::fabs(fraction - lastFraction_) < 1e-3 && fraction < 1.0) return;
  lastTask_ = task;
  lastFraction_ = fraction;
  callback_(task, fraction);
}

void Progress::checkCancelled() const {
  if (cancelled()) throw Cancelled();
}

Progress& Progress::none() {
  // Without a callback report() touches no state, so sharing one instance across threads is safe.
  static Progress silent;
  return silent;
}

}  // namespace piperun
