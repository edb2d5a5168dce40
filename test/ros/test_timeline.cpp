// The mapping of simulation time to ROS time across pauses (timeline.h), checked against times
// worked out by hand; the timeline a recording's stamps give back (runTimeline); and a driver
// whose pending commands move with a new segment, so that a command stamped during a pause takes
// effect at the first step after it.
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <std_msgs/String.h>

#include <cmath>

#include "fem_cloth/io/scene_yaml.h"
#include "fem_cloth/ros/bag_io.h"
#include "fem_cloth/ros/simulation_driver.h"
#include "fem_cloth/ros/time_checks.h"
#include "fem_cloth/ros/time_text.h"
#include "fem_cloth/ros/timeline.h"
#include "../temp_dir.h"

using namespace fem_cloth;

namespace {

ros::Time at(double seconds) { return ros::Time(seconds); }

double timeOf(const Timeline& timeline, double stamp, double dt = 0.01) {
  const Expected<double> t = timeline.timeOf(at(stamp), dt, "stamp");
  EXPECT_TRUE(t.ok());
  return t ? *t : -1e9;
}

double stampOf(const Timeline& timeline, std::uint64_t step, double time) {
  const Expected<ros::Time> t = timeline.stampOf(step, time, "time");
  EXPECT_TRUE(t.ok());
  return t ? t->toSec() : -1e9;
}

// Origin 100 s; 300 steps of 0.01 s (simulation time 3 s, ROS time 103 s); then a pause until
// ROS time 106 s, where the run goes on.
Timeline pausedAtThreeSeconds() {
  Timeline timeline(at(100.0));
  timeline.start(300, 3.0, at(106.0));
  return timeline;
}

}  // namespace

TEST(Timeline, OneSegmentIsTheTimeOriginBitForBit) {
  const Timeline timeline(ros::Time(100, 5));
  ASSERT_EQ(timeline.segments().size(), 1u);
  // origin + ros::Duration(t), the node's stamps before segments existed.
  for (double t : {0.0, 0.01, 0.3, 2.5, 1234.5678}) {
    EXPECT_EQ(*timeline.stampOf(static_cast<std::uint64_t>(t * 100), t, "t"), ros::Time(100, 5) + ros::Duration(t));
    EXPECT_EQ(*timeline.timeOf(ros::Time(100, 5) + ros::Duration(t), 0.01, "s"), (ros::Duration(t) + ros::Duration(0, 0)).toSec());
  }
  // Before the origin: a negative simulation time (due before the next step).
  EXPECT_NEAR(timeOf(timeline, 99.0), -1.0 - 5e-9, 1e-12);
}

TEST(Timeline, APauseStartsASegmentAtTheResume) {
  const Timeline timeline = pausedAtThreeSeconds();
  ASSERT_EQ(timeline.segments().size(), 2u);
  // Before the pause: 100 s + t. The last step before it (from step 299) ends at 103 s.
  EXPECT_NEAR(stampOf(timeline, 0, 0.0), 100.0, 1e-9);
  EXPECT_NEAR(stampOf(timeline, 150, 1.5), 101.5, 1e-9);
  EXPECT_NEAR(stampOf(timeline, 299, 3.0), 103.0, 1e-9);
  // From the resume on: 106 s + (t - 3 s), 3 s later than one origin would have them.
  EXPECT_NEAR(stampOf(timeline, 300, 3.0), 106.0, 1e-9);
  EXPECT_NEAR(stampOf(timeline, 350, 3.5), 106.5, 1e-9);
  EXPECT_NEAR(stampOf(timeline, 1000, 10.0), 113.0, 1e-9);
  // And back: 101.5 s is 1.5 s, 106.5 s is 3.5 s; during the pause (103 s to 106 s) the time
  // stands at 3 s, where the run resumed.
  EXPECT_NEAR(timeOf(timeline, 101.5), 1.5, 1e-9);
  EXPECT_NEAR(timeOf(timeline, 102.99), 2.99, 1e-9);
  EXPECT_NEAR(timeOf(timeline, 103.5), 3.0, 1e-12);
  EXPECT_NEAR(timeOf(timeline, 105.999), 3.0, 1e-12);
  EXPECT_NEAR(timeOf(timeline, 106.0), 3.0, 1e-9);
  EXPECT_NEAR(timeOf(timeline, 106.5), 3.5, 1e-9);
}

TEST(Timeline, ASegmentWithoutStepsIsReplacedAndStampsNeverGoBack) {
  Timeline timeline = pausedAtThreeSeconds();
  // Still paused at step 300 at 107 s: the segment moves (no step was taken in it).
  timeline.start(300, 3.0, at(107.0));
  ASSERT_EQ(timeline.segments().size(), 2u);
  EXPECT_NEAR(stampOf(timeline, 300, 3.0), 107.0, 1e-9);
  // Two steps later (3.02 s, 107.02 s) ROS time reads 107.01 s only (simulation ran ahead, a
  // real-time factor above 1): the segment starts where the last one has come, 107.02 s.
  timeline.start(302, 3.02, at(107.01));
  ASSERT_EQ(timeline.segments().size(), 3u);
  EXPECT_NEAR(stampOf(timeline, 302, 3.02), 107.02, 1e-9);
  // Before the first step the origin itself moves.
  Timeline fresh(at(100.0));
  fresh.start(0, 0.0, at(104.0));
  ASSERT_EQ(fresh.segments().size(), 1u);
  EXPECT_NEAR(stampOf(fresh, 0, 0.5), 104.5, 1e-9);
  // A segment at an earlier step drops the later ones (a ~reset of the run before them).
  timeline.start(100, 1.0, at(200.0));
  ASSERT_EQ(timeline.segments().size(), 2u);
  EXPECT_EQ(timeline.segments().back().step, 100u);
}

TEST(Timeline, ARebuiltSegmentIsPlacedAtStepTimesDtUntilReached) {
  Timeline timeline(at(100.0));
  ASSERT_TRUE(timeline.add(300, at(106.0)).ok());
  EXPECT_TRUE(std::isnan(timeline.segments().back().time));
  // Placed at 300 x 0.01 s = 3 s until the replay gets there.
  EXPECT_NEAR(timeOf(timeline, 106.5), 3.5, 1e-9);
  EXPECT_NEAR(timeOf(timeline, 104.0), 3.0, 1e-12);
  // The simulator's 300 sums of 0.01 s are not exactly 3 s: from now on its own time counts.
  double sum = 0.0;
  for (int k = 0; k < 300; ++k) sum += 0.01;
  EXPECT_TRUE(timeline.reach(300, sum));
  EXPECT_FALSE(timeline.reach(300, sum));  // once
  EXPECT_EQ(*timeline.timeOf(at(106.0), 0.01, "s"), sum);
  EXPECT_EQ(*timeline.stampOf(300, sum, "t"), at(106.0));
  // Steps only go forward; one at the last step replaces its stamp.
  EXPECT_FALSE(timeline.add(200, at(107.0)).ok());
  ASSERT_TRUE(timeline.add(300, at(106.5)).ok());
  EXPECT_EQ(timeline.segments().size(), 2u);
  EXPECT_EQ(timeline.segments().back().stamp, at(106.5));
}

// A recording: step 0 at start-up (stale, the node waited paused), then every 3 steps from the
// origin 105 s; a pause at step 6 (105.06 s) until 108 s, where the state of step 6 is published
// again with its new stamp; steps 9 and 12 follow at 108.03 s and 108.06 s.
TEST(RunTimeline, RebuiltFromTheStampsOfTheRecordedStates) {
  RecordedRun run;
  run.states = {{0, at(100.0), "a"},    {3, at(105.03), "b"},  {6, at(105.06), "c"},
                {6, at(108.0), "c"},    {9, at(108.03), "d"},  {12, at(108.06), "e"}};
  const std::optional<Timeline> timeline = runTimeline(run, 0.01);
  ASSERT_TRUE(timeline);
  ASSERT_EQ(timeline->segments().size(), 2u);
  EXPECT_NEAR(timeline->origin().toSec(), 105.0, 1e-9);
  EXPECT_EQ(timeline->segments()[1].step, 6u);
  EXPECT_EQ(timeline->segments()[1].stamp, at(108.0));
  // Without the pause: one segment, as runEpoch gives.
  run.states = {{0, at(100.0), "a"}, {3, at(105.03), "b"}, {6, at(105.06), "c"}, {9, at(105.09), "d"}};
  const std::optional<Timeline> one = runTimeline(run, 0.01);
  ASSERT_TRUE(one);
  EXPECT_EQ(one->segments().size(), 1u);
  EXPECT_EQ(one->origin(), *runEpoch(run, 0.01));
}

namespace {

const char* kScene = R"(
name: timeline_test
mesh: {type: grid, rows: 3, cols: 3, width: 0.2, height: 0.2}
material: {model: stvk, youngs_modulus: 2.0e6, poisson_ratio: 0.3, thickness: 5.0e-4, density: 2000}
integrator: {name: backward_euler, dt: 0.01}
pins:
  - grid_vertices: [[0, 0], [0, -1]]
)";

SimulationDriver makeDriver() {
  DriverSettings settings;
  settings.epoch = at(100.0);
  const Scene scene = *parseScene(YAML::Load(kScene));
  return SimulationDriver(std::move(buildSimulation(scene).value()), settings, nullptr);
}

ForceCommand forceAt(double stamp) {
  ForceCommand c;
  c.header.stamp = at(stamp);
  c.header.frame_id = "world";
  c.action = ForceCommand::APPLY;
  c.vertices = {4};
  c.forces.resize(1);
  c.forces[0].z = 1.0;
  return c;
}

}  // namespace

TEST(DriverTimeline, StampsAndCommandsFollowTheSegments) {
  SimulationDriver driver = makeDriver();
  for (int k = 0; k < 10; ++k) ASSERT_TRUE(driver.step().ok);
  EXPECT_NEAR(driver.now().toSec(), 100.1, 1e-9);
  // Sent before the pause, stamped 100.15 s: 5 steps ahead then. The run pauses at 0.1 s and
  // resumes at 103 s: 100.15 s has passed, so it takes effect at the first step after the pause.
  ASSERT_TRUE(driver.submit(forceAt(100.15)).ok());
  // One stamped 103.05 s, during the new segment: 5 steps after the resume.
  ASSERT_TRUE(driver.submit(forceAt(103.05)).ok());
  driver.startSegment(at(103.0));
  EXPECT_NEAR(driver.now().toSec(), 103.0, 1e-9);
  ASSERT_TRUE(driver.step().ok);
  std::vector<ForceCommand> applied = driver.takeAppliedForces();
  ASSERT_EQ(applied.size(), 1u);
  EXPECT_NEAR(applied[0].header.stamp.toSec(), 103.0, 1e-9);  // the step it took effect before
  EXPECT_NEAR(driver.now().toSec(), 103.01, 1e-9);
  for (int k = 0; k < 3; ++k) ASSERT_TRUE(driver.step().ok);
  EXPECT_TRUE(driver.takeAppliedForces().empty());
  ASSERT_TRUE(driver.step().ok);  // the step from 103.04 s: not yet
  EXPECT_TRUE(driver.takeAppliedForces().empty());
  ASSERT_TRUE(driver.step().ok);  // from 103.05 s
  applied = driver.takeAppliedForces();
  ASSERT_EQ(applied.size(), 1u);
  EXPECT_NEAR(applied[0].header.stamp.toSec(), 103.05, 1e-9);
  // ~reset: one origin again.
  driver.reset();
  EXPECT_EQ(driver.timeline().segments().size(), 1u);
  EXPECT_EQ(driver.now(), at(100.0));
}

TEST(CommandQueue, RetimeKeepsTheOrderOfEqualTimes) {
  CommandQueue queue(10);
  ForceCommand a = forceAt(1.0), b = forceAt(2.0), c = forceAt(3.0);
  ASSERT_TRUE(queue.push(1.0, a).ok());
  ASSERT_TRUE(queue.push(2.0, b).ok());
  ASSERT_TRUE(queue.push(3.0, c).ok());
  // b and c become due at 0.5 s, a at 4 s: b, c (arrival order), then a.
  queue.retime([](const Command& cmd, double) { return headerOf(cmd).stamp.toSec() == 1.0 ? 4.0 : 0.5; });
  const std::vector<Command> due = queue.takeDue(0.5);
  ASSERT_EQ(due.size(), 2u);
  EXPECT_EQ(headerOf(due[0]).stamp, at(2.0));
  EXPECT_EQ(headerOf(due[1]).stamp, at(3.0));
  EXPECT_TRUE(queue.takeDue(3.9).empty());
  EXPECT_EQ(queue.takeDue(4.0).size(), 1u);
}

// Seconds that may be a ROS time are printed in full (to the nanosecond, no trailing zeros), not
// as 1.79646e+09: the range checks' messages name the time a user gave.
TEST(TimeText, SecondsInFull) {
  EXPECT_EQ(secondsText(1796460000.123), "1796460000.123");
  EXPECT_EQ(secondsText(4294967295.0), "4294967295");
  EXPECT_EQ(secondsText(-0.5), "-0.5");
  EXPECT_EQ(secondsText(0.0), "0");
  EXPECT_EQ(secondsText(1e300), "1e+300");  // no ROS time: as numberText
  EXPECT_EQ(secondsText(std::nan("")), "nan");
  const Expected<ros::Time> late = checkedTime(2500000000.25, "the stamp");
  ASSERT_FALSE(late.ok());
  EXPECT_EQ(late.error().rfind("the stamp = 2500000000.25 s is later than 2147483647 s", 0), 0u) << late.error();
  const Expected<ros::Time> after = checkedTimeAfter(ros::Time(4294967000u, 500000000u), 300.0, "the end");
  ASSERT_FALSE(after.ok());
  EXPECT_NE(after.error().find("after ROS time 4294967000.500000000 s"), std::string::npos) << after.error();
}

// A recording that spans a reset of the node is refused with a `rosbag filter` expression that
// should keep the part before the reset, and the bag time of the reset. On a clock of today
// (1796460000 s) the time was printed as 1.79646e+09, before every message: the filter
// "t.to_sec() < 1.79646e+09" kept nothing. Now the time is printed in full, and the filter
// compares nanoseconds, exactly.
TEST(RunReading, TheResetRefusalsFilterKeepsThePartBeforeTheReset) {
  const fem_cloth::test::TempDir dir("fem_cloth_reset_refusal");
  const std::string path = dir.path("reset.bag");
  const ros::Time epoch(1796460000, 123000000);
  std::vector<ros::Time> received;
  {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    std_msgs::String scene;
    scene.data = "integrator: {dt: 0.01}\n";
    bag.write("/fem_cloth_node/scene", epoch, scene);
    // Steps 0..5, then the node reset: steps 0..2 again, each received 10 ms after the last.
    const std::vector<std::uint64_t> steps{0, 1, 2, 3, 4, 5, 0, 1, 2};
    for (std::size_t k = 0; k < steps.size(); ++k) {
      ClothState s;
      s.step = steps[k];
      s.header.stamp = epoch + ros::Duration(0, 10000000 * static_cast<std::int32_t>(k));
      s.positions.resize(1);
      received.push_back(epoch + ros::Duration(0, 10000000 * static_cast<std::int32_t>(k + 1)));
      bag.write("/fem_cloth_node/state", received.back(), s);
    }
  }
  const Expected<RecordedRun> run = readRun(path);
  ASSERT_FALSE(run.ok());
  const std::string& why = run.error();
  EXPECT_NE(why.find("spans a reset"), std::string::npos) << why;
  // The reset's state came at 1796460000.193 s (epoch + 7 x 10 ms).
  EXPECT_NE(why.find("at bag time 1796460000.193000000 s"), std::string::npos) << why;
  const std::string filter = "t.to_nsec() < ";
  const std::size_t at = why.find(filter);
  ASSERT_NE(at, std::string::npos) << why;
  const std::uint64_t before = std::stoull(why.substr(at + filter.size()));
  EXPECT_EQ(before, 1796460000193000000ull) << why;
  // What the filter keeps: the scene and the six states before the reset.
  int kept = 0;
  rosbag::Bag bag(path);
  for (const rosbag::MessageInstance& m : rosbag::View(bag)) kept += m.getTime().toNSec() < before ? 1 : 0;
  EXPECT_EQ(kept, 7) << why;
}
