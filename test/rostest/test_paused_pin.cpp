// A pin in a moving frame sent to a node that was started paused, more than tf_timeout (1 s)
// after it started and after the frame's first transform: it is accepted, not refused as 'unknown
// at the time it is needed' (the node's time origin stays at ROS time until its first step), and
// takes effect at the first step, stamped at the ROS time of that step; the vertex then sits at
// its place in the frame.
#include <fem_cloth/Advance.h>
#include <fem_cloth/PinCommand.h>
#include <tf2_msgs/TFMessage.h>

#include "node_test_support.h"

using namespace fem_cloth_test;

TEST(PausedPin, APinInAMovingFrameIsTakenAndAppliesAtTheFirstStep) {
  ros::NodeHandle nh;
  ASSERT_TRUE(ros::service::waitForService(topic("advance"), 20000));
  ros::Publisher tfPub = nh.advertise<tf2_msgs::TFMessage>("/tf", 100);
  ASSERT_TRUE(waitForConnection(tfPub));
  // The gripper 0.3 m above world, broadcast from now on (100 Hz, stamped 0.2 s ahead so that
  // a step finds it at its exact times).
  TfBroadcaster broadcaster(tfPub, [] { return frameAt("world", "gripper", ros::Time::now() + ros::Duration(0.2), 0, 0, 0.3); });
  ros::WallDuration(2.5).sleep();  // longer than tf_timeout since the node and the frame started

  ros::Publisher pinPub = nh.advertise<fem_cloth::PinCommand>(topic("pin"), 10);
  ASSERT_TRUE(waitForConnection(pinPub));
  Latest<fem_cloth::PinCommand> applied(topic("applied_pin"));
  Latest<fem_cloth::ClothState> state(topic("state"));
  ASSERT_TRUE(applied.waitConnected());
  // Vertex 0 at (0, 0, -0.1) in the gripper frame: (0, 0, 0.2) in world.
  pinPub.publish(pinAt("gripper", {0}, {point(0, 0, -0.1)}));
  ros::WallDuration(0.5).sleep();
  EXPECT_EQ(applied.count(), 0u) << "a paused node applied a pin without a step";

  // One step (~advance publishes the state it stops at).
  const ros::Time stepped = ros::Time::now();
  fem_cloth::Advance step;
  step.request.steps = 1;
  ASSERT_TRUE(ros::service::call(topic("advance"), step));
  ASSERT_TRUE(step.response.success) << step.response.message;
  auto a = applied.waitForAny(10.0);
  ASSERT_TRUE(a) << "the pin was not applied at the first step (refused?)";
  EXPECT_EQ(a->vertices, std::vector<std::uint32_t>{0});
  // Stamped with the first step's ROS time: now, not when the node started (> 2.5 s ago).
  EXPECT_LT(std::abs((a->header.stamp - stepped).toSec()), 0.5) << a->header.stamp << " vs " << stepped;
  auto s = state.waitFor([](const fem_cloth::ClothState& m) { return m.step >= 1; }, 10.0);
  ASSERT_TRUE(s);
  EXPECT_NEAR(s->positions[0].x, 0.0, 1e-9);
  EXPECT_NEAR(s->positions[0].y, 0.0, 1e-9);
  EXPECT_NEAR(s->positions[0].z, 0.2, 1e-9);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_paused_pin");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
