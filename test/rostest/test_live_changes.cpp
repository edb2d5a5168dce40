// The live services as a client calls them (docs/node.md, Live changes): ~set refuses a bad pair
// naming it and changes nothing, applies a good one at a step boundary and publishes it on
// ~applied_set; ~add_obstacle adds an obstacle that shows in ~obstacle_markers and gets its
// wrench topic, ~move_obstacle moves it, ~remove_obstacle takes it away; ~grasp_nearest pins
// exactly the vertices within the radius (counted here from ~state), following its frame; each
// grasp frame has a wrench topic of its own, and at rest together they carry the cloth's weight
// under the gravity ~set gave it.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/WrenchStamped.h>
#include <tf2_msgs/TFMessage.h>
#include <visualization_msgs/MarkerArray.h>

#include <cmath>
#include <map>
#include <mutex>
#include <set>
#include <vector>

#include "fem_cloth/GraspNearest.h"
#include "fem_cloth/ObstacleChange.h"
#include "fem_cloth/Set.h"
#include "fem_cloth/SetCommand.h"
#include "fem_cloth/StepStats.h"
#include "node_test_support.h"

using namespace fem_cloth_test;

TEST(LiveChanges, SetRefusesABadPairWholeAndAppliesAGoodOne) {
  ros::NodeHandle nh;
  ASSERT_TRUE(ros::service::waitForService(topic("set"), 20000));
  Latest<fem_cloth::SetCommand> applied(topic("applied_set"));
  fem_cloth::Set bad;
  bad.request.pairs = {"damping.mass=1.0", "material.poisson_ratio=0.7"};
  ASSERT_TRUE(ros::service::call(topic("set"), bad));
  EXPECT_FALSE(bad.response.success);
  EXPECT_NE(bad.response.message.find("material.poisson_ratio"), std::string::npos) << bad.response.message;
  fem_cloth::Set frozen;
  frozen.request.pairs = {"mesh.rows=5"};
  ASSERT_TRUE(ros::service::call(topic("set"), frozen));
  EXPECT_FALSE(frozen.response.success);
  EXPECT_NE(frozen.response.message.find("'mesh.rows' cannot change while running"), std::string::npos)
      << frozen.response.message;

  ASSERT_TRUE(applied.waitConnected());
  fem_cloth::Set good;
  good.request.pairs = {"gravity=[0, 0, -2]", "damping.mass=1.0"};
  ASSERT_TRUE(ros::service::call(topic("set"), good));
  EXPECT_TRUE(good.response.success) << good.response.message;
  auto msg = applied.waitForAny(20.0);
  ASSERT_TRUE(msg);
  EXPECT_EQ(msg->pairs, good.request.pairs);
  EXPECT_GT(msg->header.stamp.toSec(), 0.0);
  EXPECT_EQ(applied.count(), 1u) << "the refused pairs were applied too";
}

TEST(LiveChanges, AddedObstacleShowsAndHasItsWrenchTopic) {
  ros::NodeHandle nh;
  ASSERT_TRUE(ros::service::waitForService(topic("add_obstacle"), 20000));
  fem_cloth::ObstacleChange add;
  add.request.name = "ball";
  add.request.entry = "{type: sphere, center: [0.5, 0.5, -0.6], radius: 0.15}";
  ASSERT_TRUE(ros::service::call(topic("add_obstacle"), add));
  ASSERT_TRUE(add.response.success) << add.response.message;
  Latest<visualization_msgs::MarkerArray> markers(topic("obstacle_markers"));
  auto m = markers.waitFor([](const visualization_msgs::MarkerArray& a) {
    for (const auto& k : a.markers) {
      if (k.type == visualization_msgs::Marker::SPHERE && std::abs(k.scale.x - 0.3) < 1e-12) return true;
    }
    return false;
  }, 20.0);
  ASSERT_TRUE(m) << "no sphere of diameter 0.3 m in ~obstacle_markers";
  Latest<geometry_msgs::WrenchStamped> wrench(topic("obstacles/ball/wrench"));
  EXPECT_TRUE(wrench.waitForAny(20.0));
  fem_cloth::ObstacleChange again = add;
  ASSERT_TRUE(ros::service::call(topic("add_obstacle"), again));
  EXPECT_FALSE(again.response.success);
  EXPECT_NE(again.response.message.find("'ball' exists already"), std::string::npos) << again.response.message;
  // A name that cannot name its wrench topic is refused by the service itself, as the node would
  // refuse it later (the service and the node share one check).
  fem_cloth::ObstacleChange badName = add;
  badName.request.name = "two/balls";
  ASSERT_TRUE(ros::service::call(topic("add_obstacle"), badName));
  EXPECT_FALSE(badName.response.success);
  EXPECT_NE(badName.response.message.find("refused, nothing changed: obstacle 'two/balls': its name must be a valid "
                                          "ROS name without '/'"), std::string::npos) << badName.response.message;

  // Moved: its marker is at the new centre. Removed: no sphere is left.
  fem_cloth::ObstacleChange move;
  move.request.name = "ball";
  move.request.entry = "{center: [0.5, 0.5, -1.5]}";
  ASSERT_TRUE(ros::service::call(topic("move_obstacle"), move));
  ASSERT_TRUE(move.response.success) << move.response.message;
  auto sphereAt = [](double z) {
    return [z](const visualization_msgs::MarkerArray& a) {
      for (const auto& k : a.markers) {
        if (k.type == visualization_msgs::Marker::SPHERE && k.pose.position.z == z) return true;
      }
      return false;
    };
  };
  EXPECT_TRUE(markers.waitFor(sphereAt(-1.5), 20.0)) << "the moved ball is not at z = -1.5 m";
  fem_cloth::ObstacleChange remove;
  remove.request.name = "ball";
  ASSERT_TRUE(ros::service::call(topic("remove_obstacle"), remove));
  ASSERT_TRUE(remove.response.success) << remove.response.message;
  EXPECT_TRUE(markers.waitFor([](const visualization_msgs::MarkerArray& a) {
    for (const auto& k : a.markers) {
      if (k.type == visualization_msgs::Marker::SPHERE) return false;
    }
    return true;
  }, 20.0)) << "the removed ball is still in ~obstacle_markers";
  ASSERT_TRUE(ros::service::call(topic("remove_obstacle"), remove));
  EXPECT_FALSE(remove.response.success);
  EXPECT_NE(remove.response.message.find("no obstacle named 'ball'"), std::string::npos) << remove.response.message;
}

TEST(LiveChanges, GraspNearestPinsTheVerticesWithinTheRadius) {
  ros::NodeHandle nh;
  ASSERT_TRUE(ros::service::waitForService(topic("grasp_nearest"), 20000));
  // A gripper frame where world is (so a point reads the same in both), stamped ahead so that
  // the node can interpolate at every step's end.
  ros::Publisher tfPub = nh.advertise<tf2_msgs::TFMessage>("/tf", 100);
  ASSERT_TRUE(waitForConnection(tfPub));
  TfBroadcaster broadcaster(tfPub, [] { return frameAt("world", "gripper", ros::Time::now() + ros::Duration(0.2), 0, 0, 0); });
  ros::WallDuration(0.3).sleep();
  // Every state, in order: the one the grasp was made in is found among them below.
  std::mutex statesMutex;
  std::vector<fem_cloth::ClothState> states;
  Latest<fem_cloth::ClothState> state(topic("state"), [&](const fem_cloth::ClothState& m) {
    std::lock_guard<std::mutex> lock(statesMutex);
    states.push_back(m);
  });
  auto s = state.waitForAny();
  ASSERT_TRUE(s);
  // Around the free corner's vertex 80 (row 8, column 8): the vertices within 0.2 m of it now.
  const geometry_msgs::Point c = s->positions[80];
  const double radius = 0.2;
  fem_cloth::GraspNearest grasp;
  grasp.request.frame_id = "gripper";
  grasp.request.point = c;
  grasp.request.radius = radius;
  ASSERT_TRUE(ros::service::call(topic("grasp_nearest"), grasp));
  ASSERT_TRUE(grasp.response.success) << grasp.response.message;
  ASSERT_FALSE(grasp.response.vertices.empty()) << grasp.response.message;
  const std::size_t seen = state.count();
  auto later = state.waitFor([&](const fem_cloth::ClothState&) { return state.count() >= seen + 10; });
  ASSERT_TRUE(later);
  std::set<std::uint32_t> pinned(grasp.response.vertices.begin(), grasp.response.vertices.end());
  // The state the grasp was made in: the first one after which every grasped vertex stands
  // exactly still (the cloth swings, so before the grasp they move). States that were on their
  // way when the service returned come before it, however loaded the machine.
  std::vector<fem_cloth::ClothState> recorded;
  {
    std::lock_guard<std::mutex> lock(statesMutex);
    recorded = states;
  }
  auto still = [&](const fem_cloth::ClothState& a, const fem_cloth::ClothState& b) {
    for (std::uint32_t v : pinned) {
      if (a.positions[v].x != b.positions[v].x || a.positions[v].z != b.positions[v].z) return false;
    }
    return b.step > a.step;
  };
  const fem_cloth::ClothState* held = nullptr;
  for (std::size_t i = 0; i + 1 < recorded.size() && held == nullptr; ++i) {
    if (still(recorded[i], recorded[i + 1])) held = &recorded[i];
  }
  ASSERT_NE(held, nullptr) << "no two consecutive states with the grasped vertices still";
  auto distance = [&](const geometry_msgs::Point& p) {
    return std::sqrt((p.x - c.x) * (p.x - c.x) + (p.y - c.y) * (p.y - c.y) + (p.z - c.z) * (p.z - c.z));
  };
  for (std::uint32_t v = 0; v < held->positions.size(); ++v) {
    if (pinned.count(v)) {
      // Pinned where it was when grasped: still there, and it was within the radius.
      EXPECT_EQ(later->positions[v].x, held->positions[v].x) << v;
      EXPECT_EQ(later->positions[v].z, held->positions[v].z) << v;
      EXPECT_LE(distance(held->positions[v]), radius) << v;
    } else {
      // Not grasped: it was outside the radius (1 cm of margin, should a state have been lost).
      EXPECT_GT(distance(held->positions[v]), radius - 0.01) << v;
    }
  }
  EXPECT_TRUE(std::find(grasp.response.vertices.begin(), grasp.response.vertices.end(), 80u) !=
              grasp.response.vertices.end());
  fem_cloth::GraspNearest none;
  none.request.point = c;
  none.request.radius = -1.0;
  ASSERT_TRUE(ros::service::call(topic("grasp_nearest"), none));
  EXPECT_FALSE(none.response.success);

  // One wrench topic per grasp frame: the gripper's grasp, and the corners fixed in world. At
  // rest the two together hold the cloth up: the force it exerts on them sums to its weight,
  // m g = (2000 kg/m^3 x 1 m^2 x 0.5 mm) x 2 m/s^2 = 2 N down, under the gravity the first test
  // set (damping back up, so that it settles soon).
  fem_cloth::Set damp;
  damp.request.pairs = {"damping.mass=4.0"};
  ASSERT_TRUE(ros::service::call(topic("set"), damp));
  ASSERT_TRUE(damp.response.success) << damp.response.message;
  Latest<fem_cloth::ClothEnergy> energy(topic("energy"));
  Latest<geometry_msgs::WrenchStamped> gripper(topic("grasp/gripper/wrench"));
  Latest<geometry_msgs::WrenchStamped> world(topic("grasp/world/wrench"));
  // Connected before the wait for rest, and generous timeouts: on a loaded machine a new
  // subscription and the node's steps both take seconds.
  ASSERT_TRUE(gripper.waitConnected(20.0) && world.waitConnected(20.0));
  ASSERT_TRUE(energy.waitFor([](const fem_cloth::ClothEnergy& e) { return e.kinetic < 1e-7; }, 40.0))
      << "the cloth did not come to rest";
  auto g = gripper.waitForNext(20.0);
  auto w = world.waitForNext(20.0);
  ASSERT_TRUE(g && w);
  EXPECT_EQ(g->header.frame_id, "gripper");
  EXPECT_EQ(w->header.frame_id, "world");
  // How the weight splits depends on where the corner was when grasped (held above its hanging
  // place, the cloth pushes the gripper up): only the sum is known.
  EXPECT_NEAR(g->wrench.force.z + w->wrench.force.z, -2.0, 0.01);
  EXPECT_NEAR(g->wrench.force.x + w->wrench.force.x, 0.0, 0.01);
  EXPECT_NEAR(g->wrench.force.y + w->wrench.force.y, 0.0, 0.01);
}

// ~stats and /diagnostics count the requests of the live services on the topic each queues on:
// a request a service refuses is received and rejected, a good one received and applied. Other
// tests ran first on the same node, so the counts are compared with those read before.
TEST(LiveChanges, StatsAndDiagnosticsCountTheServicesRequests) {
  ros::NodeHandle nh;
  ASSERT_TRUE(ros::service::waitForService(topic("set"), 20000));
  ASSERT_TRUE(ros::service::waitForService(topic("remove_obstacle"), 20000));
  ASSERT_TRUE(ros::service::waitForService(topic("grasp_nearest"), 20000));
  Latest<fem_cloth::StepStats> stats(topic("stats"));
  Latest<diagnostic_msgs::DiagnosticArray> diagnostics("/diagnostics");
  auto entry = [](const fem_cloth::StepStats& s, const std::string& name) {
    for (const fem_cloth::CommandStats& c : s.commands) {
      if (c.topic == name) return c;
    }
    ADD_FAILURE() << "no '" << name << "' in ~stats.commands";
    return fem_cloth::CommandStats();
  };
  auto before = stats.waitForAny();
  ASSERT_TRUE(before);
  ASSERT_EQ(before->commands.size(), 5u);
  const std::vector<std::string> order = {"pin", "force", "set", "obstacle", "grasp"};
  for (std::size_t k = 0; k < order.size(); ++k) EXPECT_EQ(before->commands[k].topic, order[k]);
  EXPECT_EQ(before->pin_commands, before->commands[0]);
  const fem_cloth::CommandStats set0 = entry(*before, "set"), obstacle0 = entry(*before, "obstacle"),
                                grasp0 = entry(*before, "grasp");

  fem_cloth::Set bad, good;
  bad.request.pairs = {"material.poisson_ratio=0.7"};
  good.request.pairs = {"damping.mass=4.0"};
  fem_cloth::ObstacleChange remove;
  remove.request.name = "no_such_obstacle";
  fem_cloth::GraspNearest none;
  none.request.radius = -1.0;
  ASSERT_TRUE(ros::service::call(topic("set"), bad) && ros::service::call(topic("set"), good) &&
              ros::service::call(topic("remove_obstacle"), remove) && ros::service::call(topic("grasp_nearest"), none));
  EXPECT_FALSE(bad.response.success);
  EXPECT_TRUE(good.response.success) << good.response.message;
  EXPECT_FALSE(remove.response.success);
  EXPECT_FALSE(none.response.success);

  // set: 2 received, 1 rejected, 1 applied (once it took effect); obstacle, grasp: 1 rejected.
  // Counted by a message of a step after the calls (those queued before them are older).
  const ros::Time called = ros::Time::now();
  auto after = stats.waitFor([&](const fem_cloth::StepStats& s) {
    return s.header.stamp > called && s.commands.size() == 5 && s.commands[2].applied == set0.applied + 1;
  });
  ASSERT_TRUE(after) << "the good ~set was not counted as applied";
  const fem_cloth::CommandStats set = entry(*after, "set"), obstacle = entry(*after, "obstacle"),
                                grasp = entry(*after, "grasp");
  EXPECT_EQ(set.received, set0.received + 2);
  EXPECT_EQ(set.rejected, set0.rejected + 1);
  EXPECT_EQ(obstacle.received, obstacle0.received + 1);
  EXPECT_EQ(obstacle.rejected, obstacle0.rejected + 1);
  EXPECT_EQ(obstacle.applied, obstacle0.applied);
  EXPECT_EQ(grasp.received, grasp0.received + 1);
  EXPECT_EQ(grasp.rejected, grasp0.rejected + 1);
  EXPECT_EQ(grasp.applied, grasp0.applied);
  for (const fem_cloth::CommandStats& c : after->commands) {
    EXPECT_EQ(c.received, c.rejected + c.applied + c.pending + c.discarded) << c.topic;
  }
  // /diagnostics shows the same counts (sent at least once a second).
  auto d = diagnostics.waitFor([&](const diagnostic_msgs::DiagnosticArray& a) {
    for (const auto& status : a.status) {
      for (const auto& kv : status.values) {
        if (kv.key == "~set commands applied") return kv.value == std::to_string(set.applied);
      }
    }
    return false;
  }, 10.0);
  ASSERT_TRUE(d) << "no /diagnostics with '~set commands applied' = " << set.applied;
  std::map<std::string, std::string> values;
  for (const auto& kv : d->status.at(0).values) values[kv.key] = kv.value;
  EXPECT_EQ(values["~set commands rejected"], std::to_string(set.rejected));
  EXPECT_EQ(values["~obstacle commands rejected"], std::to_string(obstacle.rejected));
  EXPECT_EQ(values["~grasp commands received"], std::to_string(grasp.received));
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_live_changes");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
