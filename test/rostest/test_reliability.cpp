// The node never crashes, never wedges, never loses input silently (issue 11, docs/node.md):
// each test sends what used to abort, wedge or vanish, and checks that the node says so by name,
// counts it, and runs on.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <rosgraph_msgs/Log.h>
#include <std_srvs/Trigger.h>
#include <sys/wait.h>
#include <tf2_msgs/TFMessage.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <mutex>
#include <sstream>
#include <thread>

#include "fem_cloth/Advance.h"
#include "fem_cloth/ForceCommand.h"
#include "fem_cloth/PinCommand.h"
#include "fem_cloth/StepStats.h"
#include "node_test_support.h"

using namespace fem_cloth_test;

namespace {

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// Waits for a WARN (or worse) status on /diagnostics whose message contains `part`.
bool diagnosticSays(const std::string& part, const std::function<void()>& send) {
  Latest<diagnostic_msgs::DiagnosticArray> diagnostics("/diagnostics");
  if (!diagnostics.waitConnected()) return false;
  send();
  return diagnostics.waitFor([&](const diagnostic_msgs::DiagnosticArray& a) {
    for (const auto& s : a.status) {
      if (s.level >= diagnostic_msgs::DiagnosticStatus::WARN && contains(s.message, part)) return true;
    }
    return false;
  }, 30.0) != nullptr;
}

// The node's log lines on /rosout that contain `part`, as they arrive.
class NodeLog {
 public:
  explicit NodeLog(const std::string& part)
      : part_(part),
        log_("/rosout", [this](const rosgraph_msgs::Log& m) {
          if (m.name == kNode && contains(m.msg, part_)) {
            std::lock_guard<std::mutex> lock(mutex_);
            lines_.push_back(m.msg);
          }
        }) {}
  std::vector<std::string> lines() {
    std::lock_guard<std::mutex> lock(mutex_);
    return lines_;
  }
  /// Spins until pred(lines) holds or the timeout (s) passes.
  bool waitFor(const std::function<bool(const std::vector<std::string>&)>& pred, double timeout = 30.0) {
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout);
    while (ros::ok() && ros::WallTime::now() < end) {
      ros::spinOnce();
      if (pred(lines())) return true;
      ros::WallDuration(0.01).sleep();
    }
    return false;
  }

 private:
  std::string part_;
  std::mutex mutex_;
  std::vector<std::string> lines_;
  Latest<rosgraph_msgs::Log> log_;
};

fem_cloth::ForceCommand badForce(std::uint32_t vertices) {
  fem_cloth::ForceCommand c;
  c.header.frame_id = "world";
  c.action = fem_cloth::ForceCommand::APPLY;
  for (std::uint32_t v = 0; v < vertices; ++v) c.vertices.push_back(v);
  c.forces.resize(2);  // neither one per vertex nor one for all
  return c;
}

// The node still steps: a state 10 steps after the next one (null if none comes).
fem_cloth::ClothState::ConstPtr stepsOn() {
  Latest<fem_cloth::ClothState> state(topic("state"));
  auto s = state.waitForNext();
  if (!s) return nullptr;
  return state.waitFor([&](const fem_cloth::ClothState& m) { return m.step > s->step + 10; });
}

fem_cloth::StepStats::ConstPtr nextStats() {
  Latest<fem_cloth::StepStats> stats(topic("stats"));
  return stats.waitForNext();
}

bool call(const std::string& service) {
  std_srvs::Trigger t;
  return ros::service::call(topic(service), t) && t.response.success;
}

// An ~advance called on a thread of its own. However the test ends, it is not left waiting: a
// call still running is ended with ~pause, then joined.
class AdvanceCall {
 public:
  explicit AdvanceCall(std::uint32_t steps) {
    srv_.request.steps = steps;
    thread_ = std::thread([this] { answered_ = ros::service::call(topic("advance"), srv_); });
  }
  ~AdvanceCall() {
    if (!thread_.joinable()) return;
    call("pause");
    thread_.join();
  }
  /// Waits for the answer; false if the call failed.
  bool answer(fem_cloth::Advance::Response* response) {
    thread_.join();
    *response = srv_.response;
    return answered_;
  }

 private:
  fem_cloth::Advance srv_;
  std::atomic<bool> answered_{false};
  std::thread thread_;
};

}  // namespace

// First, while no other ~force warning window is open: 2000 rejections in a burst are all
// counted in a handful of lines (each line stands for itself, "N more ..." for N).
TEST(Throttle, TwoThousandRejectionsAreCountedInAFewLines) {
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<fem_cloth::ForceCommand>(topic("force"), 5000);
  ASSERT_TRUE(waitForConnection(pub));
  NodeLog log("APPLY has 7 vertices but 2 forces");
  // /rosout is connected to the node once one of its lines arrives: probe with rejections on
  // ~pin (a kind of their own, throttled apart from those on ~force), a second apart.
  ros::Publisher pinPub = nh.advertise<fem_cloth::PinCommand>(topic("pin"), 10);
  ASSERT_TRUE(waitForConnection(pinPub));
  NodeLog probe("vertex 9999 (vertices[0]) does not exist");
  fem_cloth::PinCommand unknown;
  unknown.action = fem_cloth::PinCommand::PIN_IN_PLACE;
  unknown.vertices = {9999};
  for (int attempt = 0; attempt < 10 && probe.lines().empty(); ++attempt) {
    pinPub.publish(unknown);
    probe.waitFor([](const auto& lines) { return !lines.empty(); }, 1.2);
  }
  ASSERT_FALSE(probe.lines().empty()) << "no line of the node's on /rosout";
  const ros::WallTime begin = ros::WallTime::now();
  ros::Rate rate(2000.0);
  for (int k = 0; k < 2000; ++k) {
    pub.publish(badForce(7));
    rate.sleep();
  }
  const double sending = (ros::WallTime::now() - begin).toSec();
  auto told = [](const std::vector<std::string>& lines) {
    std::uint64_t n = 0;
    for (const std::string& l : lines) {
      const std::size_t more = l.find(" more ~force rejected");
      n += more == std::string::npos ? 1 : std::stoull(l.substr(l.rfind(' ', more - 1) + 1));
    }
    return n;
  };
  EXPECT_TRUE(log.waitFor([&](const auto& lines) { return told(lines) >= 2000; }))
      << "told " << told(log.lines()) << " of 2000 rejections";
  ros::WallDuration(1.5).sleep();  // nothing more comes
  const std::vector<std::string> lines = log.lines();
  EXPECT_EQ(told(lines), 2000u);
  // At most two lines per second of sending (one that opens a window, one that counts it).
  EXPECT_LE(lines.size(), 2u * static_cast<std::size_t>(std::ceil(sending) + 2.0))
      << lines.size() << " lines in " << sending << " s";
  auto stats = nextStats();
  ASSERT_TRUE(stats);
  EXPECT_EQ(stats->force_commands.received, 2000u);
  EXPECT_EQ(stats->force_commands.rejected, 2000u);
  EXPECT_EQ(stats->force_commands.applied, 0u);
}

TEST(Stamps, AStampNoRosDurationCanReachIsRejectedByNameAndTheNodeRunsOn) {
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<fem_cloth::ForceCommand>(topic("force"), 10);
  ASSERT_TRUE(waitForConnection(pub));
  fem_cloth::ForceCommand c;
  c.header.frame_id = "world";
  c.header.stamp = ros::Time(4294967295u, 0u);  // what used to abort the node
  c.action = fem_cloth::ForceCommand::APPLY;
  c.vertices = {40};
  c.forces.resize(1);
  c.forces[0].z = 0.2;
  c.duration = 1.0;
  EXPECT_TRUE(diagnosticSays("~force rejected: header.stamp = 4294967295.000000000 s", [&] { pub.publish(c); }));
  auto later = stepsOn();
  ASSERT_TRUE(later) << "the node stopped stepping";
  EXPECT_TRUE(finite(*later));
}

TEST(Stamps, ATransformStampedWhereTf2OverflowsIsRefusedByNameAndTheNodeRunsOn) {
  ros::NodeHandle nh;
  ros::Publisher tfPub = nh.advertise<tf2_msgs::TFMessage>("/tf", 10);
  ASSERT_TRUE(waitForConnection(tfPub));
  geometry_msgs::TransformStamped t;
  t.header.frame_id = "world";
  t.child_frame_id = "bomb";
  t.header.stamp = ros::Time(4294967295u, 0u);  // aborted the node inside tf2 (its listener)
  t.transform.rotation.w = 1.0;
  tf2_msgs::TFMessage m;
  m.transforms.push_back(t);
  EXPECT_TRUE(diagnosticSays("/tf: the stamp of transform 'world' -> 'bomb'", [&] { tfPub.publish(m); }));
  EXPECT_TRUE(stepsOn()) << "the node stopped stepping";
}

TEST(PinJump, AFarTargetIsRefusedNamingTheVertexAndTheDistance) {
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<fem_cloth::PinCommand>(topic("pin"), 10);
  ASSERT_TRUE(waitForConnection(pub));
  fem_cloth::PinCommand c;
  c.header.frame_id = "world";
  c.action = fem_cloth::PinCommand::PIN_AT_TARGETS;
  c.vertices = {40};
  c.targets.resize(1);
  c.targets[0].x = 100.0;  // the 100 m
  auto before = nextStats();
  ASSERT_TRUE(before);
  EXPECT_TRUE(diagnosticSays("the target of vertex 40 is ", [&] { pub.publish(c); }));
  Latest<fem_cloth::ClothState> state(topic("state"));
  auto s = state.waitForNext();
  ASSERT_TRUE(s);
  EXPECT_LT(s->positions[40].x, 2.0);  // the 1 m cloth was not pulled there
  auto stats = nextStats();
  ASSERT_TRUE(stats);
  EXPECT_EQ(stats->pin_commands.received, before->pin_commands.received + 1);
  EXPECT_EQ(stats->pin_commands.rejected, before->pin_commands.rejected + 1);
  EXPECT_EQ(stats->pin_commands.applied, before->pin_commands.applied);
}

TEST(PendingCap, FutureCommandsBeyondTheCapAreRefusedNamingItAndResetDiscardsThem) {
  ros::NodeHandle nh;
  ros::Publisher pub = nh.advertise<fem_cloth::ForceCommand>(topic("force"), 1000);
  ASSERT_TRUE(waitForConnection(pub));
  auto before = nextStats();
  ASSERT_TRUE(before);
  fem_cloth::ForceCommand c;
  c.header.frame_id = "world";
  c.header.stamp = ros::Time::now() + ros::Duration(1000.0);  // far in the future
  c.action = fem_cloth::ForceCommand::APPLY;
  c.vertices = {40};
  c.forces.resize(1);
  EXPECT_TRUE(diagnosticSays("(max_pending_commands", [&] {
    for (int k = 0; k < 250; ++k) pub.publish(c);
  }));
  Latest<fem_cloth::StepStats> stats(topic("stats"));
  auto full = stats.waitFor([&](const fem_cloth::StepStats& s) {
    return s.force_commands.received == before->force_commands.received + 250;
  });
  ASSERT_TRUE(full);
  // The node holds 200 (max_pending_commands in reliability.test) and refused the other 50.
  EXPECT_EQ(full->force_commands.pending, 200u);
  EXPECT_EQ(full->force_commands.rejected, before->force_commands.rejected + 50);
  ASSERT_TRUE(call("reset"));
  auto after = stats.waitFor([](const fem_cloth::StepStats& s) { return s.force_commands.pending == 0; });
  ASSERT_TRUE(after);
  EXPECT_EQ(after->force_commands.discarded, before->force_commands.discarded + 200);
  const fem_cloth::CommandStats& n = after->force_commands;
  EXPECT_EQ(n.received, n.rejected + n.applied + n.pending + n.discarded);
}

// ~reset restarts the window the real-time factor is measured over (issue 15, item 6): a window
// across a reset measured (simulation time after it - simulation time before) / wall time, which
// is negative once the run had gone on longer than the window lasts after the reset.
TEST(RealTimeFactor, IsNeverNegativeAfterAReset) {
  Latest<fem_cloth::StepStats> stats(topic("stats"));
  ASSERT_TRUE(stats.waitFor([](const fem_cloth::StepStats& s) { return s.step >= 200; }));  // 2 s on
  std::mutex mutex;
  double lowest = std::numeric_limits<double>::infinity();
  std::size_t seen = 0;
  Latest<fem_cloth::StepStats> after(topic("stats"), [&](const fem_cloth::StepStats& s) {
    std::lock_guard<std::mutex> lock(mutex);
    lowest = std::min(lowest, s.real_time_factor);
    ++seen;
  });
  ASSERT_TRUE(after.waitConnected());
  ASSERT_TRUE(call("reset"));
  // Two windows of about a second each, and the one the reset cut short.
  after.waitFor([](const fem_cloth::StepStats&) { return false; }, 3.0);
  std::lock_guard<std::mutex> lock(mutex);
  EXPECT_GT(seen, 10u);
  EXPECT_GE(lowest, 0.0);
}

TEST(Advance, AnEndlessAdvanceLetsCommandsThroughAndYieldsToPauseAndReset) {
  ros::NodeHandle nh;
  ros::ServiceClient advance = nh.serviceClient<fem_cloth::Advance>(topic("advance"));
  ASSERT_TRUE(advance.waitForExistence(ros::Duration(10.0)));
  ros::Publisher pinPub = nh.advertise<fem_cloth::PinCommand>(topic("pin"), 10);
  ASSERT_TRUE(waitForConnection(pinPub));
  Latest<fem_cloth::ClothState> state(topic("state"));
  Latest<fem_cloth::PinCommand> applied(topic("applied_pin"));
  ASSERT_TRUE(applied.waitConnected());
  ASSERT_TRUE(call("pause"));
  fem_cloth::Advance one;
  one.request.steps = 1;
  ASSERT_TRUE(advance.call(one));
  ASSERT_TRUE(one.response.success) << one.response.message;
  const std::uint64_t start = one.response.step;

  // 2^32 - 1 steps: about 500 days of this cloth's simulated time, in a service call.
  fem_cloth::Advance::Response endless;
  {
    AdvanceCall running(4294967295u);
    ASSERT_TRUE(state.waitFor([&](const fem_cloth::ClothState& s) { return s.step > start + 50; }));
    // A command gets in between its steps.
    fem_cloth::PinCommand pin;
    pin.header.frame_id = "world";
    pin.action = fem_cloth::PinCommand::PIN_IN_PLACE;
    pin.vertices = {40};
    pinPub.publish(pin);
    ASSERT_TRUE(applied.waitFor([](const fem_cloth::PinCommand& c) {
      return c.vertices == std::vector<std::uint32_t>{40};
    })) << "a command sent during ~advance was not applied";
    // ~pause answers and ends it.
    std_srvs::Trigger pause;
    ASSERT_TRUE(ros::service::call(topic("pause"), pause));
    EXPECT_TRUE(contains(pause.response.message, "the ~advance in progress stops there")) << pause.response.message;
    ASSERT_TRUE(running.answer(&endless));
  }
  EXPECT_FALSE(endless.success);
  EXPECT_TRUE(contains(endless.message, "interrupted by ~pause after ")) << endless.message;
  EXPECT_TRUE(contains(endless.message, " of 4294967295 steps")) << endless.message;
  EXPECT_GT(endless.steps_taken, 50u);
  EXPECT_EQ(endless.step, start + endless.steps_taken);
  auto at = state.waitFor([&](const fem_cloth::ClothState& s) { return s.step == endless.step; }, 10.0);
  ASSERT_TRUE(at);
  EXPECT_EQ(at->state_hash, endless.state_hash);

  // ~reset gets through too, and the run is back at step 0.
  {
    AdvanceCall running(4294967295u);
    ASSERT_TRUE(state.waitFor([&](const fem_cloth::ClothState& s) { return s.step > endless.step + 50; }));
    std_srvs::Trigger reset;
    ASSERT_TRUE(ros::service::call(topic("reset"), reset));
    EXPECT_TRUE(reset.response.success);
    ASSERT_TRUE(running.answer(&endless));
  }
  EXPECT_TRUE(contains(endless.message, "interrupted by ~reset after ")) << endless.message;
  EXPECT_TRUE(state.waitFor([](const fem_cloth::ClothState& s) { return s.step == 0; }, 10.0));
  ASSERT_TRUE(call("resume"));
}

TEST(TfStops, AFollowedFrameThatStopsIsDroppedAndStepsDoNotWaitForIt) {
  ros::NodeHandle nh;
  ros::Publisher tfPub = nh.advertise<tf2_msgs::TFMessage>("/tf", 100);
  ASSERT_TRUE(waitForConnection(tfPub));
  ros::Publisher pinPub = nh.advertise<fem_cloth::PinCommand>(topic("pin"), 10);
  ASSERT_TRUE(waitForConnection(pinPub));
  // A hand frame at the world's origin, broadcast at 100 Hz until it stops.
  TfBroadcaster broadcaster(tfPub, [] {
    geometry_msgs::TransformStamped tf;
    tf.header.stamp = ros::Time::now();
    tf.header.frame_id = "world";
    tf.child_frame_id = "hand";
    tf.transform.rotation.w = 1.0;
    return tf;
  });
  ros::WallDuration(0.5).sleep();
  Latest<fem_cloth::PinCommand> applied(topic("applied_pin"));
  ASSERT_TRUE(applied.waitConnected());
  NodeLog dropped("stop following frame 'hand'");
  fem_cloth::PinCommand pin;
  pin.header.frame_id = "hand";
  pin.action = fem_cloth::PinCommand::PIN_IN_PLACE;
  pin.vertices = {4};
  pinPub.publish(pin);
  ASSERT_TRUE(applied.waitFor([](const fem_cloth::PinCommand& c) { return c.header.frame_id == "hand"; }));
  broadcaster.stop();
  // Dropped after tf_timeout (1 s) with a warning naming the vertex.
  ASSERT_TRUE(dropped.waitFor([](const auto& lines) { return !lines.empty(); }))
      << "no warning that the pin stopped following 'hand'";
  EXPECT_TRUE(contains(dropped.lines().front(), "vertex 4")) << dropped.lines().front();
  // From then on the node steps at its pace (100 steps a second), not one per tf_timeout; the
  // vertex stays exactly where the hand left it.
  Latest<fem_cloth::ClothState> state(topic("state"));
  auto s = state.waitForNext();
  ASSERT_TRUE(s);
  auto later = state.waitFor([&](const fem_cloth::ClothState& m) { return m.step >= s->step + 200; }, 60.0);
  ASSERT_TRUE(later) << "steps wait for the stopped frame";
  EXPECT_EQ(later->positions[4].x, s->positions[4].x);
  EXPECT_EQ(later->positions[4].y, s->positions[4].y);
  EXPECT_EQ(later->positions[4].z, s->positions[4].z);
}

namespace {

// Runs the node with extra arguments (its own name, so its parameters do not touch the node
// under test); returns its exit status and what it printed.
int runNode(const std::string& name, const std::string& arguments, std::string* output) {
  const std::string log = "/tmp/fem_cloth_reliability_" + name + "_" + std::to_string(getpid()) + ".log";
  const std::string command = std::string(FEM_CLOTH_NODE_EXE) + " __name:=" + name +
                              " _scene_file:=" FEM_CLOTH_SOURCE_DIR "/test/rostest/config/small_cloth.yaml " +
                              arguments + " > " + log + " 2>&1";
  const int status = std::system(command.c_str());
  std::ifstream in(log);
  std::stringstream text;
  text << in.rdbuf();
  *output = text.str();
  std::remove(log.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

}  // namespace

TEST(StartUp, ParametersNoRosTimeCanHoldStopItWithExitTwoNamingThem) {
  for (const auto& [name, argument, expected] :
       std::vector<std::tuple<std::string, std::string, std::string>>{
           {"lag", "_step_lag:=1e10", "parameter ~step_lag = 10000000000 s"},
           {"start", "_start_time:=4e9", "parameter ~start_time = 4000000000 s"},
           {"jump", "_max_pin_jump:=-1", "parameter ~max_pin_jump must be positive"}}) {
    std::string output;
    EXPECT_EQ(runNode(name, argument, &output), 2) << argument << ": " << output;
    EXPECT_TRUE(contains(output, "FATAL")) << output;
    EXPECT_TRUE(contains(output, expected)) << output;
    EXPECT_FALSE(contains(output, "terminate called")) << output;
  }
}

// Values roscpp or the node once took silently (issue 31, part 5): getParam rounds 5.5 to an
// integer, a frame name with blanks names nothing tf can look up, a real-time factor of 1e308
// makes every step due at once, and a camera in the simulation frame is a transform of that
// frame to itself.
TEST(StartUp, ParametersOnceTakenSilentlyStopItWithExitTwoNamingThem) {
  const std::string camera = " _camera/width:=64 _camera/height:=48 _camera/horizontal_fov:=1.0";
  for (const auto& [name, argument, expected] :
       std::vector<std::tuple<std::string, std::string, std::string>>{
           {"queue", "_command_queue_size:=5.5", "parameter ~command_queue_size must be an integer, got '5.5'"},
           {"pending", "_max_pending_commands:=abc", "parameter ~max_pending_commands must be an integer, got 'abc'"},
           {"frame", "'_frame_id:=a b/ c'", "parameter ~frame_id must be a frame name without blanks"},
           {"fast", "_real_time_factor:=1e308", "parameter ~real_time_factor must be between 0.001 and 1000"},
           {"slow", "_real_time_factor:=0.0001", "parameter ~real_time_factor must be between 0.001 and 1000"},
           {"camera", "_camera/frame_id:=world" + camera, "parameter ~camera/frame_id is 'world', the simulation frame"},
           {"blank", "'_camera/frame_id:=my camera'" + camera, "parameter ~camera/frame_id must be a frame name without blanks"},
           {"mode", "_replay_mode:=fast", "parameter ~replay_mode must be play or drive, got 'fast'"},
           {"drive", "_replay_mode:=drive", "parameter ~replay_mode drive replays a recording: give it in ~replay_bag"},
           {"driven", "_replay_mode:=drive _replay_bag:=/nonexistent.bag _time_mode:=real_time",
            "~time_mode must be fast (or not given), got 'real_time'"}}) {
    std::string output;
    EXPECT_EQ(runNode(name, argument, &output), 2) << argument << ": " << output;
    EXPECT_TRUE(contains(output, expected)) << argument << ": " << output;
  }
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_reliability");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
