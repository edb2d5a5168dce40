// A step that keeps failing stops the run and says why (issue 32, docs/node.md, Exit status): an
// obstacle added in a tf frame that holds it inside the resting cloth (as a finger that jumped
// onto it) makes every attempt at the next step fail ("vertex V would be inside obstacle
// 'blocker'"; a fixed obstacle there is refused when added). The running node pauses itself after exactly
// max_failed_attempts attempts, keeps and publishes its last good state, reports ERROR on
// /diagnostics with the cause, logs one ERROR line saying how to go on (not one per attempt,
// on and on), and steps again after ~remove_obstacle and ~resume.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <rosgraph_msgs/Log.h>
#include <std_srvs/Trigger.h>

#include <set>

#include "fem_cloth/ObstacleChange.h"
#include "node_test_support.h"

using namespace fem_cloth_test;

namespace {

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// The node's own status and one of its values ("" when absent).
const diagnostic_msgs::DiagnosticStatus* nodeStatus(const diagnostic_msgs::DiagnosticArray& a) {
  for (const auto& s : a.status) {
    if (s.name == kNode) return &s;
  }
  return nullptr;
}

std::string value(const diagnostic_msgs::DiagnosticArray& a, const std::string& key) {
  if (const auto* s = nodeStatus(a)) {
    for (const auto& kv : s->values) {
      if (kv.key == key) return kv.value;
    }
  }
  return "";
}

bool obstacle(const std::string& service, const std::string& name, const std::string& entry, std::string* message) {
  fem_cloth::ObstacleChange change;
  change.request.name = name;
  change.request.entry = entry;
  if (!ros::service::call(topic(service), change)) return false;
  *message = change.response.message;
  return change.response.success;
}

bool call(const std::string& service) {
  std_srvs::Trigger trigger;
  return ros::service::call(topic(service), trigger) && trigger.response.success;
}

}  // namespace

TEST(FailingStep, PausesSaysWhyOnceAndResumesWhenTheCauseIsGone) {
  ros::NodeHandle nh, pnh("~");
  int maxAttempts = 0;
  ASSERT_TRUE(pnh.getParam("max_failed_attempts", maxAttempts));
  ASSERT_TRUE(ros::service::waitForService(topic("resume"), 20000));
  ASSERT_TRUE(ros::service::waitForService(topic("add_obstacle"), 20000));

  std::mutex mutex;
  std::vector<rosgraph_msgs::Log> lines;  // the node's lines on /rosout
  Latest<rosgraph_msgs::Log> log("/rosout", [&](const rosgraph_msgs::Log& m) {
    if (m.name != kNode) return;
    std::lock_guard<std::mutex> lock(mutex);
    lines.push_back(m);
  });
  auto linesWith = [&](std::uint8_t level, const std::string& part) {
    std::lock_guard<std::mutex> lock(mutex);
    std::size_t n = 0;
    for (const auto& m : lines) n += m.level == level && contains(m.msg, part);
    return n;
  };
  // /rosout hears the node once a line of its arrives: probe with a pin of a vertex it lacks.
  ros::Publisher pinPub = nh.advertise<fem_cloth::PinCommand>(topic("pin"), 10);
  ASSERT_TRUE(waitForConnection(pinPub));
  bool heard = false;
  for (int attempt = 0; attempt < 10 && !heard; ++attempt) {
    pinPub.publish(pinInPlace("world", {9999}));
    heard = log.waitFor([&](const rosgraph_msgs::Log&) { return linesWith(rosgraph_msgs::Log::WARN, "9999") > 0; },
                        1.2) != nullptr;
  }
  ASSERT_TRUE(heard) << "no line of the node's on /rosout";

  Latest<fem_cloth::ClothState> state(topic("state"));
  Latest<diagnostic_msgs::DiagnosticArray> diagnostics("/diagnostics");
  ASSERT_TRUE(state.waitFor([](const fem_cloth::ClothState& s) { return s.step >= 20; }, 60.0));

  // The cloth (9 x 9 vertices, 0.0625 m apart from (-0.25, -0.25), resting at z ~ 0.5 m on the
  // table) meets a 0.2 m box centred on (0, 0, 0.5) at its 3 x 3 middle vertices: rows and
  // columns 3..5, vertex 9 row + column.
  std::set<std::string> inside;
  for (int row = 3; row <= 5; ++row) {
    for (int col = 3; col <= 5; ++col) inside.insert("vertex " + std::to_string(9 * row + col) + " ");
  }
  ros::Publisher staticPub = nh.advertise<tf2_msgs::TFMessage>("/tf_static", 1, true);
  tf2_msgs::TFMessage frames;
  frames.transforms.push_back(frameAt("world", "blocker_frame", ros::Time::now(), 0, 0, 0.5));
  staticPub.publish(frames);
  std::string message;
  ASSERT_TRUE(obstacle("add_obstacle", "blocker", "{type: box, frame: blocker_frame, center: [0, 0, 0], "
                                                  "size: [0.2, 0.2, 0.2]}", &message))
      << message;

  auto paused = diagnostics.waitFor([](const diagnostic_msgs::DiagnosticArray& a) {
    return value(a, "paused") == "true";
  }, 60.0);
  ASSERT_TRUE(paused) << "the node did not pause itself (retrying the failing step on and on?)";
  const diagnostic_msgs::DiagnosticStatus* status = nodeStatus(*paused);
  ASSERT_TRUE(status);
  EXPECT_EQ(status->level, diagnostic_msgs::DiagnosticStatus::ERROR);
  EXPECT_EQ(value(*paused, "paused by a failing step"), "true");
  EXPECT_EQ(value(*paused, "failed steps"), std::to_string(maxAttempts)) << "not within max_failed_attempts";
  EXPECT_TRUE(contains(status->message, "inside obstacle 'blocker'")) << status->message;
  bool namesAVertexInside = false;
  for (const std::string& v : inside) namesAVertexInside = namesAVertexInside || contains(status->message, v);
  EXPECT_TRUE(namesAVertexInside) << status->message;

  // The last good state is out (whatever the publish rate), and no later one.
  const std::uint64_t pausedAt = std::stoull(value(*paused, "step"));
  ASSERT_TRUE(state.waitFor([&](const fem_cloth::ClothState& s) { return s.step == pausedAt; }, 10.0))
      << "the state the node paused at (step " << pausedAt << ") was not published";

  // Three more diagnostics (about a second apart): the node stays paused and says it once.
  for (int k = 0; k < 3; ++k) ASSERT_TRUE(diagnostics.waitForNext(10.0));
  ros::spinOnce();
  EXPECT_EQ(value(*diagnostics.waitForAny(), "failed steps"), std::to_string(maxAttempts));
  EXPECT_EQ(value(*diagnostics.waitForAny(), "step"), std::to_string(pausedAt));
  EXPECT_EQ(state.waitForAny()->step, pausedAt);
  EXPECT_EQ(linesWith(rosgraph_msgs::Log::ERROR, ""), 1u) << "not one ERROR line";
  EXPECT_EQ(linesWith(rosgraph_msgs::Log::ERROR, "~resume"), 1u) << "the ERROR line does not say how to go on";
  EXPECT_EQ(linesWith(rosgraph_msgs::Log::ERROR, "inside obstacle 'blocker'"), 1u);
  // One WARN, at the first failed attempt; the later attempts are counted, not logged.
  EXPECT_EQ(linesWith(rosgraph_msgs::Log::WARN, "inside obstacle 'blocker'"), 1u)
      << "the failed attempts logged one by one";

  // The cause removed, ~resume retries the step, and the run goes on.
  ASSERT_TRUE(obstacle("remove_obstacle", "blocker", "", &message)) << message;
  ASSERT_TRUE(call("resume"));
  ASSERT_TRUE(state.waitFor([&](const fem_cloth::ClothState& s) { return s.step >= pausedAt + 10; }, 60.0))
      << "no states after ~resume";
  auto running = diagnostics.waitFor([](const diagnostic_msgs::DiagnosticArray& a) {
    return value(a, "paused") == "false";
  }, 30.0);
  ASSERT_TRUE(running);
  EXPECT_EQ(value(*running, "paused by a failing step"), "false");
  EXPECT_EQ(value(*running, "failed steps"), std::to_string(maxAttempts));
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_failing_step");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
