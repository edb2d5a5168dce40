// A service call waiting for its request to take effect is answered when the step it waits for
// does not come (issue 31, part 3; docs/node.md, Live changes): the node waits for the tf frame
// 'finger' its scene follows (nobody publishes it) before its first step, so a ~set or
// ~add_obstacle waits; a ~reset answers it "~reset came first", the node pausing itself after
// frame_wait_timeout answers it "the node paused itself (...)", each success false, nothing
// changed, and never later than the event. A paused node then applies a call at once.
#include <chrono>
#include <future>

#include "fem_cloth/ObstacleChange.h"
#include "fem_cloth/Set.h"
#include "fem_cloth/StepStats.h"
#include "node_test_support.h"

using namespace fem_cloth_test;

namespace {

// The 'set' and 'obstacle' counts of ~stats (the services count on the topic they queue on).
const fem_cloth::CommandStats& counts(const fem_cloth::StepStats& s, const std::string& topicName) {
  for (const fem_cloth::CommandStats& c : s.commands) {
    if (c.topic == topicName) return c;
  }
  static const fem_cloth::CommandStats none;
  ADD_FAILURE() << "no counts of " << topicName << " in ~stats";
  return none;
}

// A call made on a thread of its own, so that the test can act while it waits.
template <class S>
std::future<S> callLater(S service, const std::string& name) {
  return std::async(std::launch::async, [service, name]() mutable {
    EXPECT_TRUE(ros::service::call(topic(name), service)) << name;
    return service;
  });
}

bool answered(std::future<fem_cloth::Set>& f, double seconds) {
  return f.wait_for(std::chrono::duration<double>(seconds)) == std::future_status::ready;
}

}  // namespace

// Runs first: the node is still waiting for the frame (it waits frame_wait_timeout = 12 s).
TEST(WaitingCalls, AResetAnswersACallWaitingForTheNextStep) {
  ASSERT_TRUE(ros::service::waitForService(topic("set"), 20000));
  // ~stats is not latched, and a node waiting for frames publishes it only when something
  // happens: a ~reset (which publishes the state it goes back to) or the end of a pause.
  Latest<fem_cloth::StepStats> stats(topic("stats"));
  ASSERT_TRUE(stats.waitConnected());
  // A fresh wait for the frame, however long the node has been up: ~reset starts the wait over,
  // ~resume ends a pause the node may have taken already.
  ASSERT_TRUE(trigger("reset"));
  ASSERT_TRUE(trigger("resume"));
  const auto before = stats.waitForAny();
  ASSERT_TRUE(before);
  EXPECT_EQ(before->step, 0u);
  fem_cloth::Set set;
  set.request.pairs = {"damping.mass=3.0"};
  std::future<fem_cloth::Set> call = callLater(set, "set");
  // It waits: no step comes without the frame.
  EXPECT_FALSE(answered(call, 1.0)) << "answered before the ~reset";
  ASSERT_TRUE(trigger("reset"));
  ASSERT_TRUE(answered(call, 10.0)) << "the call still waits after ~reset answered";
  const fem_cloth::Set done = call.get();
  EXPECT_FALSE(done.response.success);
  EXPECT_NE(done.response.message.find("~reset came first: dropped before it took effect, nothing changed"),
            std::string::npos)
      << done.response.message;
  // Counted as discarded, not applied.
  const auto after = stats.waitFor([&](const fem_cloth::StepStats& s) {
    return counts(s, "set").discarded == counts(*before, "set").discarded + 1;
  });
  ASSERT_TRUE(after);
  EXPECT_EQ(counts(*after, "set").applied, counts(*before, "set").applied);
}

// The ~reset above started a new wait of frame_wait_timeout; a call made now waits until the node
// gives up on the frame and pauses itself, and is answered then with the reason. The wait is not
// lag (docs/node.md, Lock-step from a cold start): with frame_wait_timeout (12 s) above max_lag
// (10 s), the node used to pause for lag first, "10.00 s behind ROS time", and not name the frame.
TEST(WaitingCalls, TheNodePausingItselfAnswersACallWaitingForTheNextStep) {
  ros::NodeHandle nh("~");
  double frameWait = 0.0;
  ASSERT_TRUE(nh.getParam("frame_wait_timeout", frameWait));
  fem_cloth::ObstacleChange add;
  add.request.name = "ball";
  add.request.entry = "{type: sphere, center: [0.5, 0.5, -5], radius: 0.1}";
  const ros::WallTime start = ros::WallTime::now();
  std::future<fem_cloth::ObstacleChange> call = callLater(add, "add_obstacle");
  ASSERT_EQ(call.wait_for(std::chrono::duration<double>(frameWait + 30.0)), std::future_status::ready)
      << "no answer " << frameWait + 30.0 << " s after the call";
  const double waited = (ros::WallTime::now() - start).toSec();
  const fem_cloth::ObstacleChange done = call.get();
  EXPECT_FALSE(done.response.success);
  EXPECT_NE(done.response.message.find("the node paused itself (no transform of frame(s) 'finger'"), std::string::npos)
      << done.response.message;
  EXPECT_NE(done.response.message.find("dropped before it took effect, nothing changed"), std::string::npos)
      << done.response.message;
  // Answered by the pause, not at once: the wait began at the ~reset before the call.
  EXPECT_GT(waited, 0.5 * frameWait) << done.response.message;
  // Paused now, the node applies the same request at once, at step 0: the ball was not added before.
  fem_cloth::ObstacleChange again = add;
  ASSERT_TRUE(ros::service::call(topic("add_obstacle"), again));
  EXPECT_TRUE(again.response.success) << again.response.message;
  EXPECT_NE(again.response.message.find("applied at step 0,"), std::string::npos) << again.response.message;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_waiting_calls");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
