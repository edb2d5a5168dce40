// Contact in the node (test/rostest/config/small_table.yaml, started paused): the table arrives
// as an RViz marker of its size and place; the cloth dropped on it never goes below its top in
// any published state from the first one on; at rest the table carries the cloth's whole weight (its wrench topic) and ~stats counts
// the contacts.
#include <geometry_msgs/WrenchStamped.h>
#include <std_srvs/Trigger.h>
#include <visualization_msgs/MarkerArray.h>

#include "fem_cloth/StepStats.h"
#include "node_test_support.h"

using namespace fem_cloth_test;

namespace {

// From the scene file: a 0.5 m square at 0.2 kg/m^2 (density 400 kg/m^3 x 0.5 mm).
constexpr double kWeight = 0.5 * 0.5 * 0.2 * 9.81;  // N
constexpr double kTableTop = 0.5;                    // m

}  // namespace

TEST(Contact, TheTableIsShownWhereTheSceneSaysItIs) {
  Latest<visualization_msgs::MarkerArray> markers(topic("obstacle_markers"));
  auto m = markers.waitForAny();
  ASSERT_TRUE(m);
  ASSERT_EQ(m->markers.size(), 1u);
  const visualization_msgs::Marker& table = m->markers[0];
  EXPECT_EQ(table.type, visualization_msgs::Marker::CUBE);
  EXPECT_EQ(table.header.frame_id, "world");
  EXPECT_NEAR(table.pose.position.z, 0.25, 1e-12);
  EXPECT_NEAR(table.scale.x, 1.0, 1e-12);
  EXPECT_NEAR(table.scale.y, 1.0, 1e-12);
  EXPECT_NEAR(table.scale.z, 0.5, 1e-12);
}

TEST(Contact, TheClothLandsOnTheTableAndItCarriesTheWeight) {
  // Every state received, until the cloth is at rest: no vertex below the table top.
  double lowest = 1.0;
  int states = 0;
  bool allFinite = true;
  Latest<fem_cloth::ClothState> state(topic("state"), [&](const fem_cloth::ClothState& s) {
    for (const auto& p : s.positions) lowest = std::min(lowest, p.z);
    allFinite = allFinite && finite(s);
    ++states;
  });
  Latest<fem_cloth::ClothEnergy> energy(topic("energy"));
  Latest<geometry_msgs::WrenchStamped> wrench(topic("obstacles/table/wrench"));
  Latest<fem_cloth::StepStats> stats(topic("stats"));
  // The node starts paused (contact.test): resume once subscribed, so that every state of the
  // fall is seen.
  ASSERT_TRUE(state.waitConnected() && energy.waitConnected() && wrench.waitConnected() &&
              stats.waitConnected());
  ros::NodeHandle nh;
  ros::ServiceClient resume = nh.serviceClient<std_srvs::Trigger>(topic("resume"));
  ASSERT_TRUE(resume.waitForExistence(ros::Duration(10.0)));
  std_srvs::Trigger call;
  ASSERT_TRUE(resume.call(call) && call.response.success) << call.response.message;
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(60.0);
  bool atRest = false;
  while (!atRest && ros::WallTime::now() < end) {
    auto s = state.waitForNext();
    ASSERT_TRUE(s);
    auto e = energy.waitForAny(1.0);
    // Landed (it starts at rest 2 cm up, and falls for 64 ms), and damped at 4 /s to a kinetic
    // energy below 1e-12 J: |v| < 1e-5 m/s for 0.05 kg.
    atRest = e && s->step > 100 && lowest < kTableTop + 1e-3 && e->kinetic < 1e-12;
  }
  ASSERT_TRUE(atRest) << "the cloth did not come to rest on the table";
  EXPECT_TRUE(allFinite);
  std::cout << states << " states, lowest vertex " << lowest << " m\n";
  EXPECT_GE(lowest, kTableTop);
  EXPECT_LT(lowest, kTableTop + 1e-3) << "it rests within the contact distance of the top";
  // At rest the barrier balances the weight; the Newton tolerance leaves unbalanced forces of
  // order 1e-5 N per vertex (81 vertices), the damping drag is below 2e-6 N: allow 1 %.
  auto w = wrench.waitForNext();
  ASSERT_TRUE(w);
  EXPECT_NEAR(w->wrench.force.z, -kWeight, 0.01 * kWeight);
  EXPECT_NEAR(w->wrench.force.x, 0.0, 0.01 * kWeight);
  EXPECT_NEAR(w->wrench.force.y, 0.0, 0.01 * kWeight);
  auto st = stats.waitForNext();
  ASSERT_TRUE(st);
  // Every vertex of the flat cloth lies within the contact distance of the top.
  EXPECT_EQ(st->contacts, 81u);
  // Flat on the top, every point of it above the table: nothing reached into the box.
  EXPECT_EQ(st->max_box_depth, 0.0) << st->max_box_depth_where;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_contact");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
