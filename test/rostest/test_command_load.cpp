// 5000 force commands at 1 kHz (the issue 11 load: the node's subscriber queue of 100 used to
// drop about 120 of them, and nothing counted them): every one is applied, each is published on
// ~applied_force, and ~stats counts 5000 received, 5000 applied, none rejected or pending.
#include "fem_cloth/ForceCommand.h"
#include "fem_cloth/StepStats.h"
#include "node_test_support.h"

using namespace fem_cloth_test;

TEST(CommandLoad, FiveThousandForcesAtOneKilohertzAreAllAppliedAndCounted) {
  constexpr std::uint32_t kCommands = 5000;
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<fem_cloth::ForceCommand>(topic("force"), kCommands);
  ASSERT_TRUE(waitForConnection(pub));
  // Each command says which it is (its force's x, in mN), so the test can tell that every one
  // arrived exactly once, in order.
  std::vector<int> seen;
  std::mutex mutex;
  // Queued for the whole run: the test spins only after sending.
  ros::Subscriber applied = nh.subscribe<fem_cloth::ForceCommand>(
      topic("applied_force"), kCommands, [&](const fem_cloth::ForceCommand::ConstPtr& c) {
        std::lock_guard<std::mutex> lock(mutex);
        seen.push_back(static_cast<int>(std::lround(1e3 * c->forces.at(0).x)));
      });
  const ros::WallTime connect = ros::WallTime::now() + ros::WallDuration(10.0);
  while (applied.getNumPublishers() == 0 && ros::WallTime::now() < connect) ros::WallDuration(0.01).sleep();
  ASSERT_GT(applied.getNumPublishers(), 0u);
  Latest<fem_cloth::StepStats> stats(topic("stats"));
  ASSERT_TRUE(stats.waitForAny());
  ros::Rate rate(1000.0);
  for (std::uint32_t k = 0; k < kCommands; ++k) {
    fem_cloth::ForceCommand c;
    c.header.frame_id = "world";  // zero stamp: before the next step
    c.action = fem_cloth::ForceCommand::APPLY;
    c.vertices = {40};
    c.forces.resize(1);
    c.forces[0].x = 1e-3 * static_cast<double>(k);
    pub.publish(c);
    rate.sleep();
  }
  auto done = stats.waitFor([&](const fem_cloth::StepStats& s) {
    return s.force_commands.applied + s.force_commands.rejected >= kCommands;
  }, 60.0);
  ASSERT_TRUE(done) << "the node's counts never reached " << kCommands;
  EXPECT_EQ(done->force_commands.received, kCommands);
  EXPECT_EQ(done->force_commands.applied, kCommands);
  EXPECT_EQ(done->force_commands.rejected, 0u);
  EXPECT_EQ(done->force_commands.pending, 0u);
  EXPECT_EQ(done->pin_commands.received, 0u);
  // And every one came out on ~applied_force, once, in the order sent.
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(30.0);
  while (ros::WallTime::now() < end) {
    ros::spinOnce();
    std::lock_guard<std::mutex> lock(mutex);
    if (seen.size() >= kCommands) break;
  }
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_EQ(seen.size(), kCommands);
  for (std::uint32_t k = 0; k < kCommands; ++k) ASSERT_EQ(seen[k], static_cast<int>(k)) << k;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_command_load");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
