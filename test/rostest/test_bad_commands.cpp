// Every kind of bad command is rejected whole, with a warning that names the problem on
// /diagnostics, and the node keeps publishing finite states; ~reset restores the initial state.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <shape_msgs/Mesh.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include <limits>

#include "fem_cloth/Advance.h"
#include "fem_cloth/ForceCommand.h"
#include "fem_cloth/PinCommand.h"
#include "node_test_support.h"

using namespace fem_cloth_test;

namespace {

class BadCommands : public testing::Test {
 protected:
  void SetUp() override {
    pinPub_ = nh_.advertise<fem_cloth::PinCommand>(topic("pin"), 10);
    forcePub_ = nh_.advertise<fem_cloth::ForceCommand>(topic("force"), 10);
    ASSERT_TRUE(waitForConnection(pinPub_));
    ASSERT_TRUE(waitForConnection(forcePub_));
  }

  // Publishes, then waits for a diagnostics status whose message contains `expected`.
  template <class M>
  void expectRejected(ros::Publisher& pub, const M& command, const std::string& expected) {
    Latest<diagnostic_msgs::DiagnosticArray> diagnostics("/diagnostics");
    ros::WallDuration(0.2).sleep();
    pub.publish(command);
    auto d = diagnostics.waitFor([&](const diagnostic_msgs::DiagnosticArray& a) {
      for (const auto& s : a.status) {
        if (s.level == diagnostic_msgs::DiagnosticStatus::WARN &&
            s.message.find(expected) != std::string::npos) {
          return true;
        }
      }
      return false;
    }, 10.0);
    EXPECT_TRUE(d) << "no WARN on /diagnostics containing '" << expected << "'";
    // The node goes on publishing finite states, with vertex 40 (never validly pinned) free.
    Latest<fem_cloth::ClothState> state(topic("state"));
    auto s = state.waitForNext();
    ASSERT_TRUE(s);
    EXPECT_TRUE(finite(*s));
    EXPECT_NE(s->positions[40].z, 5.0);
  }

  fem_cloth::PinCommand pinAt(std::vector<std::uint32_t> vertices, double z) {
    fem_cloth::PinCommand c;
    c.header.frame_id = "world";
    c.action = fem_cloth::PinCommand::PIN_AT_TARGETS;
    c.vertices = std::move(vertices);
    geometry_msgs::Point p;
    p.z = z;
    c.targets.assign(c.vertices.size(), p);
    return c;
  }

  ros::NodeHandle nh_;
  ros::Publisher pinPub_, forcePub_;
};

}  // namespace

TEST_F(BadCommands, UnknownVertex) {
  expectRejected(pinPub_, pinAt({40, 9999}, 5.0), "vertex 9999 (vertices[1]) does not exist");
}

TEST_F(BadCommands, NanTarget) {
  auto c = pinAt({40}, std::numeric_limits<double>::quiet_NaN());
  expectRejected(pinPub_, c, "target 0 (vertex 40) is not finite");
}

TEST_F(BadCommands, MismatchedLengths) {
  auto c = pinAt({40}, 5.0);
  c.vertices = {40, 41};
  expectRejected(pinPub_, c, "2 vertices but 1 targets");
}

TEST_F(BadCommands, UnknownAction) {
  auto c = pinAt({40}, 5.0);
  c.action = 7;
  expectRejected(pinPub_, c, "unknown action 7");
}

TEST_F(BadCommands, UnknownFrame) {
  auto c = pinAt({40}, 5.0);
  c.header.frame_id = "no_such_frame";
  expectRejected(pinPub_, c, "unknown frame 'no_such_frame'");
}

TEST_F(BadCommands, StaleFrame) {
  // A frame whose transforms are all about 30 s old (tf_timeout is 1 s). Broadcast for a second,
  // with distinct stamps, so the node's listener surely has them.
  tf2_ros::TransformBroadcaster br;
  geometry_msgs::TransformStamped tf;
  tf.header.frame_id = "world";
  tf.child_frame_id = "old_gripper";
  tf.transform.rotation.w = 1.0;
  const ros::Time old = ros::Time::now() - ros::Duration(30.0);
  for (int k = 0; k < 20; ++k) {
    tf.header.stamp = old + ros::Duration(0.001 * k);
    br.sendTransform(tf);
    ros::WallDuration(0.05).sleep();
  }
  auto c = pinAt({40}, 5.0);
  c.header.frame_id = "old_gripper";
  expectRejected(pinPub_, c, "frame 'old_gripper' is stale");
}

TEST_F(BadCommands, InfiniteForce) {
  fem_cloth::ForceCommand c;
  c.header.frame_id = "world";
  c.action = fem_cloth::ForceCommand::APPLY;
  c.vertices = {40};
  geometry_msgs::Vector3 f;
  f.z = std::numeric_limits<double>::infinity();
  c.forces = {f};
  expectRejected(forcePub_, c, "force 0 is not finite");
}

TEST_F(BadCommands, ForceCountMismatch) {
  fem_cloth::ForceCommand c;
  c.header.frame_id = "world";
  c.action = fem_cloth::ForceCommand::APPLY;
  c.vertices = {40, 41, 42};
  c.forces.resize(2);
  expectRejected(forcePub_, c, "APPLY has 3 vertices but 2 forces");
}

TEST(Reset, RestoresTheInitialState) {
  ros::NodeHandle nh;
  Latest<shape_msgs::Mesh> mesh(topic("mesh"));
  auto m = mesh.waitForAny();
  ASSERT_TRUE(m);
  Latest<fem_cloth::ClothState> state(topic("state"));
  // Let it fall for a while.
  ASSERT_TRUE(state.waitFor([](const fem_cloth::ClothState& s) { return s.step > 50; }));
  ros::ServiceClient reset = nh.serviceClient<std_srvs::Trigger>(topic("reset"));
  ASSERT_TRUE(reset.waitForExistence(ros::Duration(10.0)));
  std_srvs::Trigger srv;
  ASSERT_TRUE(reset.call(srv));
  EXPECT_TRUE(srv.response.success);
  // The first state after the reset is the initial one: step 0 at the rest positions.
  auto s = state.waitFor([](const fem_cloth::ClothState& st) { return st.step == 0; }, 10.0);
  ASSERT_TRUE(s) << "no state with step 0 after ~reset";
  ASSERT_EQ(s->positions.size(), m->vertices.size());
  for (std::size_t i = 0; i < s->positions.size(); ++i) {
    EXPECT_EQ(s->positions[i].x, m->vertices[i].x);
    EXPECT_EQ(s->positions[i].y, m->vertices[i].y);
    EXPECT_EQ(s->positions[i].z, m->vertices[i].z);
  }
}

TEST(Advance, StepsAPausedSimulationSynchronously) {
  ros::NodeHandle nh;
  ros::ServiceClient pause = nh.serviceClient<std_srvs::Trigger>(topic("pause"));
  ros::ServiceClient advance = nh.serviceClient<fem_cloth::Advance>(topic("advance"));
  ros::ServiceClient resume = nh.serviceClient<std_srvs::Trigger>(topic("resume"));
  ASSERT_TRUE(advance.waitForExistence(ros::Duration(10.0)));
  // Refused while running.
  fem_cloth::Advance a;
  a.request.steps = 3;
  ASSERT_TRUE(advance.call(a));
  EXPECT_FALSE(a.response.success);
  std_srvs::Trigger t;
  ASSERT_TRUE(pause.call(t));
  Latest<fem_cloth::ClothState> state(topic("state"));
  ASSERT_TRUE(state.waitConnected());
  ASSERT_TRUE(advance.call(a));
  ASSERT_TRUE(a.response.success) << a.response.message;
  const std::uint64_t first = a.response.step;
  a.request.steps = 7;
  ASSERT_TRUE(advance.call(a));
  ASSERT_TRUE(a.response.success) << a.response.message;
  // Exactly 7 more steps of dt = 0.01 s, and paused: nothing moves in between.
  EXPECT_EQ(a.response.step, first + 7);
  auto s = state.waitFor([&](const fem_cloth::ClothState& m) { return m.step == a.response.step; }, 10.0);
  ASSERT_TRUE(s) << "no state for the step ~advance reported";
  EXPECT_EQ(s->state_hash, a.response.state_hash);
  ros::WallDuration(0.3).sleep();
  a.request.steps = 0;
  ASSERT_TRUE(advance.call(a));
  EXPECT_EQ(a.response.step, first + 8);
  EXPECT_NEAR(a.response.time, 0.01 * static_cast<double>(a.response.step), 1e-9);
  ASSERT_TRUE(resume.call(t));
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_bad_commands");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
