// ~state is latched (issue 32, part 5): a subscriber that comes after the node paused gets the
// last state at once, exactly once, and the node publishes no state twice (the same step with the
// same stamp) — not when a step fails again and again, not on ~pause or ~advance.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <std_srvs/Trigger.h>

#include <set>
#include <utility>

#include "fem_cloth/Advance.h"
#include "fem_cloth/ObstacleChange.h"
#include "node_test_support.h"

using namespace fem_cloth_test;

namespace {

bool call(const std::string& service) {
  std_srvs::Trigger trigger;
  return ros::service::call(topic(service), trigger) && trigger.response.success;
}

std::string value(const diagnostic_msgs::DiagnosticArray& a, const std::string& key) {
  for (const auto& s : a.status) {
    if (s.name != kNode) continue;
    for (const auto& kv : s.values) {
      if (kv.key == key) return kv.value;
    }
  }
  return "";
}

// Every state a subscriber got, in order.
class States {
 public:
  States()
      : latest_(topic("state"), [this](const fem_cloth::ClothState& s) {
          std::lock_guard<std::mutex> lock(mutex_);
          all_.push_back(s);
        }) {}
  Latest<fem_cloth::ClothState>& latest() { return latest_; }
  std::vector<fem_cloth::ClothState> all() {
    std::lock_guard<std::mutex> lock(mutex_);
    return all_;
  }

 private:
  std::mutex mutex_;
  std::vector<fem_cloth::ClothState> all_;
  Latest<fem_cloth::ClothState> latest_;
};

// The same state (step and stamp) twice in `states`, described; "" when none.
std::string repeated(const std::vector<fem_cloth::ClothState>& states) {
  std::set<std::pair<std::uint64_t, ros::Time>> seen;
  for (const auto& s : states) {
    if (!seen.insert({s.step, s.header.stamp}).second) {
      return "step " + std::to_string(s.step) + " stamped " + std::to_string(s.header.stamp.toSec()) + " twice";
    }
  }
  return "";
}

// Waits for `n` more diagnostics (about a second apart), so that anything still to come has come.
void waitDiagnostics(Latest<diagnostic_msgs::DiagnosticArray>& diagnostics, int n) {
  for (int k = 0; k < n; ++k) ASSERT_TRUE(diagnostics.waitForNext(10.0));
}

}  // namespace

TEST(LatchedState, ALateSubscriberOfAPausedNodeGetsTheLastStateOnce) {
  ASSERT_TRUE(ros::service::waitForService(topic("advance"), 20000));
  Latest<diagnostic_msgs::DiagnosticArray> diagnostics("/diagnostics");
  {
    Latest<fem_cloth::ClothState> early(topic("state"));
    ASSERT_TRUE(early.waitFor([](const fem_cloth::ClothState& s) { return s.step >= 10; }, 60.0));
  }
  ASSERT_TRUE(call("pause"));
  fem_cloth::Advance advance;
  advance.request.steps = 4;
  ASSERT_TRUE(ros::service::call(topic("advance"), advance));
  ASSERT_TRUE(advance.response.success) << advance.response.message;

  States late;
  auto got = late.latest().waitForAny(20.0);
  ASSERT_TRUE(got) << "a subscriber of the paused node got no state";
  EXPECT_EQ(got->step, advance.response.step);
  EXPECT_EQ(got->state_hash, advance.response.state_hash);
  waitDiagnostics(diagnostics, 3);
  ros::spinOnce();
  EXPECT_EQ(late.all().size(), 1u) << "not exactly the last state";
}

TEST(LatchedState, AfterAStepKeptFailingTheLastGoodStateOnceAndNoneTwice) {
  ros::NodeHandle nh;
  ASSERT_TRUE(ros::service::waitForService(topic("add_obstacle"), 20000));
  Latest<diagnostic_msgs::DiagnosticArray> diagnostics("/diagnostics");
  States early;  // from before the run goes on
  ASSERT_TRUE(early.latest().waitConnected());

  // A box in a tf frame that holds it inside the resting cloth: every attempt at a step fails.
  ros::Publisher staticPub = nh.advertise<tf2_msgs::TFMessage>("/tf_static", 1, true);
  tf2_msgs::TFMessage frames;
  frames.transforms.push_back(frameAt("world", "blocker_frame", ros::Time::now(), 0, 0, 0.5));
  staticPub.publish(frames);
  fem_cloth::ObstacleChange add;
  add.request.name = "blocker";
  add.request.entry = "{type: box, frame: blocker_frame, center: [0, 0, 0], size: [0.2, 0.2, 0.2]}";
  ASSERT_TRUE(ros::service::call(topic("add_obstacle"), add));
  ASSERT_TRUE(add.response.success) << add.response.message;
  ASSERT_TRUE(call("resume"));
  auto paused = diagnostics.waitFor([](const diagnostic_msgs::DiagnosticArray& a) {
    return value(a, "paused by a failing step") == "true";
  }, 60.0);
  ASSERT_TRUE(paused) << "the node did not pause itself";
  const std::uint64_t pausedAt = std::stoull(value(*paused, "step"));
  auto last = early.latest().waitFor([&](const fem_cloth::ClothState& s) { return s.step == pausedAt; }, 10.0);
  ASSERT_TRUE(last);
  EXPECT_EQ(repeated(early.all()), "") << "a state published twice";

  States late;
  auto got = late.latest().waitForAny(20.0);
  ASSERT_TRUE(got) << "a subscriber of the paused node got no state";
  EXPECT_EQ(got->step, pausedAt);
  EXPECT_EQ(got->header.stamp, last->header.stamp);
  EXPECT_EQ(got->state_hash, last->state_hash);
  waitDiagnostics(diagnostics, 3);
  ros::spinOnce();
  EXPECT_EQ(late.all().size(), 1u) << "not exactly the last state";
  const std::vector<fem_cloth::ClothState> all = early.all();
  EXPECT_EQ(all.back().step, pausedAt);
  EXPECT_EQ(repeated(all), "") << "a state published twice";
  EXPECT_GT(all.size(), 1u);  // the resumed run's states, not the latched one only
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_latched_state");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
