// Pins: a pin holds a vertex exactly at its target, and a pin in a frame moved by a tf
// broadcaster follows that frame; a pin that jumps is taken but flagged on /diagnostics, which
// also reports the run's energy balance.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <tf2/LinearMath/Vector3.h>
#include <tf2_msgs/TFMessage.h>

#include "fem_cloth/PinCommand.h"
#include "node_test_support.h"

using namespace fem_cloth_test;

TEST(Pins, HoldsVertexExactlyAtTarget) {
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<fem_cloth::PinCommand>(topic("pin"), 10);
  ASSERT_TRUE(waitForConnection(pub));
  Latest<fem_cloth::ClothState> state(topic("state"));
  ASSERT_TRUE(state.waitForAny());
  const geometry_msgs::Point target = point(0.5, 0.25, -0.125);
  pub.publish(pinAt("world", {40}, {target}));
  auto at = state.waitFor([&](const fem_cloth::ClothState& s) {
    return s.positions[40].x == target.x && s.positions[40].y == target.y &&
           s.positions[40].z == target.z;
  });
  ASSERT_TRUE(at) << "vertex 40 never reached its target exactly";
  // And it stays there, bit for bit, while the rest of the cloth moves.
  for (int k = 0; k < 5; ++k) {
    auto next = state.waitForNext();
    ASSERT_TRUE(next);
    EXPECT_EQ(next->positions[40].x, target.x);
    EXPECT_EQ(next->positions[40].y, target.y);
    EXPECT_EQ(next->positions[40].z, target.z);
    EXPECT_TRUE(finite(*next));
  }
}

TEST(Pins, FollowsAFrameMovedByTf) {
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<fem_cloth::PinCommand>(topic("pin"), 10);
  ASSERT_TRUE(waitForConnection(pub));
  // A gripper frame rising at 0.2 m/s from (0.5, 0, 0) in world. Transforms are stamped 0.2 s
  // ahead, so the node can interpolate at the end time of every step; the motion is linear, so
  // tf's interpolation is exact.
  const ros::Time t0 = ros::Time::now();
  const double speed = 0.2;
  auto gripperAt = [&](const ros::Time& t) {
    return tf2::Vector3(0.5, 0.0, speed * (t - t0).toSec());
  };
  // Published on /tf directly, so the test can wait until the node's tf listener is connected
  // (a message sent before that is lost, and the node would not know the frame yet).
  ros::Publisher tfPub = nh.advertise<tf2_msgs::TFMessage>("/tf", 100);
  ASSERT_TRUE(waitForConnection(tfPub));
  TfBroadcaster broadcaster(tfPub, [&] {
    const ros::Time stamp = ros::Time::now() + ros::Duration(0.2);
    const tf2::Vector3 p = gripperAt(stamp);
    return frameAt("world", "gripper", stamp, p.x(), p.y(), p.z());
  });
  // Stamp the command 0.3 s ahead: the node applies it at that simulation time, which its tf
  // buffer covers exactly (a command stamped before the frame's first transform would be
  // served the nearest transform instead, with a warning).
  ros::WallDuration(0.1).sleep();

  // Vertex 4 (middle of the pinned edge, at x = 0.5) held 0.1 m beside and 0.1 m below the
  // gripper from the command's stamp on.
  const geometry_msgs::Point local = point(0.1, 0.0, -0.1);
  const fem_cloth::PinCommand c = pinAt("gripper", {4}, {local}, ros::Time::now() + ros::Duration(0.3));
  pub.publish(c);

  Latest<fem_cloth::ClothState> state(topic("state"));
  int checked = 0;
  double worst = 0.0;
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(20.0);
  while (checked < 20 && ros::WallTime::now() < end) {
    auto s = state.waitForNext();
    ASSERT_TRUE(s);
    ASSERT_TRUE(finite(*s));
    const tf2::Vector3 g = gripperAt(s->header.stamp);
    const double dz = s->positions[4].z - (g.z() - 0.1);
    const double dx = s->positions[4].x - (g.x() + 0.1);
    // The command takes effect before the first step that starts at or after its stamp, so
    // from the state that step ends in (dt = 0.01 s in small_cloth.yaml).
    if (s->header.stamp < c.header.stamp + ros::Duration(0.01)) continue;
    EXPECT_LT(std::abs(dx), 1e-12) << "at " << s->header.stamp;
    worst = std::max(worst, std::abs(dz));
    ++checked;
  }
  ASSERT_EQ(checked, 20) << "the pinned vertex never followed the gripper";
  // Exact up to tf's float-to-double round trips.
  EXPECT_LT(worst, 1e-6);
}

// A target 0.3 m above a vertex moves it there within one step (30 m/s): the pins do far more
// work in it than the cloth's energy scale (weight x size, 9.81 x 1 kg x 1.41 m = 13.9 J). The
// step is taken, the vertex is there, and /diagnostics goes WARN and counts the pin jump, and
// carries the run's energy balance as fem_cloth_sim judges it.
TEST(Pins, AJumpIsTakenButFlaggedOnDiagnostics) {
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<fem_cloth::PinCommand>(topic("pin"), 10);
  ASSERT_TRUE(waitForConnection(pub));
  Latest<fem_cloth::ClothState> state(topic("state"));
  auto now = state.waitForNext();
  ASSERT_TRUE(now);
  Latest<diagnostic_msgs::DiagnosticArray> diagnostics("/diagnostics");
  ASSERT_TRUE(diagnostics.waitConnected());
  const geometry_msgs::Point at = now->positions[30];
  pub.publish(pinAt("world", {30}, {point(at.x, at.y, at.z + 0.3)}));
  auto value = [](const diagnostic_msgs::DiagnosticStatus& s, const std::string& key) {
    for (const auto& kv : s.values) {
      if (kv.key == key) return kv.value;
    }
    return std::string();
  };
  auto flagged = diagnostics.waitFor([&](const diagnostic_msgs::DiagnosticArray& a) {
    for (const auto& s : a.status) {
      // The count, not the message: a later warning (the frame of the test before stopping)
      // may replace the message.
      if (s.level >= diagnostic_msgs::DiagnosticStatus::WARN && value(s, "pin jumps") != "0" &&
          !value(s, "pin jumps").empty()) {
        return true;
      }
    }
    return false;
  }, 30.0);
  ASSERT_TRUE(flagged) << "no pin jump on /diagnostics";
  const diagnostic_msgs::DiagnosticStatus& s = flagged->status.front();
  EXPECT_NE(value(s, "energy balance").find("% of the energy scale"), std::string::npos) << value(s, "energy balance");
  EXPECT_FALSE(value(s, "energy balance error (J)").empty());
  auto there = state.waitFor([&](const fem_cloth::ClothState& c) { return c.positions[30].z == at.z + 0.3; });
  EXPECT_TRUE(there) << "the jump was not taken";
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_pins");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
