// Live replay: the node, on simulation time from rosbag play, reproduces the states recorded
// in the fixture bag bit for bit (same state hash at the same step).
// With `drive` (replay_drive.test) the node reads the bag itself (~replay_mode drive), started
// paused so that this test hears every state (and a ~set is refused: the run is the
// recording's): resumed, it reproduces every recorded state, also
// when each of its steps takes longer than real time allows (~test_step_delay), and pauses at the
// end of the recording, where an ~advance takes no step, saying the replay is over; ~reset
// replays it again.
#include <rosbag/bag.h>
#include <rosbag/view.h>

#include <map>

#include "fem_cloth/Advance.h"
#include "fem_cloth/Set.h"
#include "../run_program.h"
#include "node_test_support.h"

using namespace fem_cloth_test;

TEST(LiveReplay, ReproducesTheRecordedStates) {
  ros::NodeHandle pnh("~");
  std::string fixture;
  ASSERT_TRUE(pnh.getParam("fixture", fixture));
  // A fixture recorded across a pause (paused_replay.test): stamps that jump ahead of the steps.
  double minPause = 0.0, dt = 0.01;
  bool drive = false;
  pnh.getParam("min_pause", minPause);
  pnh.getParam("dt", dt);
  pnh.getParam("drive", drive);
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
  if (drive) {
    // Paused at its initial state, which the latched ~state gives us; then every step is heard.
    ASSERT_TRUE(state.waitFor([](const fem_cloth::ClothState& s) { return s.step == 0; }, 30.0));
    // The run is the recording's: a live change is refused, saying why, and changes nothing.
    fem_cloth::Set set;
    set.request.pairs = {"damping.mass=1.0"};
    ASSERT_TRUE(ros::service::call(topic("set"), set));
    EXPECT_FALSE(set.response.success);
    EXPECT_NE(set.response.message.find("replay_mode drive"), std::string::npos) << set.response.message;
    ASSERT_TRUE(trigger("resume"));
    ASSERT_TRUE(state.waitFor([&](const fem_cloth::ClothState& s) { return s.step >= last; }, 120.0))
        << "the replay did not reach the end of the recording";
    // It stops there: an ~advance (which answers with the outcome of its steps) takes none,
    // saying so.
    fem_cloth::Advance more;
    more.request.steps = 1;
    ASSERT_TRUE(ros::service::call(topic("advance"), more));
    EXPECT_FALSE(more.response.success);
    EXPECT_EQ(more.response.steps_taken, 0u);
    EXPECT_EQ(more.response.step, last);
    EXPECT_NE(more.response.message.find("is over at step " + std::to_string(last)), std::string::npos)
        << more.response.message;
    // ~reset replays it again from the start: advanced to a recorded step, the same state.
    const auto again = recorded.lower_bound(40);
    ASSERT_NE(again, recorded.end());
    ASSERT_TRUE(trigger("reset"));
    fem_cloth::Advance to;
    to.request.steps = static_cast<std::uint32_t>(again->first);
    ASSERT_TRUE(ros::service::call(topic("advance"), to));
    EXPECT_TRUE(to.response.success) << to.response.message;
    EXPECT_EQ(to.response.step, again->first);
    EXPECT_EQ(to.response.state_hash, again->second) << "step " << again->first << " replayed after ~reset";
  } else {
    // The replay stops with the bag, step_lag (0.2 s = 20 steps) before its end.
    ASSERT_TRUE(state.waitFor([&](const fem_cloth::ClothState& s) { return s.step + 30 >= last; },
                              90.0))
        << "the replay did not get near the end of the recording";
  }
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
  if (drive) {
    // Every recorded state, however slow the node's steps.
    EXPECT_EQ(compared, recorded.size());
  } else {
    // Nearly all of the recording was replayed (the first states may come before we listened).
    EXPECT_GT(compared, recorded.size() * 3 / 4) << compared << " of " << recorded.size();
  }

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
