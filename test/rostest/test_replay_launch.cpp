// replay.launch clears the node's namespace (clear_params): parameters an earlier cloth.launch
// left there — another scene, a paused start — do not take over the replay. (Its bit-for-bit
// reproduction is test_live_replay's; here only that the bag's run is the one that starts.)
#include <rosbag/bag.h>
#include <rosbag/view.h>

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
  {
    rosbag::Bag bag(fixture);
    for (const auto& m : rosbag::View(bag, rosbag::TopicQuery(topic("state")))) {
      vertices = m.instantiate<fem_cloth::ClothState>()->positions.size();
      break;
    }
  }
  ASSERT_GT(vertices, 0u);
  // What cloth.launch leaves behind: another scene (the hanging cloth has another mesh) and a
  // paused start. Without clear_params the node ran the stale scene, or never stepped.
  ros::param::set(std::string(kNode) + "/scene_file", staleScene);
  ros::param::set(std::string(kNode) + "/start_paused", true);

  Latest<fem_cloth::ClothState> state(topic("state"));
  // roslaunch ends when rosbag play does (it is required); SIGINT after 120 s, as Ctrl-C would.
  fem_cloth::test::TempDir dir("fem_cloth_replay_launch");
  fem_cloth::test::ProgramResult launched;
  std::thread launch([&] {
    launched = fem_cloth::test::runProgram(
        "/usr/bin/timeout", {"-s", "INT", "-k", "10", "120", "roslaunch", "fem_cloth", "replay.launch",
                             "bag:=" + fixture, "output:=log"}, dir);
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
  launch.join();
  EXPECT_EQ(launched.status, 0) << launched.out << launched.err;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_replay_launch");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
