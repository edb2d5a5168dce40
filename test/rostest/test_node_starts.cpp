// The node starts from the launch file: ~mesh arrives latched, states flow, the cloth falls under
// gravity (its potential energy drops), and no message carries a NaN.
#include <shape_msgs/Mesh.h>

#include "fem_cloth/StepStats.h"
#include "node_test_support.h"

using namespace fem_cloth_test;

TEST(NodeStarts, MeshIsLatchedAndMatchesTheScene) {
  // Subscribing after the node published still delivers the mesh: it is latched.
  Latest<shape_msgs::Mesh> mesh(topic("mesh"));
  auto m = mesh.waitForAny();
  ASSERT_TRUE(m) << "no ~mesh";
  // 9 x 9 grid: 81 vertices, 2 * 8 * 8 triangles (test/rostest/config/small_cloth.yaml).
  EXPECT_EQ(m->vertices.size(), 81u);
  EXPECT_EQ(m->triangles.size(), 128u);
  // Vertex (8, 8) of the 1 m grid sits at (1, 1, 0).
  EXPECT_DOUBLE_EQ(m->vertices[80].x, 1.0);
  EXPECT_DOUBLE_EQ(m->vertices[80].y, 1.0);
}

TEST(NodeStarts, ClothFallsAndEverythingIsFinite) {
  bool allFinite = true;
  Latest<fem_cloth::ClothState> state(topic("state"), [&](const fem_cloth::ClothState& s) {
    allFinite = allFinite && finite(s);
  });
  Latest<fem_cloth::ClothEnergy> energy(topic("energy"), [&](const fem_cloth::ClothEnergy& e) {
    allFinite = allFinite && finite(e);
  });
  Latest<fem_cloth::StepStats> stats(topic("stats"));
  auto first = energy.waitForAny();
  ASSERT_TRUE(first) << "no ~energy";
  // Wait for 0.5 s of simulated time more.
  auto later = energy.waitFor([&](const fem_cloth::ClothEnergy& e) {
    return (e.header.stamp - first->header.stamp).toSec() >= 0.5;
  });
  ASSERT_TRUE(later);
  // Falling from rest under gravity: the gravitational potential drops, by a lot more than
  // round-off (the free corner of a 1 m cloth falls about 1 m).
  EXPECT_LT(later->gravity, first->gravity - 0.1);
  auto s = state.waitForAny();
  ASSERT_TRUE(s);
  EXPECT_EQ(s->positions.size(), 81u);
  EXPECT_EQ(s->header.frame_id, "world");
  EXPECT_EQ(s->state_hash.size(), 16u);
  // The pinned corners (vertices 0 and 8) stay exactly at their rest positions.
  EXPECT_EQ(s->positions[0].x, 0.0);
  EXPECT_EQ(s->positions[0].z, 0.0);
  EXPECT_EQ(s->positions[8].x, 1.0);
  auto st = stats.waitForAny();
  ASSERT_TRUE(st);
  EXPECT_EQ(st->integrator, "backward_euler");
  EXPECT_DOUBLE_EQ(st->dt, 0.01);
  EXPECT_TRUE(std::isfinite(st->residual));
  EXPECT_TRUE(allFinite);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_node_starts");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
