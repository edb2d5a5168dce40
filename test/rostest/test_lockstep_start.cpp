// Lock-step from a cold start (issue 32, part 3; lockstep_start.test). The node runs in fast mode
// on simulation time (/use_sim_time true), starts paused at ROS time 100 s, and its scene has a
// sphere in the tf frame 'finger', which nobody publishes at first.
// 1. A subscriber to /clock that comes after the node started gets /clock, at 100 s, again and
//    again (before, a paused node published /clock once, at start-up).
// 2. After ~resume the node takes no step while 'finger' is missing (before, it stepped after
//    tf_timeout, 0.2 s, without it), says on /diagnostics which frame it waits for, and keeps
//    /clock going at 100 s, so that a robot's tf publisher on simulation time can start.
// 3. Once 'finger' comes (on /tf_static, at (-2, 0.5, 1)), it steps; the first obstacle marker after
//    step 0 shows the sphere at the frame.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <rosgraph_msgs/Clock.h>
#include <std_srvs/Trigger.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>

#include "node_test_support.h"

using namespace fem_cloth_test;

namespace {

// The node's value of `key` on /diagnostics ("" when absent).
std::string value(const diagnostic_msgs::DiagnosticArray& a, const std::string& key) {
  auto node = std::find_if(a.status.begin(), a.status.end(), [](const auto& s) { return s.name == kNode; });
  if (node == a.status.end()) return "";
  auto kv = std::find_if(node->values.begin(), node->values.end(), [&key](const auto& v) { return v.key == key; });
  return kv == node->values.end() ? "" : kv->value;
}

}  // namespace

TEST(LockstepStart, ClockWhilePausedAndNoStepBeforeTheFrames) {
  ros::NodeHandle nh;
  const ros::Time start(100.0);
  ASSERT_TRUE(ros::service::waitForService(topic("resume"), 30000));
  // The node has started: its initial state is out (latched).
  Latest<fem_cloth::ClothState> states(topic("state"));
  ASSERT_TRUE(states.waitForAny(30.0));

  // 1. /clock for a subscriber that comes late, at the paused node's time.
  std::vector<ros::Time> clocks;
  Latest<rosgraph_msgs::Clock> clock("/clock", [&clocks](const rosgraph_msgs::Clock& c) { clocks.push_back(c.clock); });
  ASSERT_TRUE(clock.waitFor([&clocks](const rosgraph_msgs::Clock&) { return clocks.size() >= 3; }, 60.0))
      << "a paused node in fast mode sent " << clocks.size() << " /clock messages to a late subscriber";
  for (const ros::Time& t : clocks) EXPECT_EQ(t, start);

  // 2. ~resume: no step while 'finger' is missing, /clock still at 100 s.
  Latest<diagnostic_msgs::DiagnosticArray> diagnostics("/diagnostics");
  Latest<visualization_msgs::MarkerArray> markers(topic("obstacle_markers"));
  std::uint64_t stepped = 0;
  Latest<fem_cloth::ClothState> stepping(topic("state"), [&stepped](const fem_cloth::ClothState& s) {
    stepped = std::max<std::uint64_t>(stepped, s.step);
  });
  std_srvs::Trigger resume;
  ASSERT_TRUE(ros::service::call(topic("resume"), resume) && resume.response.success);
  const auto waiting = diagnostics.waitFor(
      [](const diagnostic_msgs::DiagnosticArray& a) { return value(a, "waiting for frames") == "finger"; }, 60.0);
  ASSERT_TRUE(waiting) << "no diagnostics saying the node waits for 'finger'";
  EXPECT_EQ(value(*waiting, "step"), "0");
  const std::size_t before = clocks.size();
  ros::WallDuration(1.5).sleep();  // 7 x tf_timeout: the old node had stepped without the frame
  ASSERT_TRUE(clock.waitFor([&](const rosgraph_msgs::Clock&) { return clocks.size() >= before + 3; }, 60.0));
  EXPECT_EQ(stepped, 0u) << "the node stepped without the frame its sphere follows";
  for (const ros::Time& t : clocks) EXPECT_EQ(t, start);

  // 3. The frame comes: the node steps, with the sphere at the frame.
  ros::Publisher tfStatic = nh.advertise<tf2_msgs::TFMessage>("/tf_static", 1, true);
  tf2_msgs::TFMessage message;
  message.transforms.push_back(frameAt("world", "finger", ros::Time(0), -2.0, 0.5, 1.0));
  tfStatic.publish(message);
  const auto placed = markers.waitFor([&start](const visualization_msgs::MarkerArray& a) {
    for (const auto& m : a.markers) {
      if (m.action == visualization_msgs::Marker::ADD && m.header.stamp > start) return true;
    }
    return false;
  }, 60.0);
  ASSERT_TRUE(placed) << "no obstacle marker after step 0 (the last state: step " << stepped << ")";
  for (const auto& m : placed->markers) {
    if (m.action != visualization_msgs::Marker::ADD) continue;
    EXPECT_NEAR(m.pose.position.x, -2.0, 1e-9);
    EXPECT_NEAR(m.pose.position.y, 0.5, 1e-9);
    EXPECT_NEAR(m.pose.position.z, 1.0, 1e-9);
  }
  EXPECT_GT(stepped, 0u);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_lockstep_start");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
