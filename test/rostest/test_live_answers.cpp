// The live services answer with what they did (issue 31, part 3; docs/node.md, Live changes):
// a request the node refuses when it comes to apply it (a frame tf does not know, no vertex
// within the radius, an obstacle in the cloth) is answered success false with the reason; a
// grasp answers with the vertices it pinned; a paused node applies a request at once; and with
// max_pending_commands = 3 pins waiting for a later time, a fourth is refused while ~set and a
// pin for the next step still go through (the cap is per topic).
#include <cmath>

#include "fem_cloth/Advance.h"
#include "fem_cloth/GraspNearest.h"
#include "fem_cloth/ObstacleChange.h"
#include "fem_cloth/Set.h"
#include "fem_cloth/StepStats.h"
#include "node_test_support.h"

using namespace fem_cloth_test;

namespace {

const fem_cloth::CommandStats& pinStats(const fem_cloth::StepStats& s) { return s.commands[0]; }

}  // namespace

TEST(LiveAnswers, ThePendingCapIsPerTopicAndLetsTheServicesThrough) {
  ros::NodeHandle nh;
  ASSERT_TRUE(ros::service::waitForService(topic("set"), 20000));
  ros::Publisher pins = nh.advertise<fem_cloth::PinCommand>(topic("pin"), 10);
  ASSERT_TRUE(waitForConnection(pins));
  Latest<fem_cloth::StepStats> stats(topic("stats"));
  auto before = stats.waitForAny();
  ASSERT_TRUE(before);
  ASSERT_EQ(before->commands.size(), 5u);
  ASSERT_EQ(before->commands[0].topic, "pin");
  fem_cloth::PinCommand later = pinInPlace("world", {40});
  later.header.stamp = ros::Time::now() + ros::Duration(1000.0);
  for (int k = 0; k < 4; ++k) pins.publish(later);
  auto full = stats.waitFor([&](const fem_cloth::StepStats& s) {
    return pinStats(s).received == pinStats(*before).received + 4;
  });
  ASSERT_TRUE(full);
  EXPECT_EQ(pinStats(*full).pending, 3u);
  EXPECT_EQ(pinStats(*full).rejected, pinStats(*before).rejected + 1);

  fem_cloth::Set set;
  set.request.pairs = {"damping.mass=4.0"};
  ASSERT_TRUE(ros::service::call(topic("set"), set));
  EXPECT_TRUE(set.response.success) << set.response.message;
  EXPECT_NE(set.response.message.find("applied at step"), std::string::npos) << set.response.message;
  // A pin for the next step: applied, though three pins wait for later.
  Latest<fem_cloth::PinCommand> applied(topic("applied_pin"));
  ASSERT_TRUE(applied.waitConnected());
  pins.publish(pinInPlace("world", {40}));
  auto pinned = applied.waitForAny(30.0);
  ASSERT_TRUE(pinned);
  EXPECT_EQ(pinned->vertices, std::vector<std::uint32_t>{40});
  // Back to the start for the next tests: the pins for later are discarded.
  ASSERT_TRUE(trigger("reset"));
}

TEST(LiveAnswers, AnObstacleInTheClothIsRefusedWithTheReasonAndNotAdded) {
  ASSERT_TRUE(ros::service::waitForService(topic("add_obstacle"), 20000));
  // A sphere of 10 km radius around the cloth: every vertex starts inside it.
  fem_cloth::ObstacleChange huge;
  huge.request.name = "huge";
  huge.request.entry = "{type: sphere, center: [0.5, 0.5, 0], radius: 1.0e4}";
  ASSERT_TRUE(ros::service::call(topic("add_obstacle"), huge));
  EXPECT_FALSE(huge.response.success);
  EXPECT_NE(huge.response.message.find("refused, nothing changed"), std::string::npos) << huge.response.message;
  EXPECT_NE(huge.response.message.find("inside"), std::string::npos) << huge.response.message;
  // Not added: the name is free for a sphere clear of the cloth (5 m below it).
  fem_cloth::ObstacleChange small = huge;
  small.request.entry = "{type: sphere, center: [0.5, 0.5, -5], radius: 0.1}";
  ASSERT_TRUE(ros::service::call(topic("add_obstacle"), small));
  EXPECT_TRUE(small.response.success) << small.response.message;
  fem_cloth::ObstacleChange remove;
  remove.request.name = "huge";
  ASSERT_TRUE(ros::service::call(topic("remove_obstacle"), remove));
  EXPECT_TRUE(remove.response.success) << remove.response.message;
}

TEST(LiveAnswers, AGraspAnswersWithTheVerticesItPinnedOrWhyNot) {
  ASSERT_TRUE(ros::service::waitForService(topic("grasp_nearest"), 20000));
  fem_cloth::GraspNearest unknown;
  unknown.request.frame_id = "no_such_frame";
  unknown.request.radius = 0.1;
  ASSERT_TRUE(ros::service::call(topic("grasp_nearest"), unknown));
  EXPECT_FALSE(unknown.response.success);
  EXPECT_TRUE(unknown.response.vertices.empty());
  EXPECT_NE(unknown.response.message.find("no_such_frame"), std::string::npos) << unknown.response.message;

  // Paused, after one ~advance: the published state is the state a grasp is applied in.
  ASSERT_TRUE(trigger("pause"));
  fem_cloth::Advance advance;
  advance.request.steps = 1;
  ASSERT_TRUE(ros::service::call(topic("advance"), advance));
  ASSERT_TRUE(advance.response.success) << advance.response.message;
  Latest<fem_cloth::ClothState> state(topic("state"));
  auto now = state.waitFor([&](const fem_cloth::ClothState& s) { return s.step == advance.response.step; });
  ASSERT_TRUE(now);
  ASSERT_EQ(now->positions.size(), 81u);

  fem_cloth::GraspNearest nowhere;
  nowhere.request.point = point(0.0, 0.0, 100.0);
  nowhere.request.radius = 0.01;
  ASSERT_TRUE(ros::service::call(topic("grasp_nearest"), nowhere));
  EXPECT_FALSE(nowhere.response.success);
  EXPECT_TRUE(nowhere.response.vertices.empty());
  EXPECT_NE(nowhere.response.message.find("no vertex within 0.01 m"), std::string::npos) << nowhere.response.message;

  // At vertex 80 within 1 mm: its neighbours are about 0.125 m away (a 1 m 9 x 9 grid).
  fem_cloth::GraspNearest corner;
  corner.request.point = now->positions[80];
  corner.request.radius = 1e-3;
  ASSERT_TRUE(ros::service::call(topic("grasp_nearest"), corner));
  EXPECT_TRUE(corner.response.success) << corner.response.message;
  EXPECT_EQ(corner.response.vertices, std::vector<std::uint32_t>{80});
  // Applied at once in the paused state, not at a later step.
  EXPECT_NE(corner.response.message.find("at step " + std::to_string(advance.response.step) + ","), std::string::npos)
      << corner.response.message;
  EXPECT_TRUE(trigger("resume"));
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_live_answers");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
