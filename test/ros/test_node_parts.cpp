// The parts the node is wired from, without a ROS master: range-checked ROS times, the command
// queue and inbox with their caps and counts, the warning throttle, the run control between the
// services and the run loop, the policy for waiting for transforms, and the tf intake.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <map>
#include <stdexcept>
#include <thread>

#include "fem_cloth/ros/bag_io.h"
#include "fem_cloth/ros/command_queue.h"
#include "fem_cloth/ros/run_control.h"
#include "fem_cloth/ros/scene_params.h"
#include "fem_cloth/ros/tf_intake.h"
#include "fem_cloth/ros/time_checks.h"
#include "fem_cloth/ros/transform_wait.h"
#include "fem_cloth/ros/warning_throttle.h"

using namespace fem_cloth;

namespace {

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

ForceCommand forceNumbered(std::uint32_t vertex) {
  ForceCommand c;
  c.vertices = {vertex};
  c.forces.resize(1);
  return c;
}

// The first vertex of a pin or force command (the only kinds these tests queue).
std::uint32_t vertexOf(const Command& c) {
  if (const PinCommand* pin = std::get_if<PinCommand>(&c)) return pin->vertices.at(0);
  return std::get<ForceCommand>(c).vertices.at(0);
}

}  // namespace

// --- Time checks ---------------------------------------------------------------------------------

// The node's integrator keys: cloth.launch loads the scene file's keys as parameters as well
// as naming the file, so a parameter that repeats the file's value (0.9 comes back from the
// parameter server as the double 0.90000000000000002) is the file's, not set by the user; a
// changed value or a new key is set. Only keys set are refused when the integrator does not
// read them (checkGivenIntegratorKeys); the file's are warnings.
TEST(SceneParams, IntegratorKeysSetAreThoseTheFileDoesNotGive) {
  const YAML::Node file = YAML::Load("{integrator: {name: projective_dynamics, iterations: 7, chebyshev_rho: 0.9}}");
  XmlRpc::XmlRpcValue params;
  params["name"] = std::string("backward_euler");
  params["iterations"] = 7;
  params["chebyshev_rho"] = 0.9;
  XmlRpc::XmlRpcValue root;
  root["integrator"] = params;
  EXPECT_EQ(integratorKeysSet(toYaml(root), file), std::vector<std::string>{"name"});
  params["chebyshev_rho"] = 0.5;
  params["newton_tolerance"] = 1.0;
  root["integrator"] = params;
  std::vector<std::string> set = integratorKeysSet(toYaml(root), file);
  std::sort(set.begin(), set.end());
  EXPECT_EQ(set, (std::vector<std::string>{"chebyshev_rho", "name", "newton_tolerance"}));
  EXPECT_TRUE(integratorKeysSet(YAML::Load("{mesh: {rows: 3}}"), file).empty());
  EXPECT_EQ(integratorKeysSet(toYaml(root), YAML::Load("{mesh: {rows: 3}}")).size(), 4u);
}

TEST(TimeChecks, RostimeThrowsWhereTheCheckedVersionsGiveNamedErrors) {
  // What issue 11 found: a stamp of 2^32 - 1 s minus an epoch of today is no ros::Duration.
  const ros::Time stamp(4294967295u, 0u), epoch(1700000000u, 0u);
  EXPECT_THROW((void)(stamp - epoch), std::runtime_error);
  const Expected<double> since = checkedSecondsSince(stamp, epoch, "header.stamp");
  ASSERT_FALSE(since.ok());
  EXPECT_TRUE(contains(since.error(), "header.stamp")) << since.error();
  // The exact difference is still known: 2594967295 s.
  EXPECT_EQ(secondsBetween(stamp, epoch), 2594967295.0);
  EXPECT_EQ(secondsBetween(epoch, stamp), -2594967295.0);
  EXPECT_DOUBLE_EQ(secondsBetween(ros::Time(10u, 250000000u), ros::Time(12u, 0u)), -1.75);

  EXPECT_THROW(ros::Duration(1e10), std::runtime_error);
  const Expected<ros::Duration> lag = checkedDuration(1e10, "parameter ~step_lag");
  ASSERT_FALSE(lag.ok());
  EXPECT_TRUE(contains(lag.error(), "parameter ~step_lag = 10000000000 s")) << lag.error();
  EXPECT_FALSE(checkedDuration(std::numeric_limits<double>::quiet_NaN(), "d").ok());
  const Expected<ros::Duration> fine = checkedDuration(-2.5, "d");
  ASSERT_TRUE(fine.ok());
  EXPECT_EQ(fine->toNSec(), -2500000000LL);
}

TEST(TimeChecks, TimesAreKeptWhereAnyTwoDifferByADuration) {
  const Expected<ros::Time> late = checkedTime(4e9, "parameter ~start_time");
  ASSERT_FALSE(late.ok());
  EXPECT_TRUE(contains(late.error(), "parameter ~start_time = 4000000000 s")) << late.error();
  EXPECT_FALSE(checkedTime(-1.0, "t").ok());
  EXPECT_FALSE(checkedTime(std::numeric_limits<double>::infinity(), "t").ok());
  const Expected<ros::Time> t = checkedTime(1234.5, "t");
  ASSERT_TRUE(t.ok());
  EXPECT_EQ(t->sec, 1234u);
  EXPECT_EQ(t->nsec, 500000000u);
  // The latest accepted time minus 0 is still a duration.
  const Expected<ros::Time> last = checkedTime(kMaxRosDuration, "t");
  ASSERT_TRUE(last.ok());
  EXPECT_NO_THROW((void)(*last - ros::Time(0u, 0u)));
}

TEST(TimeChecks, TimeAfterIsOriginPlusDurationBitForBitWithoutItsLimit) {
  // Against rostime itself where it does not throw: the stamps of a run must not change.
  const ros::Time origin(1000u, 123456789u);
  for (double s : {0.0, 0.01, 0.07, 1.0 / 3.0, 12.345678912, -0.3, -999.9, 86400.0 * 365 * 50}) {
    const Expected<ros::Time> t = checkedTimeAfter(origin, s, "t");
    ASSERT_TRUE(t.ok()) << s;
    EXPECT_EQ(*t, origin + ros::Duration(s)) << s;
  }
  for (int k = 1; k <= 1000; ++k) {
    const double s = 0.01 * k;
    EXPECT_EQ(*checkedTimeAfter(origin, s, "t"), origin + ros::Duration(s)) << k;
  }
  // Beyond ros::Duration's 2^31 s, still a ROS time: 3e9 s after 0.
  const Expected<ros::Time> far = checkedTimeAfter(ros::Time(0u, 0u), 3e9, "t");
  ASSERT_TRUE(far.ok());
  EXPECT_EQ(far->sec, 3000000000u);
  // Not a ROS time: before 0, or from 2^32 s on.
  EXPECT_FALSE(checkedTimeAfter(ros::Time(5u, 0u), -6.0, "t").ok());
  const Expected<ros::Time> over = checkedTimeAfter(ros::Time(4294967000u, 0u), 296.0, "the end");
  ASSERT_FALSE(over.ok());
  EXPECT_TRUE(contains(over.error(), "the end = 296 s")) << over.error();
  EXPECT_TRUE(checkedTimeAfter(ros::Time(4294967000u, 0u), 295.5, "t").ok());
  EXPECT_FALSE(checkedTimeAfter(origin, 1e300, "t").ok());
}

// --- Command queue and inbox ---------------------------------------------------------------------

TEST(CommandQueue, TimeOrderWithEqualTimesInArrivalOrder) {
  CommandQueue q(10);
  ASSERT_TRUE(q.push(1.0, forceNumbered(1)).ok());
  ASSERT_TRUE(q.push(0.5, forceNumbered(2)).ok());
  ASSERT_TRUE(q.push(1.0, forceNumbered(3)).ok());
  ASSERT_TRUE(q.push(-1.0, forceNumbered(4)).ok());  // a zero stamp: the next step
  PinCommand pin;
  pin.vertices = {5};
  ASSERT_TRUE(q.push(2.0, pin).ok());
  EXPECT_EQ(q.size(), 5u);
  EXPECT_EQ(q.size(CommandTopic::Force), 4u);
  EXPECT_EQ(q.size(CommandTopic::Pin), 1u);
  // due() looks, takeDue() takes.
  EXPECT_EQ(q.due(0.5).size(), 2u);
  EXPECT_EQ(q.size(), 5u);
  std::vector<Command> first = q.takeDue(0.0);
  ASSERT_EQ(first.size(), 1u);
  EXPECT_EQ(vertexOf(first[0]), 4u);
  std::vector<Command> next = q.takeDue(1.0);
  ASSERT_EQ(next.size(), 3u);
  EXPECT_EQ(vertexOf(next[0]), 2u);
  EXPECT_EQ(vertexOf(next[1]), 1u);
  EXPECT_EQ(vertexOf(next[2]), 3u);
  EXPECT_EQ(q.size(CommandTopic::Force), 0u);
  EXPECT_EQ(q.size(CommandTopic::Pin), 1u);
}

TEST(CommandQueue, RefusesBeyondItsCapacityNamingIt) {
  // The capacity is per topic and counts commands for later (now = 0.5 s): three forces for
  // later fill the force topic, not the pin topic, and never the next step.
  CommandQueue q(3);
  for (std::uint32_t k = 0; k < 3; ++k) ASSERT_TRUE(q.push(1e6 + k, forceNumbered(k), 0.5).ok());
  const Status full = q.push(1.0, forceNumbered(9), 0.5);
  ASSERT_FALSE(full.ok());
  EXPECT_TRUE(contains(full.error(), "3 ~force commands")) << full.error();
  EXPECT_TRUE(contains(full.error(), "max_pending_commands = 3")) << full.error();
  EXPECT_TRUE(q.push(0.5, forceNumbered(10), 0.5).ok());  // due at the next step
  EXPECT_TRUE(q.push(-1.0, forceNumbered(11), 0.5).ok());  // a zero stamp: the next step
  PinCommand pin;
  pin.vertices = {1};
  for (int k = 0; k < 3; ++k) EXPECT_TRUE(q.push(2.0 + k, pin, 0.5).ok()) << k;
  EXPECT_FALSE(q.push(9.0, pin, 0.5).ok());
  EXPECT_EQ(q.size(CommandTopic::Force), 5u);
  EXPECT_EQ(q.size(CommandTopic::Pin), 3u);
  const std::array<std::uint64_t, kCommandTopics> dropped = q.clear();
  EXPECT_EQ(dropped[static_cast<std::size_t>(CommandTopic::Force)], 5u);
  EXPECT_EQ(dropped[static_cast<std::size_t>(CommandTopic::Pin)], 3u);
  EXPECT_EQ(q.size(), 0u);
  EXPECT_TRUE(q.push(1.0, pin, 0.5).ok());
}

TEST(CommandQueue, TicketsFollowTheirCommandsAndCanBeWithdrawn) {
  CommandQueue q(10);
  ASSERT_TRUE(q.push(-1.0, forceNumbered(1), 0.0, 7).ok());
  ASSERT_TRUE(q.push(-1.0, forceNumbered(2)).ok());
  ASSERT_TRUE(q.push(-1.0, forceNumbered(3), 0.0, 9).ok());
  std::array<std::uint64_t, kCommandTopics> dropped{};
  EXPECT_EQ(q.withdrawTicketed(dropped), (std::vector<std::uint64_t>{7, 9}));
  EXPECT_EQ(dropped[static_cast<std::size_t>(CommandTopic::Force)], 2u);
  EXPECT_EQ(q.size(CommandTopic::Force), 1u);
  ASSERT_TRUE(q.push(-1.0, forceNumbered(4), 0.0, 11).ok());
  std::vector<std::uint64_t> tickets;
  const std::vector<Command> due = q.takeDue(0.0, &tickets);
  ASSERT_EQ(due.size(), 2u);
  EXPECT_EQ(vertexOf(due[0]), 2u);
  EXPECT_EQ(vertexOf(due[1]), 4u);
  EXPECT_EQ(tickets, (std::vector<std::uint64_t>{0, 11}));
  CommandInbox inbox(5);
  ASSERT_TRUE(inbox.push(forceNumbered(5), 3));
  ASSERT_TRUE(inbox.push(forceNumbered(6)));
  tickets.clear();
  EXPECT_EQ(inbox.take(&tickets).size(), 2u);
  EXPECT_EQ(tickets, (std::vector<std::uint64_t>{3, 0}));
}

TEST(CommandInbox, CountsWhatItRefusesWhenFull) {
  CommandInbox inbox(2);
  EXPECT_TRUE(inbox.push(forceNumbered(1)));
  EXPECT_TRUE(inbox.push(forceNumbered(2)));
  EXPECT_FALSE(inbox.push(forceNumbered(3)));
  const CommandInbox::Tally t = inbox.tally(CommandTopic::Force);
  EXPECT_EQ(t.received, 3u);
  EXPECT_EQ(t.refused, 1u);
  EXPECT_EQ(t.waiting, 2u);
  std::vector<Command> taken = inbox.take();
  ASSERT_EQ(taken.size(), 2u);
  EXPECT_EQ(vertexOf(taken[0]), 1u);
  EXPECT_EQ(vertexOf(taken[1]), 2u);
  EXPECT_EQ(inbox.tally(CommandTopic::Force).waiting, 0u);
  EXPECT_EQ(inbox.tally(CommandTopic::Pin).received, 0u);
}

TEST(CommandInbox, LosesNothingWhilePushedFromSeveralThreadsAndTaken) {
  // Four publishers' callbacks and a run loop at once: every command comes out exactly once,
  // in the order of its own thread.
  constexpr std::uint32_t kPerThread = 20000;
  CommandInbox inbox(1000000);
  std::atomic<int> done{0};
  std::vector<std::thread> pushers;
  for (std::uint32_t p = 0; p < 4; ++p) {
    pushers.emplace_back([&, p] {
      for (std::uint32_t k = 0; k < kPerThread; ++k) inbox.push(forceNumbered(p * kPerThread + k));
      ++done;
    });
  }
  std::vector<std::uint32_t> last(4, 0), count(4, 0);
  bool ordered = true;
  auto drain = [&] {
    for (const Command& c : inbox.take()) {
      const std::uint32_t v = vertexOf(c), p = v / kPerThread;
      if (count[p] > 0 && v <= last[p]) ordered = false;
      last[p] = v;
      ++count[p];
    }
  };
  while (done < 4) drain();
  for (std::thread& t : pushers) t.join();
  drain();
  EXPECT_TRUE(ordered);
  for (std::uint32_t p = 0; p < 4; ++p) EXPECT_EQ(count[p], kPerThread) << p;
  EXPECT_EQ(inbox.tally(CommandTopic::Force).received, 4 * kPerThread);
  EXPECT_EQ(inbox.tally(CommandTopic::Force).refused, 0u);
}

TEST(CommandCounts, TheNodeAddsItsInboxToTheDriver) {
  CommandInbox::Tally inbox;
  // 7 refused on arrival, 2 refused by a service's check, 3 still waiting, 88 handed to the driver
  inbox.received = 100;
  inbox.refused = 7;
  inbox.invalid = 2;
  inbox.waiting = 3;
  CommandCounts driver;
  driver.received = 88;
  driver.rejected = 10;
  driver.applied = 58;
  driver.pending = 15;
  driver.discarded = 5;
  const CommandCounts c = combinedCounts(inbox, driver);
  EXPECT_EQ(c.received, 100u);
  EXPECT_EQ(c.rejected, 19u);
  EXPECT_EQ(c.applied, 58u);
  EXPECT_EQ(c.pending, 18u);
  EXPECT_EQ(c.discarded, 5u);
  EXPECT_EQ(c.received, c.rejected + c.applied + c.pending + c.discarded);
  const CommandStats msg = toMsg(CommandTopic::Obstacle, c);
  EXPECT_EQ(msg.topic, "obstacle");
  EXPECT_EQ(msg.received, 100u);
  EXPECT_EQ(msg.rejected, 19u);
  EXPECT_EQ(msg.applied, 58u);
  EXPECT_EQ(msg.pending, 18u);
  EXPECT_EQ(msg.discarded, 5u);
}

TEST(CommandCounts, AServiceRefusalIsReceivedAndRejectedNotACapacityRefusal) {
  CommandInbox box(10);
  box.refuse(CommandTopic::Set);
  const CommandInbox::Tally t = box.tally(CommandTopic::Set);
  EXPECT_EQ(t.received, 1u);
  EXPECT_EQ(t.invalid, 1u);
  EXPECT_EQ(t.refused, 0u);  // the node warns about capacity refusals from this count
  EXPECT_EQ(t.waiting, 0u);
  EXPECT_EQ(box.tally(CommandTopic::Pin).received, 0u);
}

// --- Warning throttle ----------------------------------------------------------------------------

namespace {

// The number a summary line starts with ("12 more ..."), or 0.
std::uint64_t summarised(const std::string& line) {
  if (!contains(line, " more ")) return 0;
  return std::stoull(line.substr(0, line.find(' ')));
}

}  // namespace

TEST(WarningThrottle, TwentyThousandRejectionsGiveAFewLinesThatCountThemAll) {
  WarningThrottle throttle(1.0);
  std::vector<std::string> lines;
  auto keep = [&](std::vector<std::string> more) { lines.insert(lines.end(), more.begin(), more.end()); };
  // 20 000 rejections over 20 s, the loop flushing every 10 ms.
  for (int k = 0; k < 20000; ++k) {
    const double now = 0.001 * k;
    keep(throttle.add("~force rejected", "~force rejected: vertex " + std::to_string(k) + " does not exist", now));
    if (k % 10 == 0) keep(throttle.flush(now));
  }
  keep(throttle.flush(25.0));
  // One line opens each second and one counts the rest of it: about 40, not 20 000.
  EXPECT_LE(lines.size(), 42u);
  EXPECT_GE(lines.size(), 38u);
  std::uint64_t told = 0;
  for (const std::string& line : lines) {
    const std::uint64_t n = summarised(line);
    told += n > 0 ? n : 1;
  }
  EXPECT_EQ(told, 20000u);
  // A summary repeats the latest message of its window.
  EXPECT_TRUE(contains(lines[1], "999 more ~force rejected in the 1 s that followed")) << lines[1];
  EXPECT_TRUE(contains(lines[1], "vertex 999 does not exist")) << lines[1];
}

TEST(WarningThrottle, KindsAreThrottledApartAndALoneMessageHasNoSummary) {
  WarningThrottle throttle(1.0);
  EXPECT_EQ(throttle.add("a", "first a", 0.0).size(), 1u);
  EXPECT_EQ(throttle.add("b", "first b", 0.1).size(), 1u);
  EXPECT_TRUE(throttle.add("a", "second a", 0.2).empty());
  EXPECT_TRUE(throttle.flush(0.5).empty());  // windows still open
  const std::vector<std::string> lines = throttle.flush(1.5);
  ASSERT_EQ(lines.size(), 1u);  // b's window suppressed nothing
  EXPECT_EQ(lines[0], "1 more a in the 1 s that followed (latest: second a)");
  // After its window a kind is logged at once again.
  EXPECT_EQ(throttle.add("a", "third a", 1.6), std::vector<std::string>{"third a"});
  EXPECT_EQ(WarningThrottle::kindOf("vertex 12 at t = 0.35 s."), "vertex # at t = # s.");
  EXPECT_EQ(WarningThrottle::kindOf("at 1.79615e+09 s, 0.0043182 s older"),
            WarningThrottle::kindOf("at 1.79615e+09 s, 0.104318 s older"));
  // A label for the summary.
  WarningThrottle labelled(1.0);
  labelled.add("k#", "w 1", 0.0, "similar warnings");
  labelled.add("k#", "w 2", 0.5, "similar warnings");
  EXPECT_EQ(labelled.flush(1.0), std::vector<std::string>{"1 more similar warnings in the 1 s that followed (latest: w 2)"});
}

// --- Run control ---------------------------------------------------------------------------------

namespace {

// A stand-in for the node's run loop: takes steps while the control wants them, until told to
// stop; counts them. `fail` (0: never) makes that step fail.
class FakeLoop {
 public:
  explicit FakeLoop(RunControl& control, std::uint64_t fail = 0) : control_(control), fail_(fail) {
    thread_ = std::thread([this] { run(); });
  }
  ~FakeLoop() {
    stop_ = true;
    thread_.join();
  }
  std::uint64_t steps() const { return steps_; }
  std::uint64_t resets() const { return resets_; }

 private:
  void run() {
    while (!stop_) {
      const RunControl::Boundary b = control_.boundary();
      if (b.advanceEnded) control_.finishAdvance(steps_, 0.01 * static_cast<double>(steps_), "hash");
      if (b.reset) {
        ++resets_;
        control_.resetDone();
      }
      if (!b.running && !b.stepWanted) {
        control_.wait(0.01);
        continue;
      }
      if (!control_.beginStep(0.0)) continue;
      const bool fails = fail_ > 0 && steps_ + 1 == fail_;
      if (!fails) ++steps_;
      control_.endStep(steps_, 0.01 * static_cast<double>(steps_), fails ? "boom" : "");
    }
  }
  RunControl& control_;
  std::uint64_t fail_;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> steps_{0}, resets_{0};
  std::thread thread_;
};

}  // namespace

TEST(RunControl, PauseAnswersAtOnceDuringAStepAndTakesEffectAfterIt) {
  RunControl control(false, 0.01);
  ASSERT_TRUE(control.boundary().running);
  ASSERT_TRUE(control.beginStep(0.01));
  // The step is "in progress" on this very thread: pause() cannot be waiting for it to end.
  const std::string message = control.pause();
  EXPECT_EQ(message, "pausing after the step in progress, at t = 0.01 s");
  EXPECT_TRUE(control.paused());
  control.endStep(1, 0.01, "");
  const RunControl::Boundary b = control.boundary();
  EXPECT_FALSE(b.running);
  EXPECT_FALSE(b.stepWanted);
  EXPECT_FALSE(control.beginStep(0.02));
  EXPECT_EQ(control.pause(), "paused at t = 0.01 s");
}

TEST(RunControl, StepIsRefusedWhileRunningAndTakesOneStepWhilePaused) {
  RunControl control(false, 0.01);
  EXPECT_FALSE(control.step().ok());
  control.pause();
  const Expected<std::string> s = control.step();
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(*s, "stepping to t = 0.01 s");
  EXPECT_TRUE(control.boundary().stepWanted);
  EXPECT_TRUE(control.beginStep(0.01));
  control.endStep(1, 0.01, "");
  EXPECT_FALSE(control.boundary().stepWanted);
  EXPECT_FALSE(control.beginStep(0.02));
}

TEST(RunControl, AdvanceTakesItsStepsAndSaysSo) {
  RunControl control(true, 0.01);
  FakeLoop loop(control);
  const AdvanceResult r = control.advance(5);
  EXPECT_TRUE(r.success) << r.message;
  EXPECT_EQ(r.message, "advanced 5 steps");
  EXPECT_EQ(r.stepsTaken, 5u);
  EXPECT_EQ(r.step, 5u);
  EXPECT_EQ(r.stateHash, "hash");
  EXPECT_EQ(loop.steps(), 5u);
  EXPECT_EQ(control.advance(0).stepsTaken, 1u);  // 0 counts as 1
}

TEST(RunControl, AnEndlessAdvanceIsInterruptedByPause) {
  RunControl control(true, 0.01);
  FakeLoop loop(control);
  AdvanceResult r;
  std::thread caller([&] { r = control.advance(4294967295u); });
  while (loop.steps() < 200) std::this_thread::yield();
  const std::string paused = control.pause();
  EXPECT_TRUE(contains(paused, "the ~advance in progress stops there")) << paused;
  caller.join();
  EXPECT_FALSE(r.success);
  EXPECT_TRUE(contains(r.message, "interrupted by ~pause after ")) << r.message;
  EXPECT_TRUE(contains(r.message, " of 4294967295 steps")) << r.message;
  EXPECT_GE(r.stepsTaken, 200u);
  // It reports the state it stopped at: every step the loop took was one of its steps.
  EXPECT_EQ(r.stepsTaken, loop.steps());
  EXPECT_EQ(r.step, loop.steps());
  EXPECT_TRUE(control.paused());
}

TEST(RunControl, ResetInterruptsAnAdvanceAndWaitsUntilItIsDone) {
  RunControl control(true, 0.01);
  FakeLoop loop(control);
  AdvanceResult r;
  std::thread caller([&] { r = control.advance(4294967295u); });
  while (loop.steps() < 100) std::this_thread::yield();
  EXPECT_TRUE(control.reset());
  EXPECT_EQ(loop.resets(), 1u);  // done by the loop before reset() answered
  caller.join();
  EXPECT_TRUE(contains(r.message, "interrupted by ~reset after")) << r.message;
  // Resume interrupts one too.
  std::thread again([&] { r = control.advance(4294967295u); });
  while (loop.steps() < r.stepsTaken + 100) std::this_thread::yield();
  const std::string resumed = control.resume();
  EXPECT_TRUE(contains(resumed, "running; the ~advance in progress stops there (")) << resumed;
  again.join();
  EXPECT_TRUE(contains(r.message, "interrupted by ~resume")) << r.message;
  EXPECT_FALSE(control.paused());
}

TEST(RunControl, AFailedStepEndsTheAdvanceAndIsNotCounted) {
  RunControl control(true, 0.01);
  FakeLoop loop(control, 3);
  const AdvanceResult r = control.advance(10);
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.message, "step 3 of 10 failed: boom");
  EXPECT_EQ(r.stepsTaken, 2u);
}

TEST(RunControl, AdvanceIsRefusedWhileRunningAndShutdownEndsEveryWait) {
  RunControl control(false, 0.01);
  const AdvanceResult refused = control.advance(3);
  EXPECT_FALSE(refused.success);
  EXPECT_EQ(refused.message, "~advance steps a paused simulation; call ~pause first");
  EXPECT_TRUE(refused.stateHash.empty());
  // Paused with no run loop: only shutdown can end the waits.
  control.pause();
  AdvanceResult r;
  bool reset = true;
  std::thread advancing([&] { r = control.advance(10); });
  std::thread resetting([&] { reset = control.reset(); });
  control.shutdown();
  advancing.join();
  resetting.join();
  EXPECT_FALSE(r.success);
  EXPECT_TRUE(contains(r.message, "shutting down")) << r.message;
  EXPECT_FALSE(reset);
}

// --- Waiting for transforms ----------------------------------------------------------------------

TEST(TransformWait, AStoppedFrameIsWaitedForOnceNotAtEveryStep) {
  std::map<std::string, std::optional<ros::Time>> newest = {{"gripper", ros::Time(100.0)}};
  TransformWait wait(1.0, [&](const std::string& frame) { return newest[frame]; });
  EXPECT_EQ(wait.check({}, 0.0), TransformWait::Verdict::Step);
  EXPECT_EQ(wait.check({"gripper"}, 10.0), TransformWait::Verdict::Wait);
  EXPECT_EQ(wait.check({"gripper"}, 10.9), TransformWait::Verdict::Wait);
  std::vector<std::string> gaveUp;
  EXPECT_EQ(wait.check({"gripper"}, 11.0, &gaveUp), TransformWait::Verdict::TimedOut);
  EXPECT_EQ(gaveUp, std::vector<std::string>{"gripper"});
  // The next steps do not wait for it: nothing new has come.
  for (int k = 1; k <= 100; ++k) {
    EXPECT_EQ(wait.check({"gripper"}, 11.0 + 0.01 * k), TransformWait::Verdict::Step) << k;
  }
  // Another frame is still waited for.
  EXPECT_EQ(wait.check({"gripper", "camera"}, 13.0), TransformWait::Verdict::Wait);
  EXPECT_EQ(wait.check({"gripper"}, 13.1), TransformWait::Verdict::Step);
  // When the gripper's publisher is back, the node waits for it again.
  newest["gripper"] = ros::Time(101.0);
  EXPECT_EQ(wait.check({"gripper"}, 14.0), TransformWait::Verdict::Wait);
  wait.clear();
  EXPECT_EQ(wait.check({"gripper"}, 20.0), TransformWait::Verdict::Wait);
}

TEST(TransformWait, NewestTransformReadsTfAndNamesMayStartWithASlash) {
  tf2::BufferCore tf(ros::Duration(100.0));
  geometry_msgs::TransformStamped t;
  t.header.frame_id = "world";
  t.child_frame_id = "gripper";
  t.transform.rotation.w = 1.0;
  for (int k = 1; k <= 3; ++k) {
    t.header.stamp = ros::Time(10.0 * k);
    tf.setTransform(t, "test");
  }
  EXPECT_EQ(newestTransform(tf, "world", "gripper"), std::optional<ros::Time>(ros::Time(30.0)));
  EXPECT_EQ(newestTransform(tf, "/world", "/gripper"), std::optional<ros::Time>(ros::Time(30.0)));
  EXPECT_EQ(newestTransform(tf, "world", "camera"), std::nullopt);
  EXPECT_EQ(tfFrameName("/world"), "world");
}

// --- The tf intake -------------------------------------------------------------------------------

TEST(TfIntake, ATransformStampedWhereTf2OverflowsIsRefusedNotThrown) {
  geometry_msgs::TransformStamped t;
  t.header.frame_id = "world";
  t.child_frame_id = "bomb";
  t.transform.rotation.w = 1.0;
  t.header.stamp = ros::Time(4294967295u, 0u);
  // What killed the node on tf2_ros's listener thread: tf2 adds its cache time to the stamp.
  {
    tf2::BufferCore raw(ros::Duration(10.0));
    EXPECT_THROW(raw.setTransform(t, "test"), std::runtime_error);
  }
  tf2::BufferCore tf(ros::Duration(10.0));
  const Status s = insertTransform(tf, t, "test", false);
  ASSERT_FALSE(s.ok());
  EXPECT_TRUE(contains(s.error(), "the stamp of transform 'world' -> 'bomb' = 4294967295 s")) << s.error();
  EXPECT_FALSE(tf._frameExists("bomb"));
  // A good one goes in; tf2's own refusals come back as errors.
  t.header.stamp = ros::Time(100.0);
  ASSERT_TRUE(insertTransform(tf, t, "test", false).ok());
  EXPECT_EQ(newestTransform(tf, "world", "bomb"), std::optional<ros::Time>(ros::Time(100.0)));
  t.transform.translation.x = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(insertTransform(tf, t, "test", false).ok());
  EXPECT_FALSE(insertTransform(tf, t, "test", true).ok());
}

// A recording's time origin comes from its first state after step 0: a node paused from the
// start moves its origin to ROS time until its first step, so the step-0 state a recorder got at
// start-up (stamp 100 s) is older than the origin of the run (105 s: step 3 at 105.03 s, dt 0.01).
TEST(RunEpoch, TakenFromTheFirstStateAfterStepZero) {
  RecordedRun run;
  run.states = {{0, ros::Time(100.0), "a"}, {0, ros::Time(105.0), "a"}, {3, ros::Time(105, 30000000), "b"}};
  const std::optional<ros::Time> epoch = runEpoch(run, 0.01);
  ASSERT_TRUE(epoch);
  EXPECT_NEAR(epoch->toSec(), 105.0, 1e-9);
  // Only step-0 states: the last one.
  run.states.pop_back();
  EXPECT_EQ(runEpoch(run, 0.01), std::optional<ros::Time>(ros::Time(105.0)));
}
