#include "fem_cloth/ros/run_control.h"

#include <algorithm>
#include <chrono>

namespace fem_cloth {

std::string RunControl::timeText(double t) const { return "t = " + numberText(t) + " s"; }

void RunControl::changed() {
  ++generation_;
  changed_.notify_all();
}

std::string RunControl::interruptAdvance(const std::string& by) {
  if (!advance_.running()) return "";
  advance_.end = Advance::End::Interrupted;
  advance_.why = by;
  return "; the ~advance in progress stops there (" + std::to_string(advance_.taken) + " of " +
         std::to_string(advance_.total) + " steps taken so far)";
}

std::string RunControl::pause() {
  std::lock_guard<std::mutex> lock(mutex_);
  paused_ = true;
  resumed_ = false;
  std::string message = stepping_ ? "pausing after the step in progress, at " + timeText(stepEnd_)
                                  : "paused at " + timeText(time_);
  message += interruptAdvance("~pause");
  changed();
  return message;
}

std::string RunControl::resume() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (paused_) {
    paused_ = false;
    resumed_ = true;
  }
  std::string message = "running" + interruptAdvance("~resume");
  changed();
  return message;
}

Expected<std::string> RunControl::step() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!paused_) return Error{"~step advances a paused simulation; call ~pause first"};
  if (advance_.active) {
    return Error{"an ~advance is running (" + std::to_string(advance_.taken) + " of " +
                 std::to_string(advance_.total) + " steps); ~pause interrupts it"};
  }
  ++stepRequests_;
  changed();
  return "stepping to " + timeText(time_ + static_cast<double>(stepRequests_) * dt_);
}

AdvanceResult RunControl::advance(std::uint64_t steps) {
  std::unique_lock<std::mutex> lock(mutex_);
  AdvanceResult refused;
  refused.step = step_;
  refused.time = time_;
  if (!paused_) {
    refused.message = "~advance steps a paused simulation; call ~pause first";
    return refused;
  }
  if (advance_.active) {
    refused.message = "an ~advance is already running (" + std::to_string(advance_.taken) + " of " +
                      std::to_string(advance_.total) + " steps)";
    return refused;
  }
  advance_ = Advance();
  advance_.active = true;
  advance_.total = std::max<std::uint64_t>(steps, 1);
  changed();
  changed_.wait(lock, [this] { return advance_.result.has_value() || shutdown_; });
  AdvanceResult result;
  if (advance_.result) {
    result = *advance_.result;
  } else {
    result.message = "interrupted after " + std::to_string(advance_.taken) + " of " +
                     std::to_string(advance_.total) + " steps: the node is shutting down";
    result.stepsTaken = advance_.taken;
    result.step = step_;
    result.time = time_;
  }
  advance_ = Advance();
  changed();
  return result;
}

bool RunControl::reset() {
  std::unique_lock<std::mutex> lock(mutex_);
  interruptAdvance("~reset");
  resetRequested_ = true;
  const std::uint64_t target = resetsDone_ + 1;
  changed();
  changed_.wait(lock, [&] { return resetsDone_ >= target || shutdown_; });
  return resetsDone_ >= target;
}

void RunControl::shutdown() {
  std::lock_guard<std::mutex> lock(mutex_);
  shutdown_ = true;
  changed();
}

bool RunControl::paused() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return paused_;
}

RunControl::Boundary RunControl::boundary() {
  std::lock_guard<std::mutex> lock(mutex_);
  Boundary b;
  b.advanceEnded = advance_.active && !advance_.running() && !advance_.result;
  b.reset = resetRequested_;
  b.resumed = resumed_;
  resumed_ = false;
  b.running = !paused_;
  b.stepWanted = paused_ && (advance_.running() || stepRequests_ > 0);
  return b;
}

void RunControl::finishAdvance(std::uint64_t step, double time, const std::string& stateHash) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!advance_.active || advance_.running()) return;
  AdvanceResult r;
  const std::string total = std::to_string(advance_.total);
  r.success = advance_.end == Advance::End::Done;
  switch (advance_.end) {
    case Advance::End::Done:
      r.message = "advanced " + total + " steps";
      break;
    case Advance::End::Failed:
      r.message = "step " + std::to_string(advance_.taken + 1) + " of " + total + " failed: " + advance_.why;
      break;
    default:
      r.message = "interrupted by " + advance_.why + " after " + std::to_string(advance_.taken) +
                  " of " + total + " steps";
  }
  r.stepsTaken = advance_.taken;
  r.step = step;
  r.time = time;
  r.stateHash = stateHash;
  advance_.result = r;
  changed();
}

void RunControl::resetDone() {
  std::lock_guard<std::mutex> lock(mutex_);
  resetRequested_ = false;
  ++resetsDone_;
  step_ = 0;
  time_ = 0.0;
  changed();
}

bool RunControl::beginStep(double endTime) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (resetRequested_ || shutdown_) return false;
  advance_.thisStep = false;
  if (paused_) {
    if (advance_.running()) {
      advance_.thisStep = true;
    } else if (stepRequests_ > 0) {
      --stepRequests_;
    } else {
      return false;
    }
  }
  stepping_ = true;
  stepEnd_ = endTime;
  return true;
}

void RunControl::endStep(std::uint64_t step, double time, const std::string& error) {
  std::lock_guard<std::mutex> lock(mutex_);
  stepping_ = false;
  step_ = step;
  time_ = time;
  if (advance_.thisStep) {
    advance_.thisStep = false;
    if (!error.empty()) {
      // A failed step leaves the state as it was: it is not counted as taken.
      if (advance_.running()) {
        advance_.end = Advance::End::Failed;
        advance_.why = error;
      }
    } else if (++advance_.taken == advance_.total) {
      advance_.end = Advance::End::Done;  // even if interrupted during its last step
    }
  }
  changed();
}

void RunControl::wait(double seconds) {
  std::unique_lock<std::mutex> lock(mutex_);
  const std::uint64_t seen = generation_;
  changed_.wait_for(lock, std::chrono::duration<double>(seconds),
                    [&] { return generation_ != seen || shutdown_; });
}

}  // namespace fem_cloth
