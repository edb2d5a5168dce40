// Live replay: the node, on simulation time from rosbag play, reproduces the states recorded
// in the fixture bag bit for bit (same state hash at the same step).
#include <rosbag/bag.h>
#include <rosbag/view.h>

#include <map>

#include "../run_program.h"
#include "node_test_support.h"

using namespace fem_cloth_test;

TEST(LiveReplay, ReproducesTheRecordedStates) {
  ros::NodeHandle pnh("~");
  std::string fixture;
  ASSERT_TRUE(pnh.getParam("fixture", fixture));
  // A fixture recorded across a pause (paused_replay.test): stamps that jump ahead of the steps.
  double minPause = 0.0, dt = 0.01;
  pnh.getParam("min_pause", minPause);
  pnh.getParam("dt", dt);
  std::map<std::uint64_t, std::string> recorded;
  double longestPause = 0.0;
  {
    rosbag::Bag bag(fixture);
    fem_cloth::ClothState::ConstPtr before;
    for (const auto& m : rosbag::View(bag, rosbag::TopicQuery(topic("state")))) {
      auto s = m.instantiate<fem_cloth::ClothState>();
      recorded[s->step] = s->state_hash;
      if (before && before->step > 0) {
        const double ahead = (s->header.stamp - before->header.stamp).toSec() -
                             static_cast<double>(s->step - before->step) * dt;
        longestPause = std::max(longestPause, ahead);
      }
      before = s;
    }
  }
  ASSERT_GT(recorded.size(), 50u);
  if (minPause > 0.0) {
    EXPECT_GE(longestPause, minPause) << "the fixture holds no pause that long";
  }
  const std::uint64_t last = recorded.rbegin()->first;

  std::map<std::uint64_t, std::string> replayed;
  Latest<fem_cloth::ClothState> state(topic("state"), [&](const fem_cloth::ClothState& s) {
    replayed[s.step] = s.state_hash;
  });
  // The replay stops with the bag, step_lag (0.2 s = 20 steps) before its end.
  ASSERT_TRUE(state.waitFor([&](const fem_cloth::ClothState& s) { return s.step + 30 >= last; },
                            90.0))
      << "the replay did not get near the end of the recording";
  std::size_t compared = 0, identical = 0;
  for (const auto& [step, hash] : replayed) {
    auto it = recorded.find(step);
    if (it == recorded.end()) continue;
    ++compared;
    if (it->second == hash) {
      ++identical;
    } else {
      ADD_FAILURE() << "step " << step << ": recorded " << it->second << ", replayed " << hash;
    }
  }
  EXPECT_EQ(identical, compared);
  // Nearly all of the recording was replayed (the first states may come before we listened).
  EXPECT_GT(compared, recorded.size() * 3 / 4) << compared << " of " << recorded.size();

  // And the offline re-simulation of the same bag reproduces it too: live and offline agree.
  fem_cloth::test::TempDir dir("fem_cloth_live_replay");
  const fem_cloth::test::ProgramResult offline = fem_cloth::test::runProgram(
      FEM_CLOTH_SIM_EXE, {"--commands", fixture, "--out", dir.path("offline.bag"), "--verify", "-q"},
      dir);
  EXPECT_EQ(offline.status, 0) << offline.out << offline.err;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_live_replay");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
