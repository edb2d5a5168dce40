// A run paused for 3 s (longer than tf_timeout) in the middle: after ~resume the stamps run on
// from ROS time at the resume, not 3 s behind it, so a pin following a moving gripper reads the gripper's pose of
// now; a pin sent while paused is accepted (checked against the frame as it is now) and takes
// effect at the first step after the resume; the state the run resumes from is published again
// with its new stamp (what a recording's replay rebuilds the pause from).
#include <std_srvs/Trigger.h>

#include <utility>

#include "node_test_support.h"

using namespace fem_cloth_test;

namespace {

// The gripper rises at 0.1 m/s from z = 0.3 m at ROS time `start`.
double gripperZ(const ros::Time& start, const ros::Time& t) { return 0.3 + 0.1 * (t - start).toSec(); }

bool call(const std::string& service) {
  std_srvs::Trigger trigger;
  return ros::service::call(topic(service), trigger) && trigger.response.success;
}

}  // namespace

TEST(PausedRun, StampsStayOnRosTimeAndAPinSentWhilePausedIsTaken) {
  ros::NodeHandle nh;
  ASSERT_TRUE(ros::service::waitForService(topic("resume"), 20000));
  std::mutex mutex;
  std::vector<std::pair<std::uint64_t, ros::Time>> stamps;  // every state's step and stamp
  Latest<fem_cloth::ClothState> state(topic("state"), [&](const fem_cloth::ClothState& s) {
    std::lock_guard<std::mutex> lock(mutex);
    stamps.emplace_back(s.step, s.header.stamp);
  });
  ASSERT_TRUE(state.waitFor([](const fem_cloth::ClothState& s) { return s.step >= 30; }, 30.0));
  ros::Publisher tfPub = nh.advertise<tf2_msgs::TFMessage>("/tf", 100);
  ASSERT_TRUE(waitForConnection(tfPub));
  const ros::Time start = ros::Time::now();
  // Stamped 0.2 s ahead, so that a step finds the frame at its exact times.
  TfBroadcaster broadcaster(tfPub, [start] {
    const ros::Time t = ros::Time::now() + ros::Duration(0.2);
    return frameAt("world", "gripper", t, 0, 0, gripperZ(start, t));
  });

  ASSERT_TRUE(call("pause"));
  ros::WallDuration(0.3).sleep();
  const fem_cloth::ClothState::ConstPtr paused = state.waitForAny();
  ASSERT_TRUE(paused);
  const std::uint64_t pausedAt = paused->step;
  ros::WallDuration(3.0).sleep();  // longer than tf_timeout (1 s)

  ros::Publisher pinPub = nh.advertise<fem_cloth::PinCommand>(topic("pin"), 10);
  ASSERT_TRUE(waitForConnection(pinPub));
  Latest<fem_cloth::PinCommand> applied(topic("applied_pin"));
  ASSERT_TRUE(applied.waitConnected());
  // Vertex 0 at 0.1 m below the gripper's origin.
  pinPub.publish(pinAt("gripper", {0}, {point(0, 0, -0.1)}));
  ros::WallDuration(0.5).sleep();
  EXPECT_EQ(applied.count(), 0u) << "a paused node applied a pin without a step";
  EXPECT_EQ(state.waitForAny()->step, pausedAt) << "the node stepped while paused";

  std::size_t beforeResume;
  {
    std::lock_guard<std::mutex> lock(mutex);
    beforeResume = stamps.size();
  }
  const ros::Time resumed = ros::Time::now();
  ASSERT_TRUE(call("resume"));
  auto a = applied.waitForAny(10.0);
  ASSERT_TRUE(a) << "the pin sent while paused was not applied (refused?)";
  // Stamped with the first step after the resume: no earlier than the ~resume call (one origin
  // would have it 3.8 s before). Lower bounds only: how far behind ROS time a loaded machine
  // runs is no part of the test.
  EXPECT_GE(a->header.stamp, resumed) << a->header.stamp << " vs " << resumed;

  // Later: every stamp runs on from the resume, step x dt, and vertex 0 is where the gripper is
  // at that stamp (it follows the frame's pose of then, not of 3.8 s before: 0.38 m lower).
  auto s = state.waitFor([&](const fem_cloth::ClothState& m) { return m.step >= pausedAt + 50; }, 20.0);
  ASSERT_TRUE(s);
  EXPECT_GE(s->header.stamp - ros::Duration(0.01 * static_cast<double>(s->step - pausedAt)), resumed - ros::Duration(0.03))
      << "stamp " << s->header.stamp << " at step " << s->step << ", resumed at " << resumed;
  EXPECT_NEAR(s->positions[0].x, 0.0, 1e-9);
  EXPECT_NEAR(s->positions[0].z, gripperZ(start, s->header.stamp) - 0.1, 1e-6);

  // The first state after the resume is the one the run resumed from (published before any
  // step, whatever the publish rate: at most 2 steps after the last one seen paused), stamped
  // at the resume.
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_GT(stamps.size(), beforeResume);
  const auto [step, stamp] = stamps[beforeResume];
  EXPECT_GE(step, pausedAt);
  EXPECT_LE(step, pausedAt + 2);
  EXPECT_GE(stamp, resumed) << stamp << " vs " << resumed;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_paused_run");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
