// Runs in bags, without a ROS master: a run driven in process the way the node drives it and
// written the way record.launch writes it is re-simulated from the bag (runToBag, what
// fem_cloth_sim --commands does) bit for bit; replays are deterministic; commands sent with a
// zero stamp take effect at the step after they were recorded; bad bags are refused with an
// error naming the problem and leave no output behind.
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <std_msgs/String.h>
#include <tf2_msgs/TFMessage.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "../run_program.h"
#include "../temp_dir.h"
#include "fem_cloth/ClothState.h"
#include "fem_cloth/io/scene_yaml.h"
#include "fem_cloth/ros/bag_replay.h"
#include "fem_cloth/ros/simulation_driver.h"

using namespace fem_cloth;
namespace fs = std::filesystem;

namespace {

// A 7 x 7 cloth, 0.6 m, hanging from the corners of its first row. Its 10 cm cells are wide
// enough for the 0.1 m ball some runs add to pass between the vertices symplectic Euler keeps
// out (contact/surface_reach.h): accepted with the ball's radius as contact.surface_tolerance
// (any depth; measured and reported).
const char* kScene = R"(
name: replay_test
mesh: {type: grid, rows: 7, cols: 7, width: 0.6, height: 0.6}
material: {model: stvk, youngs_modulus: 2.0e6, poisson_ratio: 0.3, thickness: 5.0e-4, density: 2000}
damping: {mass: 0.5}
integrator: {name: symplectic_euler, dt: 0.01}
contact: {surface_tolerance: 0.1}
pins:
  - grid_vertices: [[0, 0], [0, -1]]
duration: 1.0
)";

const ros::Time kEpoch(1000.0);
const RunTopics kTopics("/fem_cloth_node");

// The gripper: rises 0.3 m and moves 0.2 m towards the pinned edge over a second.
geometry_msgs::TransformStamped gripperAt(double t) {
  const double s = std::min(std::max(t, 0.0), 1.0);
  geometry_msgs::TransformStamped tf;
  tf.header.stamp = kEpoch + ros::Duration(t);
  tf.header.frame_id = "world";
  tf.child_frame_id = "gripper";
  tf.transform.translation.x = 0.3;
  tf.transform.translation.y = 0.6 - 0.2 * s;
  tf.transform.translation.z = 0.3 * s;
  tf.transform.rotation.w = 1.0;
  return tf;
}

std::vector<PinCommand> pinCommands() {
  PinCommand grasp;
  grasp.header.stamp = kEpoch + ros::Duration(0.05);
  grasp.header.frame_id = "gripper";
  grasp.action = PinCommand::PIN_IN_PLACE;
  grasp.vertices = {42, 48};  // the far corners
  PinCommand release;
  release.header.stamp = kEpoch + ros::Duration(0.6);
  release.action = PinCommand::RELEASE;
  release.vertices = {0, 6};
  return {grasp, release};
}

ForceCommand pushCommand() {
  ForceCommand push;
  push.header.stamp = kEpoch + ros::Duration(0.1);
  push.header.frame_id = "world";
  push.action = ForceCommand::APPLY;
  push.vertices = {24};
  geometry_msgs::Vector3 f;
  f.y = 0.2;
  push.forces = {f};
  push.duration = 0.2;
  return push;
}

SimulationDriver makeDriver(const tf2::BufferCore* tf) {
  const Scene scene = *parseScene(YAML::Load(kScene));
  DriverSettings settings;
  settings.epoch = kEpoch;
  return SimulationDriver(std::move(buildSimulation(scene).value()), settings, tf, YAML::Load(kScene));
}

struct Recorded {
  std::map<std::uint64_t, std::string> hashes;  // step -> state hash
  std::string finalHash;
};

// Drives the run in process, as the node does (commands submitted ahead of their stamps, tf
// known ahead), and writes it the way record.launch records it; `appliedTopics` false writes
// the commands as sent (zero stamps) instead, at the bag times given. `arriving` are submitted
// only once the simulation has come to their stamp, as a user sends a command when it is to apply.
Recorded recordRun(const std::string& path, int steps, bool appliedTopics = true,
                   const std::vector<Command>& more = {}, const std::vector<Command>& arriving = {}) {
  tf2::BufferCore tf(ros::Duration(100.0));
  for (int k = 0; k <= 130; ++k) tf.setTransform(gripperAt(0.01 * k), "test");
  SimulationDriver driver = makeDriver(&tf);
  for (const PinCommand& c : pinCommands()) EXPECT_TRUE(driver.submit(c).ok());
  EXPECT_TRUE(driver.submit(pushCommand()).ok());
  for (const Command& c : more) EXPECT_TRUE(driver.submit(c).ok());

  rosbag::Bag bag(path, rosbag::bagmode::Write);
  std_msgs::String scene;
  scene.data = kScene;
  bag.write(kTopics.scene, kEpoch, scene);
  bag.write(kTopics.mesh, kEpoch, toMsg(driver.simulator().model().mesh()));
  for (int k = 0; k <= 130; ++k) {
    tf2_msgs::TFMessage m;
    m.transforms.push_back(gripperAt(0.01 * k));
    bag.write("/tf", m.transforms[0].header.stamp, m);
  }
  if (!appliedTopics) {
    // As sent: zero stamps, recorded at the time they were sent.
    for (PinCommand c : pinCommands()) {
      const ros::Time sent = c.header.stamp;
      c.header.stamp = ros::Time();
      bag.write(kTopics.pin, sent, c);
    }
    ForceCommand push = pushCommand();
    const ros::Time sent = push.header.stamp;
    push.header.stamp = ros::Time();
    bag.write(kTopics.force, sent, push);
  }
  Recorded rec;
  auto record = [&]() {
    const ClothState s = toMsg(driver.header(), driver.simulator().state(), driver.simulator().dim(), false);
    rec.hashes[s.step] = s.state_hash;
    bag.write(kTopics.state, s.header.stamp, s);
  };
  record();
  std::size_t arrived = 0;
  for (int k = 0; k < steps; ++k) {
    while (arrived < arriving.size() && headerOf(arriving[arrived]).stamp <= driver.now()) {
      EXPECT_TRUE(driver.submit(arriving[arrived++]).ok());
    }
    const StepReport r = driver.step();
    EXPECT_TRUE(r.ok) << r.error;
    EXPECT_TRUE(driver.takeWarnings().empty());
    for (const Command& c : driver.takeApplied()) {
      if (!appliedTopics) continue;
      std::visit([&](const auto& m) { bag.write(kTopics.applied(topicOf(c)), m.header.stamp, m); }, c);
    }
    if (driver.stepIndex() % 3 == 0) record();
  }
  rec.finalHash = stateHash(driver.simulator().state().x, driver.simulator().state().v);
  bag.close();
  return rec;
}

std::map<std::uint64_t, std::string> statesOf(const std::string& path) {
  std::map<std::uint64_t, std::string> out;
  rosbag::Bag bag(path);
  for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery(kTopics.state))) {
    auto s = m.instantiate<ClothState>();
    out[s->step] = s->state_hash;
  }
  return out;
}

// Neither the output nor a temporary file of it (out.partial-XXXXXX) in its folder.
bool leftNothing(const std::string& out) {
  const fs::path path(out);
  for (const auto& e : fs::directory_iterator(path.parent_path())) {
    if (e.path().filename().string().rfind(path.filename().string(), 0) == 0) return false;
  }
  return true;
}

BagRunOptions quiet() {
  BagRunOptions o;
  o.progress = false;
  return o;
}

}  // namespace

// Live changes (~set: a stiffer cloth under other gravity; an obstacle added under it) recorded
// as applied are re-applied offline at the same steps: the replay reproduces every recorded
// state bit for bit, and the changes did change the run.
TEST(BagReplay, LiveChangesReplayBitForBit) {
  test::TempDir dir("fem_cloth_bag_replay_live");
  SetCommand set;
  set.header.stamp = kEpoch + ros::Duration(0.2);
  set.pairs = {"material.youngs_modulus=4.0e6", "gravity=[0, 0, -5]"};
  ObstacleCommand ball;
  ball.header.stamp = kEpoch + ros::Duration(0.4);
  ball.action = ObstacleCommand::ADD;
  ball.name = "ball";
  ball.entry = "{type: sphere, center: [0.3, 0.3, -0.3], radius: 0.1}";
  const Recorded plain = recordRun(dir.path("plain.bag"), 90);
  const Recorded live = recordRun(dir.path("live.bag"), 90, true, {set, ball});
  EXPECT_NE(live.finalHash, plain.finalHash) << "the live changes changed nothing";
  Expected<BagRunReport> r = runToBag(dir.path("live.bag"), dir.path("replay.bag"), quiet());
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->commands[static_cast<std::size_t>(CommandTopic::Set)], 1u);
  EXPECT_EQ(r->commands[static_cast<std::size_t>(CommandTopic::Obstacle)], 1u);
  EXPECT_EQ(r->rejected, 0u);
  EXPECT_EQ(r->compared, 31u);
  EXPECT_EQ(r->identical, r->compared);
  EXPECT_EQ(r->finalHash, live.finalHash);
  // The replay's own record holds them as applied, at their steps.
  rosbag::Bag bag(dir.path("replay.bag"));
  int sets = 0;
  for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery(kTopics.applied(CommandTopic::Set)))) {
    EXPECT_EQ(m.instantiate<SetCommand>()->header.stamp, kEpoch + ros::Duration(0.2));
    ++sets;
  }
  EXPECT_EQ(sets, 1);
}

// A ball added under the cloth, moved and removed while it runs, each command sent when it is to
// apply (the move and the removal are valid only once the ball is there, issue 31): the replay
// judges each recorded command against the obstacles as they are when it comes, rejects none and
// reproduces every recorded state bit for bit; the ball did change the run.
TEST(BagReplay, AnObstacleAddedMovedAndRemovedLiveReplaysBitForBit) {
  test::TempDir dir("fem_cloth_bag_replay_ball");
  auto edit = [](double t, std::uint8_t action, const std::string& entry) {
    ObstacleCommand c;
    c.header.stamp = kEpoch + ros::Duration(t);
    c.action = action;
    c.name = "ball";
    c.entry = entry;
    return c;
  };
  const std::vector<Command> edits = {edit(0.05, ObstacleCommand::ADD, "{type: sphere, center: [0.3, 0.3, -0.15], radius: 0.1}"),
                                      edit(0.4, ObstacleCommand::MOVE, "{center: [0.3, 0.3, -0.6]}"),
                                      edit(0.7, ObstacleCommand::REMOVE, "")};
  const Recorded plain = recordRun(dir.path("plain.bag"), 90);
  const Recorded live = recordRun(dir.path("live.bag"), 90, true, {}, edits);
  EXPECT_NE(live.finalHash, plain.finalHash) << "the ball changed nothing";
  Expected<BagRunReport> r = runToBag(dir.path("live.bag"), dir.path("replay.bag"), quiet());
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->commands[static_cast<std::size_t>(CommandTopic::Obstacle)], 3u);
  EXPECT_EQ(r->rejected, 0u);
  for (const std::string& w : r->warnings) ADD_FAILURE() << w;
  EXPECT_EQ(r->compared, 31u);
  EXPECT_EQ(r->identical, r->compared) << r->firstDifference;
  EXPECT_EQ(r->finalHash, live.finalHash);
  // The replay's own record moves and removes the ball.
  rosbag::Bag bag(dir.path("replay.bag"));
  std::vector<std::uint8_t> actions;
  for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery(kTopics.applied(CommandTopic::Obstacle)))) {
    actions.push_back(m.instantiate<ObstacleCommand>()->action);
  }
  EXPECT_EQ(actions, (std::vector<std::uint8_t>{ObstacleCommand::ADD, ObstacleCommand::MOVE, ObstacleCommand::REMOVE}));
}

// A bad pair is refused when submitted, naming it, and nothing of the command is applied.
TEST(BagReplay, BadLiveChangeIsRefusedWhole) {
  tf2::BufferCore tf(ros::Duration(100.0));
  SimulationDriver driver = makeDriver(&tf);
  SetCommand set;
  set.pairs = {"damping.mass=2", "material.poisson_ratio=0.7"};
  const Status s = driver.submit(set);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("material.poisson_ratio"), std::string::npos) << s.error();
  ObstacleCommand gone;
  gone.action = ObstacleCommand::REMOVE;
  gone.name = "nothing";
  const Status g = driver.submit(gone);
  ASSERT_FALSE(g.ok());
  EXPECT_NE(g.error().find("there is no obstacle named 'nothing'"), std::string::npos) << g.error();
  ASSERT_TRUE(driver.step().ok);
  EXPECT_EQ(driver.document()["damping"]["mass"].as<double>(), 0.5);
  EXPECT_EQ(driver.commandCounts(CommandTopic::Set).rejected, 1u);
}

TEST(BagReplay, OfflineReplayReproducesTheRecordedRun) {
  test::TempDir dir("fem_cloth_bag_replay");
  const Recorded rec = recordRun(dir.path("run.bag"), 99);
  Expected<BagRunReport> r = runToBag(dir.path("run.bag"), dir.path("replay.bag"), quiet());
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_TRUE(r->exactCommands);
  EXPECT_EQ(r->commands[static_cast<std::size_t>(CommandTopic::Pin)], 2u);
  EXPECT_EQ(r->commands[static_cast<std::size_t>(CommandTopic::Force)], 1u);
  EXPECT_EQ(r->rejected, 0u);
  // 99 steps, a state every 3: steps 0, 3, ..., 99.
  EXPECT_EQ(r->steps, 99u);
  EXPECT_EQ(r->compared, 34u);
  EXPECT_EQ(r->identical, r->compared);
  EXPECT_EQ(r->finalHash, rec.finalHash);
  // The output holds the same states (and is a bag rosbag reads).
  EXPECT_EQ(statesOf(dir.path("replay.bag")), rec.hashes);
  // The grasp really changed the run: without the commands the final state differs.
  tf2::BufferCore tf;
  SimulationDriver free = makeDriver(&tf);
  for (int k = 0; k < 99; ++k) free.step();
  EXPECT_NE(stateHash(free.simulator().state().x, free.simulator().state().v), rec.finalHash);
}

TEST(BagReplay, ReplaysAreDeterministic) {
  test::TempDir dir("fem_cloth_bag_replay");
  recordRun(dir.path("run.bag"), 60);
  Expected<BagRunReport> a = runToBag(dir.path("run.bag"), dir.path("a.bag"), quiet());
  Expected<BagRunReport> b = runToBag(dir.path("run.bag"), dir.path("b.bag"), quiet());
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->finalHash, b->finalHash);
  EXPECT_EQ(statesOf(dir.path("a.bag")), statesOf(dir.path("b.bag")));
}

TEST(BagReplay, CommandsAsSentTakeEffectAfterTheyWereRecorded) {
  // Sent with zero stamps and recorded at exactly the times the applied stream would carry, the
  // commands take effect at the same steps: the run is the same.
  test::TempDir dir("fem_cloth_bag_replay");
  const Recorded applied = recordRun(dir.path("applied.bag"), 60, true);
  recordRun(dir.path("sent.bag"), 60, false);
  Expected<BagRunReport> r = runToBag(dir.path("sent.bag"), dir.path("replay.bag"), quiet());
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_FALSE(r->exactCommands);
  EXPECT_EQ(r->finalHash, applied.finalHash);
}

TEST(BagReplay, AnotherSceneOrIntegratorIsADifferentRun) {
  test::TempDir dir("fem_cloth_bag_replay");
  recordRun(dir.path("run.bag"), 60);
  BagRunOptions o = quiet();
  o.overrides = {"integrator.name=backward_euler"};
  Expected<BagRunReport> r = runToBag(dir.path("run.bag"), dir.path("be.bag"), o);
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->integrator, "backward_euler");
  EXPECT_GT(r->compared, 0u);
  EXPECT_LT(r->identical, r->compared);
}

TEST(BagReplay, MissingUnreadableAndTruncatedBags) {
  test::TempDir dir("fem_cloth_bag_replay");
  const std::string out = dir.path("out.bag");
  Expected<BagRunReport> missing = runToBag(dir.path("nope.bag"), out, quiet());
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().find("no bag at"), std::string::npos) << missing.error();
  EXPECT_TRUE(leftNothing(out));

  const std::string junk = dir.write("junk.bag", "this is not a bag\n");
  Expected<BagRunReport> unreadable = runToBag(junk, out, quiet());
  ASSERT_FALSE(unreadable.ok());
  EXPECT_NE(unreadable.error().find("junk.bag"), std::string::npos) << unreadable.error();
  EXPECT_TRUE(leftNothing(out));

  // A bag cut in the middle, as a recorder killed mid-write leaves it.
  recordRun(dir.path("run.bag"), 30);
  const auto size = fs::file_size(dir.path("run.bag"));
  fs::copy_file(dir.path("run.bag"), dir.path("cut.bag"));
  fs::resize_file(dir.path("cut.bag"), size / 2);
  Expected<BagRunReport> cut = runToBag(dir.path("cut.bag"), out, quiet());
  ASSERT_FALSE(cut.ok());
  EXPECT_NE(cut.error().find("cut.bag"), std::string::npos);
  EXPECT_NE(cut.error().find("truncated"), std::string::npos) << cut.error();
  EXPECT_TRUE(leftNothing(out));
}

TEST(BagReplay, WrongTypesAreNamed) {
  test::TempDir dir("fem_cloth_bag_replay");
  {
    rosbag::Bag bag(dir.path("wrong.bag"), rosbag::bagmode::Write);
    std_msgs::String s;
    s.data = "pin vertex 3";
    bag.write(kTopics.pin, kEpoch, s);
    s.data = kScene;
    bag.write(kTopics.scene, kEpoch, s);
  }
  Expected<BagRunReport> r = runToBag(dir.path("wrong.bag"), dir.path("out.bag"), quiet());
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("topic /fem_cloth_node/pin holds std_msgs/String messages, expected "
                           "fem_cloth/PinCommand"),
            std::string::npos)
      << r.error();
  EXPECT_TRUE(leftNothing(dir.path("out.bag")));
}

TEST(BagReplay, AMeshThatIsNotTheScenesIsRefused) {
  test::TempDir dir("fem_cloth_bag_replay");
  recordRun(dir.path("run.bag"), 10);
  // The same scene at another resolution does not fit the recorded mesh.
  const std::string other = dir.write("other.yaml", std::string(kScene) + "\n");
  BagRunOptions o = quiet();
  o.sceneFile = other;
  o.overrides = {"mesh.rows=5", "mesh.cols=5"};
  Expected<BagRunReport> r = runToBag(dir.path("run.bag"), dir.path("out.bag"), o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("the mesh stored in the bag (49 vertices, 72 triangles) is not the "
                           "scene's mesh (25 vertices, 32 triangles)"),
            std::string::npos)
      << r.error();
  EXPECT_TRUE(leftNothing(dir.path("out.bag")));
}

TEST(BagReplay, ABagWithoutASceneNeedsOne) {
  test::TempDir dir("fem_cloth_bag_replay");
  {
    rosbag::Bag bag(dir.path("bare.bag"), rosbag::bagmode::Write);
    bag.write(kTopics.pin, kEpoch, pinCommands()[0]);
  }
  Expected<BagRunReport> r = runToBag(dir.path("bare.bag"), dir.path("out.bag"), quiet());
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("holds no scene"), std::string::npos) << r.error();
  EXPECT_TRUE(leftNothing(dir.path("out.bag")));
}

TEST(BagReplay, ASceneAloneRunsIntoABag) {
  test::TempDir dir("fem_cloth_bag_replay");
  BagRunOptions o = quiet();
  o.sceneFile = dir.write("scene.yaml", kScene);
  o.duration = 0.5;
  Expected<BagRunReport> r = runToBag("", dir.path("scene.bag"), o);
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_EQ(r->steps, 50u);
  // The same run stepped directly ends in the same state.
  tf2::BufferCore tf;
  SimulationDriver direct = makeDriver(&tf);
  for (int k = 0; k < 50; ++k) direct.step();
  EXPECT_EQ(r->finalHash, stateHash(direct.simulator().state().x, direct.simulator().state().v));
  // About 30 states per simulated second: every 3rd step, and the last.
  const auto states = statesOf(dir.path("scene.bag"));
  EXPECT_EQ(states.size(), 18u);
  EXPECT_EQ(states.rbegin()->first, 50u);
}

// A simulation that fails is not bad input: runToBag reports it (failure, the steps taken), and
// writes no bag (fem_cloth_sim exits 3, not 2, from this rather than from the error's text).
TEST(BagReplay, ASimulationThatFailsIsAReportAndLeavesNoBag) {
  test::TempDir dir("fem_cloth_bag_replay");
  recordRun(dir.path("run.bag"), 30);
  BagRunOptions o = quiet();
  // Symplectic Euler told not to substep, far beyond its stability bound.
  o.overrides = {"integrator.auto_substep=false", "integrator.dt=1"};
  o.duration = 3.0;
  Expected<BagRunReport> r = runToBag(dir.path("run.bag"), dir.path("out.bag"), o);
  ASSERT_TRUE(r.ok()) << r.error();
  EXPECT_NE(r->failure.find("the simulation failed at step 1"), std::string::npos) << r->failure;
  EXPECT_NE(r->failure.find("CFL bound"), std::string::npos) << r->failure;
  EXPECT_EQ(r->steps, 0u);
  EXPECT_TRUE(leftNothing(dir.path("out.bag")));
  // A run that succeeds has no failure.
  Expected<BagRunReport> ok = runToBag(dir.path("run.bag"), dir.path("ok.bag"), quiet());
  ASSERT_TRUE(ok.ok()) << ok.error();
  EXPECT_TRUE(ok->failure.empty());
}

// The output is never one of the inputs: the recording stays as it was.
TEST(BagReplay, TheOutputIsNeverTheInput) {
  test::TempDir dir("fem_cloth_bag_replay");
  const Recorded rec = recordRun(dir.path("run.bag"), 30);
  Expected<BagRunReport> r = runToBag(dir.path("run.bag"), dir.path("run.bag"), quiet());
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("is the input"), std::string::npos) << r.error();
  EXPECT_EQ(statesOf(dir.path("run.bag")), rec.hashes);
  BagRunOptions o = quiet();
  o.sceneFile = dir.write("scene.bag", kScene);
  r = runToBag(dir.path("run.bag"), o.sceneFile, o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().find("scene.bag"), std::string::npos) << r.error();
  EXPECT_EQ(test::readTextFile(o.sceneFile), kScene);
}
