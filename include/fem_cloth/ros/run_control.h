// Where the node's run loop and its services meet (docs/node.md, Services). The run loop is the
// only thread that steps, resets or otherwise touches the simulation; ~pause, ~resume, ~step,
// ~advance and ~reset only leave requests here, under a lock that is never held across a step.
// So ~pause answers at once during a slow step, and a long ~advance runs one step at a time with
// commands and the other services getting through between its steps. Thread-safe, ROS-free.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>

#include "fem_cloth/core/expected.h"

namespace fem_cloth {

/// What an ~advance did.
struct AdvanceResult {
  bool success = false;  ///< every step asked for was taken
  std::string message;   ///< what happened: done, refused, interrupted (by what), a step failed
  std::uint64_t stepsTaken = 0;
  std::uint64_t step = 0;  ///< the state it stopped at: step index, simulation time (s), hash
  double time = 0.0;
  std::string stateHash;  ///< empty when refused
};

class RunControl {
 public:
  /// `dt`: the step (s), for the messages.
  RunControl(bool paused, double dt) : paused_(paused), dt_(dt) {}

  // --- Services (any thread) -------------------------------------------------------------------
  /// Pauses from the next step boundary on (a step in progress completes) and interrupts an
  /// ~advance. Answers at once.
  std::string pause();
  /// Runs on from the next step boundary, and interrupts an ~advance.
  std::string resume();
  /// One more step while paused; refused when running or while an ~advance runs.
  Expected<std::string> step();
  /// `steps` steps while paused (0 counts as 1). Waits until they are taken, a step fails, or
  /// ~pause, ~resume, ~reset or a shutdown interrupts them, and says which.
  AdvanceResult advance(std::uint64_t steps);
  /// Asks for a reset (it interrupts an ~advance) and waits until the run loop has done it, after
  /// the step in progress. False when the node shut down first.
  bool reset();
  /// Ends every wait: the node is going down.
  void shutdown();
  bool paused() const;

  // --- The run loop (one thread) ---------------------------------------------------------------
  struct Boundary {
    bool advanceEnded = false;  ///< an ~advance is over: publish its state, then finishAdvance()
    bool reset = false;         ///< reset now, then resetDone()
    bool resumed = false;       ///< the run just went from paused to running
    bool running = false;       ///< not paused: step when the schedule says so
    bool stepWanted = false;    ///< paused, but ~step or ~advance wants a step
  };
  /// What to do at this step boundary (takes the `resumed` news).
  Boundary boundary();
  void finishAdvance(std::uint64_t step, double time, const std::string& stateHash);
  void resetDone();
  /// Just before a step that ends at `endTime`: false when it is no longer wanted (paused or a
  /// reset asked for since boundary()). A true answer consumes one ~step request.
  bool beginStep(double endTime);
  /// After it: the state's step index and time, and the step's error (empty: it succeeded).
  void endStep(std::uint64_t step, double time, const std::string& error);
  /// Waits up to `seconds` for a new request (or shutdown).
  void wait(double seconds);

 private:
  struct Advance {
    enum class End { Running, Done, Failed, Interrupted };
    bool active = false;
    std::uint64_t total = 0, taken = 0;
    bool thisStep = false;  // the step in progress is one of its steps
    End end = End::Running;  // set once
    std::string why;         // the failed step's error, or the service that interrupted it
    std::optional<AdvanceResult> result;  // filled by finishAdvance()
    bool running() const { return active && end == End::Running; }
  };
  /// Ends a running ~advance (the caller holds the lock): `by` names the service.
  std::string interruptAdvance(const std::string& by);
  std::string timeText(double t) const;
  void changed();  // a request came in (lock held)

  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::uint64_t generation_ = 0;
  bool paused_;
  double dt_;
  bool resumed_ = false, resetRequested_ = false, shutdown_ = false;
  std::uint64_t resetsDone_ = 0;
  std::uint64_t stepRequests_ = 0;
  bool stepping_ = false;
  double stepEnd_ = 0.0;
  std::uint64_t step_ = 0;
  double time_ = 0.0;
  Advance advance_;
};

}  // namespace fem_cloth
