// Forces and reactions: a force command moves vertices along the force, and at rest the pin
// reactions balance the cloth's weight.
#include "fem_cloth/ForceCommand.h"
#include "fem_cloth/PinForces.h"
#include "node_test_support.h"

using namespace fem_cloth_test;

TEST(Forces, PinReactionsBalanceGravityAtRest) {
  Latest<fem_cloth::ClothEnergy> energy(topic("energy"));
  Latest<fem_cloth::PinForces> reactions(topic("pin_forces"));
  // Damped (damping.mass 4 /s): wait until the cloth is at rest. The damping drag 4/s x M v also
  // loads the pins while the cloth creeps; kinetic energy below 1e-10 J means |v| < 1.5e-5 m/s
  // and a drag below 1e-4 N.
  auto settled = energy.waitFor([](const fem_cloth::ClothEnergy& e) {
    return e.header.stamp.toSec() > 0 && e.kinetic < 1e-10;
  }, 60.0);
  ASSERT_TRUE(settled) << "the cloth did not come to rest";
  auto r = reactions.waitForNext();
  ASSERT_TRUE(r);
  ASSERT_EQ(r->vertices.size(), 2u);
  double fz = 0.0, fx = 0.0, fy = 0.0;
  for (const auto& f : r->forces) {
    fx += f.x;
    fy += f.y;
    fz += f.z;
  }
  // Mass: 1 m^2 x density 2000 kg/m^3 x thickness 0.5 mm = 1 kg; the cloth pulls its pins
  // down with its weight, 9.81 N, and (symmetric) no net horizontal force. The scene's tight
  // Newton tolerance leaves the vertices' unbalanced forces far below 1e-3 N in all, and the
  // damping drag at rest is below 1e-4 N; allow 2e-3 N.
  const double bound = 2e-3;
  EXPECT_NEAR(fz, -9.81, bound);
  EXPECT_NEAR(fx, 0.0, bound);
  EXPECT_NEAR(fy, 0.0, bound);
}

TEST(Forces, ForceMovesVerticesAlongIt) {
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<fem_cloth::ForceCommand>(topic("force"), 10);
  ASSERT_TRUE(waitForConnection(pub));
  Latest<fem_cloth::ClothState> state(topic("state"));
  auto before = state.waitForAny();
  ASSERT_TRUE(before);
  // One force for all free vertices: 0.01 N each along +y, perpendicular to the hanging cloth,
  // 0.79 N in all against its 9.81 N weight: the cloth swings out along +y by a few degrees,
  // and by symmetry its centroid does not move along x.
  fem_cloth::ForceCommand c;
  c.header.frame_id = "world";
  c.action = fem_cloth::ForceCommand::APPLY;
  for (std::uint32_t v = 0; v < 81; ++v) {
    if (v != 0 && v != 8) c.vertices.push_back(v);
  }
  geometry_msgs::Vector3 f;
  f.y = 0.01;
  c.forces = {f};
  pub.publish(c);
  auto after = state.waitFor([&](const fem_cloth::ClothState& s) {
    return (s.header.stamp - before->header.stamp).toSec() > 1.0;
  });
  ASSERT_TRUE(after);
  ASSERT_TRUE(finite(*after));
  double dx = 0.0, dy = 0.0;
  for (std::size_t i = 0; i < 81; ++i) {
    dx += (after->positions[i].x - before->positions[i].x) / 81.0;
    dy += (after->positions[i].y - before->positions[i].y) / 81.0;
  }
  EXPECT_GT(dy, 0.01);
  EXPECT_LT(std::abs(dx), 0.01 * dy);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_forces");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
