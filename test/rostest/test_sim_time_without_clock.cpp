// A node on simulation time (/use_sim_time true) with nothing on /clock warns once, naming
// /use_sim_time and /clock, instead of waiting in silence; the first /clock starts it.
#include <rosgraph_msgs/Clock.h>
#include <rosgraph_msgs/Log.h>

#include <atomic>

#include "node_test_support.h"

using namespace fem_cloth_test;

TEST(SimTimeWithoutClock, WarnsOnceThenStartsOnTheFirstClock) {
  std::atomic<int> warnings{0};
  Latest<rosgraph_msgs::Log> log("/rosout", [&](const rosgraph_msgs::Log& m) {
    if (m.name == kNode && m.level == rosgraph_msgs::Log::WARN &&
        m.msg.find("/use_sim_time") != std::string::npos && m.msg.find("/clock") != std::string::npos) {
      ++warnings;
    }
  });
  Latest<fem_cloth::ClothState> state(topic("state"));
  ASSERT_TRUE(log.waitFor([&](const rosgraph_msgs::Log&) { return warnings > 0; }, 40.0))
      << "no warning naming /use_sim_time and /clock";
  EXPECT_EQ(state.count(), 0u) << "the node stepped without a clock";
  // Once: two more seconds of waiting (the wait loop turns every millisecond) add none.
  log.waitFor([](const rosgraph_msgs::Log&) { return false; }, 2.0);
  EXPECT_EQ(warnings, 1);

  ros::NodeHandle nh;
  ros::Publisher clock = nh.advertise<rosgraph_msgs::Clock>("/clock", 10);
  // As rosbag play --clock does, every 10 ms from 100 s on (our own subscriber to /clock makes
  // the first connection, so the node may miss the first few).
  fem_cloth::ClothState::ConstPtr first;
  rosgraph_msgs::Clock c;
  for (int k = 0; k < 2000 && !first; ++k) {
    c.clock = ros::Time(100.0 + 0.01 * k);
    clock.publish(c);
    first = state.waitForAny(0.01);
  }
  ASSERT_TRUE(first) << "no state after /clock came";
  // Its time origin is the first /clock it saw: the first state is step 0, stamped then.
  EXPECT_EQ(first->step, 0u);
  EXPECT_GE(first->header.stamp, ros::Time(100.0));
  EXPECT_LE(first->header.stamp, c.clock);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_sim_time_without_clock");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
