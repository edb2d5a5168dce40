// Pins in a frame moved by tf, driven in process without a ROS master: exact where tf can
// interpolate; the node waits for transforms that can still arrive (later than the newest one),
// not for those that never will (before the frame's first transform), which are served by the
// nearest transform with a warning; beyond tf_timeout a command is refused, naming the frame.
// A frame that stops or jumps loses its pins, which stay where they are. And the driver's
// command checks that need no frame: far pin targets, stamps out of range, the pending cap and
// the counts.
#include <gtest/gtest.h>

#include "fem_cloth/io/scene_yaml.h"
#include "fem_cloth/ros/simulation_driver.h"

using namespace fem_cloth;

namespace {

const char* kScene = R"(
name: frames_test
mesh: {type: grid, rows: 5, cols: 5, width: 0.4, height: 0.4}
material: {model: stvk, youngs_modulus: 2.0e6, poisson_ratio: 0.3, thickness: 5.0e-4, density: 2000}
integrator: {name: backward_euler, dt: 0.01}
pins:
  - grid_vertices: [[0, 0], [0, -1]]
)";

const ros::Time kEpoch(1000.0);

// The gripper rises at 1 m/s from z = 0 at simulation time 0, at x = 2 m.
geometry_msgs::TransformStamped gripperAt(double t) {
  geometry_msgs::TransformStamped tf;
  tf.header.stamp = kEpoch + ros::Duration(t);
  tf.header.frame_id = "world";
  tf.child_frame_id = "gripper";
  tf.transform.translation.x = 2.0;
  tf.transform.translation.z = t;
  tf.transform.rotation.w = 1.0;
  return tf;
}

DriverSettings defaultSettings() {
  DriverSettings settings;
  settings.epoch = kEpoch;
  settings.tfTimeout = 1.0;
  return settings;
}

SimulationDriver makeDriver(const tf2::BufferCore* tf, DriverSettings settings = defaultSettings()) {
  const Scene scene = *parseScene(YAML::Load(kScene));
  return SimulationDriver(std::move(buildSimulation(scene).value()), settings, tf);
}

// The first tests pin vertex 12 to the gripper's origin, 1.8 m from it: not a jump the driver
// refuses (max_pin_jump), though the simulator flags it as a pin jump in the first step.
SimulationDriver makeGripperDriver(const tf2::BufferCore* tf) {
  DriverSettings settings = defaultSettings();
  settings.maxPinJump = 10.0;
  return makeDriver(tf, settings);
}

PinCommand pinInGripper(Index vertex) {
  PinCommand c;
  c.header.frame_id = "gripper";
  c.action = PinCommand::PIN_AT_TARGETS;
  c.vertices = {static_cast<std::uint32_t>(vertex)};
  c.targets.resize(1);  // at the gripper's origin
  return c;
}

}  // namespace

TEST(Frames, APinFollowsItsFrameExactlyWhereTfCanInterpolate) {
  tf2::BufferCore tf(ros::Duration(100.0));
  for (int k = 0; k <= 50; ++k) tf.setTransform(gripperAt(0.01 * k), "test");
  SimulationDriver driver = makeGripperDriver(&tf);
  ASSERT_TRUE(driver.submit(pinInGripper(12)).ok());
  for (int k = 1; k <= 20; ++k) {
    std::string missing;
    ASSERT_TRUE(driver.transformsReady(&missing)) << missing;
    ASSERT_TRUE(driver.step().ok);
    // Where the gripper is at the end of step k: (2, 0, 0.01 k).
    EXPECT_EQ(driver.simulator().pinTarget(12), Eigen::Vector3d(2.0, 0.0, 0.01 * k)) << k;
    const std::vector<std::string> warnings = driver.takeWarnings();
    if (k == 1) {
      // 1.8 m in 0.01 s: a pin jump, taken and flagged.
      ASSERT_EQ(warnings.size(), 1u);
      EXPECT_EQ(warnings[0].rfind("pin jump in the step at t = 0 s", 0), 0u) << warnings[0];
    } else {
      EXPECT_TRUE(warnings.empty()) << k << ": " << warnings.front();
    }
  }
  // Past the newest transform (t = 0.5 s) the node has to wait: it may still arrive.
  while (driver.simulator().time() < 0.495) ASSERT_TRUE(driver.step().ok);
  std::string missing;
  EXPECT_FALSE(driver.transformsReady(&missing));
  EXPECT_NE(missing.find("gripper"), std::string::npos) << missing;
}

// tf is asked once per frame and time: a step with a pin following the gripper needs the
// gripper at one new time (the step's end; its start was the last step's end), which costs the
// newest-transform lookup and the exact one; the wait check before the step, the pin, and the
// grasp wrench after it take it from there.
TEST(Frames, EachStepLooksUpAFollowedFrameOnceAtItsOneNewTime) {
  tf2::BufferCore tf(ros::Duration(100.0));
  for (int k = 0; k <= 50; ++k) tf.setTransform(gripperAt(0.01 * k), "test");
  SimulationDriver driver = makeGripperDriver(&tf);
  ASSERT_TRUE(driver.submit(pinInGripper(12)).ok());
  ASSERT_TRUE(driver.step().ok);
  const VectorX reactions = driver.simulator().pinReactions();
  ASSERT_EQ(driver.graspWrenches(reactions).size(), 2u);  // the gripper's, and the fixed pins'
  for (int k = 2; k <= 10; ++k) {
    const std::uint64_t before = driver.frames().lookups();
    std::string missing;
    ASSERT_TRUE(driver.transformsReady(&missing)) << missing;
    ASSERT_TRUE(driver.step().ok);
    ASSERT_EQ(driver.graspWrenches(driver.simulator().pinReactions()).size(), 2u);
    EXPECT_EQ(driver.frames().lookups() - before, 2u) << "step " << k;
    EXPECT_EQ(driver.simulator().pinTarget(12), Eigen::Vector3d(2.0, 0.0, 0.01 * k)) << k;
  }
}

TEST(Frames, BeforeItsFirstTransformAFrameIsServedTheNearestWithoutWaiting) {
  // The gripper appears at t = 0.3 s; the pin is commanded at t = 0.
  tf2::BufferCore tf(ros::Duration(100.0));
  for (int k = 30; k <= 60; ++k) tf.setTransform(gripperAt(0.01 * k), "test");
  SimulationDriver driver = makeGripperDriver(&tf);
  ASSERT_TRUE(driver.submit(pinInGripper(12)).ok());
  std::string missing;
  // Waiting cannot help: transforms for t < 0.3 s never arrive.
  EXPECT_TRUE(driver.transformsReady(&missing)) << missing;
  ASSERT_TRUE(driver.step().ok);
  // Held where the gripper first was (t = 0.3 s), to within the bisection's 1 us of time.
  EXPECT_NEAR((driver.simulator().pinTarget(12) - Eigen::Vector3d(2.0, 0.0, 0.3)).norm(), 0.0, 2e-6);
  const std::vector<std::string> warnings = driver.takeWarnings();
  ASSERT_FALSE(warnings.empty());
  EXPECT_NE(warnings.front().find("'gripper'"), std::string::npos) << warnings.front();
  EXPECT_NE(warnings.front().find("first transform"), std::string::npos) << warnings.front();
  // From t = 0.3 s on it is exact again, with no warning.
  while (driver.simulator().time() < 0.395) ASSERT_TRUE(driver.step().ok);
  driver.takeWarnings();
  ASSERT_TRUE(driver.step().ok);
  EXPECT_LT((driver.simulator().pinTarget(12) - Eigen::Vector3d(2.0, 0.0, 0.41)).norm(), 1e-12);
  EXPECT_TRUE(driver.takeWarnings().empty());
}

TEST(Frames, AFrameThatAppearsLaterThanTfTimeoutIsRefusedByName) {
  // The gripper appears at t = 1.5 s, more than tf_timeout = 1 s after the command's time.
  tf2::BufferCore tf(ros::Duration(100.0));
  for (int k = 150; k <= 160; ++k) tf.setTransform(gripperAt(0.01 * k), "test");
  SimulationDriver driver = makeGripperDriver(&tf);
  const Status s = driver.submit(pinInGripper(12));
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("'gripper'"), std::string::npos) << s.error();
  EXPECT_NE(s.error().find("first transform"), std::string::npos) << s.error();
  EXPECT_FALSE(driver.simulator().isPinned(12));
}

namespace {

// A frame "hand" at (x, 0, z) at simulation time t.
geometry_msgs::TransformStamped handAt(double t, double x, double z) {
  geometry_msgs::TransformStamped tf = gripperAt(t);
  tf.child_frame_id = "hand";
  tf.transform.translation.x = x;
  tf.transform.translation.z = z;
  return tf;
}

PinCommand pinInPlace(const std::string& frame, std::vector<std::uint32_t> vertices) {
  PinCommand c;
  c.header.frame_id = frame;
  c.action = PinCommand::PIN_IN_PLACE;
  c.vertices = std::move(vertices);
  return c;
}

Eigen::Vector3d positionOf(const SimulationDriver& driver, Index v) {
  return driver.simulator().state().x.segment<3>(3 * v);
}

bool anyContains(const std::vector<std::string>& lines, const std::string& part) {
  for (const std::string& l : lines) {
    if (l.find(part) != std::string::npos) return true;
  }
  return false;
}

}  // namespace

TEST(Frames, APinWhoseFrameStopsIsDroppedAfterTfTimeoutAndStaysWhereItIs) {
  // The hand rises at 1 m/s from t = 0 until its publisher stops at t = 0.5 s.
  tf2::BufferCore tf(ros::Duration(100.0));
  for (int k = 0; k <= 50; ++k) tf.setTransform(handAt(0.01 * k, 0.0, 0.01 * k), "test");
  SimulationDriver driver = makeDriver(&tf);
  const Eigen::Vector3d start = positionOf(driver, 12);
  ASSERT_TRUE(driver.submit(pinInPlace("hand", {12})).ok());
  double droppedAt = -1.0;
  while (driver.simulator().time() < 2.0) {
    ASSERT_TRUE(driver.step().ok);
    const std::vector<std::string> warnings = driver.takeWarnings();
    if (anyContains(warnings, "stop following frame 'hand'")) {
      ASSERT_LT(droppedAt, 0.0) << "dropped twice";
      droppedAt = driver.simulator().time();
      EXPECT_TRUE(anyContains(warnings, "vertex 12")) << warnings.front();
      EXPECT_TRUE(anyContains(warnings, "stale")) << warnings.front();
    } else if (droppedAt > 0.0) {
      EXPECT_TRUE(warnings.empty()) << warnings.front();  // silent once dropped
    }
  }
  // Dropped at the first step whose end is more than tf_timeout = 1 s after the newest transform
  // (t = 0.5 s): the one ending at 1.5 or 1.51 s (1.5 - 0.5 is 1 s up to the clock's rounding).
  EXPECT_GE(droppedAt, 1.5 - 1e-9);
  EXPECT_LE(droppedAt, 1.51 + 1e-9);
  // Still pinned, where the hand last was: 0.5 m above its start.
  EXPECT_TRUE(driver.simulator().isPinned(12));
  EXPECT_LT((positionOf(driver, 12) - (start + Eigen::Vector3d(0.0, 0.0, 0.5))).norm(), 1e-12);
  std::string missing;
  EXPECT_TRUE(driver.transformsReady(&missing)) << missing;  // it needs the hand no more
  EXPECT_TRUE(driver.framesNotReady().empty());
}

TEST(Frames, AFrameThatJumpsFartherThanMaxPinJumpLosesItsPins) {
  // The hand is at the origin until t = 0.1 s, then 50 m away.
  tf2::BufferCore tf(ros::Duration(100.0));
  for (int k = 0; k <= 30; ++k) tf.setTransform(handAt(0.01 * k, k <= 10 ? 0.0 : 50.0, 0.0), "test");
  SimulationDriver driver = makeDriver(&tf);
  const Eigen::Vector3d start = positionOf(driver, 12);
  ASSERT_TRUE(driver.submit(pinInPlace("hand", {12, 6})).ok());
  std::vector<std::string> warnings;
  for (int k = 1; k <= 11; ++k) {
    ASSERT_TRUE(driver.step().ok);
    warnings = driver.takeWarnings();
    if (k < 11) {
      EXPECT_TRUE(warnings.empty()) << warnings.front();
    }
  }
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("vertices 6 and 12 stop following frame 'hand'"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[0].find("max_pin_jump = 1 m"), std::string::npos) << warnings[0];
  EXPECT_TRUE(driver.simulator().isPinned(12));
  EXPECT_EQ(positionOf(driver, 12), start);
}

TEST(Commands, APinTargetFartherThanMaxPinJumpIsRefusedWholeNamingVertexAndDistance) {
  SimulationDriver driver = makeDriver(nullptr);
  const Eigen::Vector3d p6 = positionOf(driver, 6), p12 = positionOf(driver, 12);
  PinCommand c;
  c.header.frame_id = "world";
  c.action = PinCommand::PIN_AT_TARGETS;
  c.vertices = {6, 12};
  const Eigen::Vector3d near = p6 + Eigen::Vector3d(0.0, 0.0, 0.1);
  const Eigen::Vector3d far = p12 + Eigen::Vector3d(3.0, 4.0, 0.0);  // 5 m away
  c.targets.resize(2);
  c.targets[0].x = near.x();
  c.targets[0].y = near.y();
  c.targets[0].z = near.z();
  c.targets[1].x = far.x();
  c.targets[1].y = far.y();
  c.targets[1].z = far.z();
  ASSERT_TRUE(driver.submit(c).ok());  // valid as a message; refused when due
  ASSERT_TRUE(driver.step().ok);
  const std::vector<std::string> warnings = driver.takeWarnings();
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("the target of vertex 12 is 5 m from where the vertex is (max_pin_jump = 1 m)"),
            std::string::npos) << warnings[0];
  EXPECT_FALSE(driver.simulator().isPinned(6));  // not half applied
  EXPECT_FALSE(driver.simulator().isPinned(12));
  EXPECT_TRUE(driver.takeAppliedPins().empty());
  const CommandCounts n = driver.commandCounts(CommandTopic::Pin);
  EXPECT_EQ(n.received, 1u);
  EXPECT_EQ(n.rejected, 1u);
  EXPECT_EQ(n.applied, 0u);
  // Within the limit it is applied.
  c.vertices = {6};
  c.targets.resize(1);
  ASSERT_TRUE(driver.submit(c).ok());
  ASSERT_TRUE(driver.step().ok);
  EXPECT_TRUE(driver.simulator().isPinned(6));
  EXPECT_EQ(positionOf(driver, 6), near);
  EXPECT_EQ(driver.commandCounts(CommandTopic::Pin).applied, 1u);
}

TEST(Commands, AStampNoDurationRelatesToTheEpochIsRefusedNamingTheField) {
  tf2::BufferCore tf(ros::Duration(100.0));
  for (int k = 0; k <= 50; ++k) tf.setTransform(gripperAt(0.01 * k), "test");
  SimulationDriver driver = makeGripperDriver(&tf);
  // 2^32 - 1 s is 4294966295 s after the epoch (1000 s): no ros::Duration holds that. Checked
  // before tf sees it (tf's own arithmetic would throw), in any frame.
  for (const char* frame : {"world", "gripper"}) {
    ForceCommand c;
    c.header.frame_id = frame;
    c.header.stamp = ros::Time(4294967295u, 0u);
    c.vertices = {3};
    c.forces.resize(1);
    const Status s = driver.submit(c);
    ASSERT_FALSE(s.ok()) << frame;
    EXPECT_NE(s.error().find("header.stamp = 4294967295.000000000 s is 4294966295 s from the simulation's time origin "
                             "(ROS time 1000.000000000 s)"),
              std::string::npos) << s.error();
  }
  PinCommand pin = pinInGripper(12);
  pin.header.stamp = ros::Time(4294967295u, 0u);
  EXPECT_FALSE(driver.submit(pin).ok());
  // A stamp 10^9 s ahead is a ROS duration: accepted, and waits.
  ForceCommand later;
  later.header.frame_id = "world";
  later.header.stamp = kEpoch + ros::Duration(1e9);
  later.vertices = {3};
  later.forces.resize(1);
  EXPECT_TRUE(driver.submit(later).ok());
  EXPECT_EQ(driver.commandCounts(CommandTopic::Force).rejected, 2u);
  EXPECT_EQ(driver.commandCounts(CommandTopic::Force).pending, 1u);
  EXPECT_EQ(driver.commandCounts(CommandTopic::Pin).rejected, 1u);
  ASSERT_TRUE(driver.step().ok);
}

namespace {

// A driver that lets `cap` commands of a topic wait for later, and a zero force on vertex 3.
SimulationDriver cappedDriver(std::size_t cap) {
  DriverSettings settings = defaultSettings();
  settings.maxPendingCommands = cap;
  return makeDriver(nullptr, settings);
}

ForceCommand zeroForce() {
  ForceCommand c;
  c.header.frame_id = "world";
  c.vertices = {3};
  c.forces.resize(1);
  return c;
}

}  // namespace

TEST(Commands, PendingCommandsAreCappedCountedAndDiscardedByReset) {
  SimulationDriver driver = cappedDriver(5);
  ForceCommand c = zeroForce();
  for (int k = 1; k <= 6; ++k) {
    c.header.stamp = kEpoch + ros::Duration(100.0 + k);  // all in the future
    const Status s = driver.submit(c);
    EXPECT_EQ(s.ok(), k <= 5) << k;
    if (k == 6) {
      EXPECT_NE(s.error().find("(max_pending_commands = 5)"), std::string::npos) << s.error();
    }
  }
  CommandCounts n = driver.commandCounts(CommandTopic::Force);
  EXPECT_EQ(n.received, 6u);
  EXPECT_EQ(n.rejected, 1u);
  EXPECT_EQ(n.pending, 5u);
  driver.reset();
  n = driver.commandCounts(CommandTopic::Force);
  EXPECT_EQ(n.pending, 0u);
  EXPECT_EQ(n.discarded, 5u);
  EXPECT_EQ(n.received, n.rejected + n.applied + n.pending + n.discarded);
  // Room again: commands for the next step are applied and counted.
  c.header.stamp = ros::Time();
  for (int k = 0; k < 4; ++k) ASSERT_TRUE(driver.submit(c).ok());
  ASSERT_TRUE(driver.step().ok);
  EXPECT_EQ(driver.takeAppliedForces().size(), 4u);
  EXPECT_EQ(driver.commandCounts(CommandTopic::Force).applied, 4u);
  EXPECT_EQ(driver.commandCounts(CommandTopic::Pin).received, 0u);
}

TEST(Commands, AStepWhoseEndIsNoRosTimeIsRefusedAndLeavesTheState) {
  // The epoch 5 ms before the last ROS time: the first step (10 ms) would end beyond it.
  DriverSettings settings = defaultSettings();
  settings.epoch = ros::Time(4294967295u, 995000000u);
  SimulationDriver driver = makeDriver(nullptr, settings);
  const StepReport r = driver.step();
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.error.find("is not a ROS time"), std::string::npos) << r.error;
  EXPECT_EQ(driver.stepIndex(), 0u);
  EXPECT_EQ(driver.now(), settings.epoch);
}

// The cap counts a topic's commands for later: once the forces fill it, a force for the next
// step and a pin for later still go in (issue 31: 500 waiting pins once refused every ~set).
TEST(Commands, ThePendingCapIsPerTopicAndNeverRefusesTheNextStep) {
  SimulationDriver driver = cappedDriver(2);
  ForceCommand c = zeroForce();
  for (int k = 1; k <= 3; ++k) {
    c.header.stamp = kEpoch + ros::Duration(100.0 + k);
    const Status s = driver.submit(c);
    EXPECT_EQ(s.ok(), k <= 2) << k;
    if (k == 3) {
      EXPECT_NE(s.error().find("2 ~force commands"), std::string::npos) << s.error();
    }
  }
  for (const ros::Time& next : {ros::Time(), kEpoch}) {  // a zero stamp, and the current time
    c.header.stamp = next;
    EXPECT_TRUE(driver.submit(c).ok());
  }
  PinCommand later = pinInPlace("world", {12});
  later.header.stamp = kEpoch + ros::Duration(50.0);
  EXPECT_TRUE(driver.submit(later).ok());
  ASSERT_TRUE(driver.step().ok);
  EXPECT_EQ(driver.commandCounts(CommandTopic::Force).applied, 2u);
  EXPECT_EQ(driver.commandCounts(CommandTopic::Force).pending, 2u);
  EXPECT_EQ(driver.commandCounts(CommandTopic::Pin).pending, 1u);
}

// What the services wait for: a ticketed command's outcome, applied (a grasp with the vertices
// it pinned) or refused with the reason; a paused node applies them without a step, and leaves
// the commands from the topics (no ticket) for the step.
TEST(Commands, ATicketedCommandsOutcomeIsTheOutcomeOfApplyingIt) {
  SimulationDriver driver = makeDriver(nullptr);
  EXPECT_FALSE(driver.ticketedDueNow());
  GraspCommand near, far;
  near.header.frame_id = far.header.frame_id = "world";
  // Vertex 12 is grid vertex (2, 2) of the 0.4 m 5 x 5 grid: (0.2, 0.2, 0); its neighbours are
  // 0.1 m away, outside 1 cm.
  near.point.x = near.point.y = 0.2;
  near.radius = far.radius = 0.01;
  far.point = near.point;
  far.point.z = 1.0;
  ForceCommand push = zeroForce();
  ASSERT_TRUE(driver.submit(push).ok());  // from a topic: no ticket
  ASSERT_TRUE(driver.submit(near, 5).ok());
  ASSERT_TRUE(driver.submit(far, 6).ok());  // no frame to check: refused when applied
  EXPECT_TRUE(driver.ticketedDueNow());
  driver.applyTicketedNow();
  EXPECT_EQ(driver.stepIndex(), 0u);
  EXPECT_FALSE(driver.ticketedDueNow());
  EXPECT_EQ(driver.commandCounts(CommandTopic::Force).pending, 1u);
  const std::vector<SimulationDriver::Outcome> outcomes = driver.takeOutcomes();
  ASSERT_EQ(outcomes.size(), 2u);
  EXPECT_EQ(outcomes[0].ticket, 5u);
  ASSERT_TRUE(outcomes[0].status.ok()) << outcomes[0].status.error();
  EXPECT_EQ(std::get<GraspCommand>(outcomes[0].command).vertices, (std::vector<std::uint32_t>{12}));
  EXPECT_TRUE(driver.simulator().isPinned(12));
  EXPECT_EQ(outcomes[1].ticket, 6u);
  ASSERT_FALSE(outcomes[1].status.ok());
  EXPECT_NE(outcomes[1].status.error().find("no vertex within 0.01 m"), std::string::npos) << outcomes[1].status.error();
  EXPECT_EQ(driver.takeApplied<GraspCommand>().size(), 1u);
  EXPECT_TRUE(driver.takeOutcomes().empty());
  // Withdrawn before it was due (a node that paused itself, a ~reset): counted as discarded.
  ASSERT_TRUE(driver.submit(near, 7).ok());
  ASSERT_TRUE(driver.submit(far).ok());
  EXPECT_EQ(driver.withdrawTicketed(), (std::vector<std::uint64_t>{7}));
  const CommandCounts n = driver.commandCounts(CommandTopic::Grasp);
  EXPECT_EQ(n.discarded, 1u);
  EXPECT_EQ(n.pending, 1u);
  EXPECT_EQ(n.received, n.rejected + n.applied + n.pending + n.discarded);
}

// Frames gripper-1 and gripper_1 would share the wrench topic ~grasp/gripper_1/wrench (a ROS name
// holds no '-'): the second is refused, on submission and, if both came before either applied,
// when applied.
TEST(Commands, TwoFramesNeverShareAWrenchTopic) {
  EXPECT_EQ(graspWrenchTopic("gripper-1"), "grasp/gripper_1/wrench");
  EXPECT_EQ(graspWrenchTopic("/gripper_1"), "grasp/gripper_1/wrench");
  tf2::BufferCore tf(ros::Duration(100.0));
  for (const char* frame : {"gripper-1", "gripper_1"}) {
    for (int k = 0; k <= 50; ++k) {
      geometry_msgs::TransformStamped t = handAt(0.01 * k, 0.0, 0.0);
      t.child_frame_id = frame;
      tf.setTransform(t, "test");
    }
  }
  SimulationDriver driver = makeDriver(&tf);
  ASSERT_TRUE(driver.submit(pinInPlace("gripper-1", {12})).ok());
  ASSERT_TRUE(driver.submit(pinInPlace("gripper_1", {6})).ok());  // neither applied yet
  ASSERT_TRUE(driver.step().ok);
  EXPECT_TRUE(driver.simulator().isPinned(12));
  EXPECT_FALSE(driver.simulator().isPinned(6));
  EXPECT_TRUE(anyContains(driver.takeWarnings(), "frame 'gripper_1' would share the wrench topic ~grasp/gripper_1/wrench "
                                                 "with frame 'gripper-1'"));
  const Status s = driver.submit(pinInPlace("gripper_1", {6}));
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("'gripper-1', which pins follow"), std::string::npos) << s.error();
  EXPECT_TRUE(driver.submit(pinInPlace("gripper-1", {6})).ok());  // the same frame: its own topic
  // Released, gripper-1 frees the topic.
  PinCommand release = pinInPlace("world", {12, 6});
  release.action = PinCommand::RELEASE;
  ASSERT_TRUE(driver.step().ok);
  ASSERT_TRUE(driver.submit(release).ok());
  ASSERT_TRUE(driver.step().ok);
  EXPECT_TRUE(driver.submit(pinInPlace("gripper_1", {6})).ok());
}

// An obstacle that follows a frame tf does not know yet says which frame and which time it
// waits for (the step's start, as simulation time and ROS time) and why; once the frame comes,
// it is placed there.
TEST(Obstacles, OneNotPlacedYetNamesItsFrameAndTheTime) {
  const std::string scene = std::string(kScene) +
                            "obstacles:\n  - {name: ball, type: sphere, center: [0.0, 0.0, 0.5], radius: 0.05, frame: hand}\n";
  tf2::BufferCore tf(ros::Duration(100.0));
  SimulationDriver driver(std::move(buildSimulation(*parseScene(YAML::Load(scene))).value()), defaultSettings(), &tf);
  ASSERT_TRUE(driver.step().ok);
  ASSERT_TRUE(driver.step().ok);
  std::vector<std::string> warnings = driver.takeWarnings();
  ASSERT_EQ(warnings.size(), 2u);
  // The second step starts at t = 0.01 s, ROS time 1000.01 s (kEpoch 1000 s).
  EXPECT_EQ(warnings[1].rfind("obstacle 'ball' is not placed yet: its frame 'hand' has no pose at the start "
                              "of the step, t = 0.01 s (ROS time 1000.010000000 s): ", 0), 0u) << warnings[1];
  EXPECT_NE(warnings[1].find("hand"), std::string::npos);
  geometry_msgs::TransformStamped hand = gripperAt(0.0);
  hand.child_frame_id = "hand";
  for (int k = 0; k <= 10; ++k) {
    hand.header.stamp = kEpoch + ros::Duration(0.01 * k);
    tf.setTransform(hand, "test");
  }
  ASSERT_TRUE(driver.step().ok);
  for (const std::string& w : driver.takeWarnings()) EXPECT_EQ(w.find("not placed yet"), std::string::npos) << w;
}
