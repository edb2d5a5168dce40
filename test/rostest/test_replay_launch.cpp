// replay.launch clears the node's namespace (clear_params): parameters an earlier cloth.launch
// left there — another scene, a paused start — do not take over the replay. Its `rate` argument
// reaches rosbag play as -r (issue 32), and a replay at half speed reproduces the recorded states
// up to step_lag before the bag's end (the bit-for-bit details are test_live_replay's).
#include <rosbag/bag.h>
#include <rosbag/view.h>

#include <atomic>
#include <map>
#include <thread>

#include "../run_program.h"
#include "node_test_support.h"

using namespace fem_cloth_test;

TEST(ReplayLaunch, StaleParametersOfAnEarlierRunDoNotTakeOver) {
  ros::NodeHandle pnh("~");
  std::string fixture, staleScene;
  ASSERT_TRUE(pnh.getParam("fixture", fixture));
  ASSERT_TRUE(pnh.getParam("stale_scene", staleScene));
  std::size_t vertices = 0;
  std::map<std::uint64_t, std::string> recorded;  // step -> state hash
  {
    rosbag::Bag bag(fixture);
    for (const auto& m : rosbag::View(bag, rosbag::TopicQuery(topic("state")))) {
      auto s = m.instantiate<fem_cloth::ClothState>();
      vertices = s->positions.size();
      recorded[s->step] = s->state_hash;
    }
  }
  ASSERT_GT(vertices, 0u);
  ASSERT_GT(recorded.size(), 50u);
  // What cloth.launch leaves behind: another scene (the hanging cloth has another mesh) and a
  // paused start. Without clear_params the node ran the stale scene, or never stepped.
  ros::param::set(std::string(kNode) + "/scene_file", staleScene);
  ros::param::set(std::string(kNode) + "/start_paused", true);

  std::mutex mutex;
  std::map<std::uint64_t, std::string> replayed;
  Latest<fem_cloth::ClothState> state(topic("state"), [&](const fem_cloth::ClothState& s) {
    std::lock_guard<std::mutex> lock(mutex);
    replayed[s.step] = s.state_hash;
  });
  // roslaunch ends when rosbag play does (it is required); SIGINT after 120 s, as Ctrl-C would.
  fem_cloth::test::TempDir dir("fem_cloth_replay_launch");
  fem_cloth::test::ProgramResult launched;
  std::atomic<bool> ended{false};
  std::thread launch([&] {
    launched = fem_cloth::test::runProgram(
        "/usr/bin/timeout", {"-s", "INT", "-k", "10", "120", "roslaunch", "fem_cloth", "replay.launch",
                             "bag:=" + fixture, "output:=log", "rate:=0.5"}, dir);
    ended = true;
  });
  struct Join {
    std::thread& t;
    ~Join() {
      if (t.joinable()) t.join();
    }
  } join{launch};
  auto s = state.waitFor([](const fem_cloth::ClothState& m) { return m.step > 0; }, 60.0);
  ASSERT_TRUE(s) << "the replayed node did not step (a stale ~start_paused?)";
  EXPECT_EQ(s->positions.size(), vertices) << "not the bag's scene (a stale ~scene_file?)";
  // Every state until the replay ends.
  while (!ended) {
    ros::spinOnce();
    ros::WallDuration(0.005).sleep();
  }
  ros::spinOnce();
  launch.join();
  EXPECT_EQ(launched.status, 0) << launched.out << launched.err;
  // The replay ends with the bag, step_lag (0.2 s, 20 steps of 0.01 s) before the recording's
  // end: every recorded state up to there is reproduced.
  const std::uint64_t last = recorded.rbegin()->first;
  std::lock_guard<std::mutex> lock(mutex);
  std::size_t compared = 0;
  for (const auto& [step, hash] : recorded) {
    if (step + 30 > last) break;
    auto it = replayed.find(step);
    if (it == replayed.end()) {
      ADD_FAILURE() << "recorded step " << step << " was not replayed (the replay cut short?)";
      continue;
    }
    ++compared;
    EXPECT_EQ(it->second, hash) << "step " << step;
  }
  EXPECT_GT(compared, 50u);
}

TEST(ReplayLaunch, RateReachesRosbagPlay) {
  ros::NodeHandle pnh("~");
  std::string fixture;
  ASSERT_TRUE(pnh.getParam("fixture", fixture));
  fem_cloth::test::TempDir dir("fem_cloth_replay_rate");
  // The command line roslaunch would run rosbag play with (nothing is started).
  auto playArgs = [&](const std::vector<std::string>& extra) {
    std::vector<std::string> args = {"--args", "/fem_cloth_play", "fem_cloth", "replay.launch", "bag:=" + fixture};
    args.insert(args.end(), extra.begin(), extra.end());
    const fem_cloth::test::ProgramResult r = fem_cloth::test::runProgramWithin(60, "roslaunch", args, dir);
    EXPECT_EQ(r.status, 0) << r.err;
    return " " + r.out;
  };
  const std::string half = playArgs({"rate:=0.5"});
  EXPECT_NE(half.find(" -r 0.5 "), std::string::npos) << half;
  const std::string byDefault = playArgs({});
  EXPECT_NE(byDefault.find(" -r 1 "), std::string::npos) << byDefault;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_replay_launch");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
