// Pins in a frame moved by tf, driven in process without a ROS master: exact where tf can
// interpolate; the node waits for transforms that can still arrive (later than the newest one),
// not for those that never will (before the frame's first transform), which are served by the
// nearest transform with a warning; beyond tf_timeout a command is refused, naming the frame.
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

SimulationDriver makeDriver(const tf2::BufferCore* tf) {
  const Scene scene = *parseScene(YAML::Load(kScene));
  DriverSettings settings;
  settings.epoch = kEpoch;
  settings.tfTimeout = 1.0;
  return SimulationDriver(std::move(buildSimulation(scene).value()), scene, settings, tf);
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
  SimulationDriver driver = makeDriver(&tf);
  ASSERT_TRUE(driver.submit(pinInGripper(12)).ok());
  for (int k = 1; k <= 20; ++k) {
    std::string missing;
    ASSERT_TRUE(driver.transformsReady(&missing)) << missing;
    ASSERT_TRUE(driver.step().ok);
    // Where the gripper is at the end of step k: (2, 0, 0.01 k).
    EXPECT_EQ(driver.simulator().pinTarget(12), Eigen::Vector3d(2.0, 0.0, 0.01 * k)) << k;
    EXPECT_TRUE(driver.takeWarnings().empty());
  }
  // Past the newest transform (t = 0.5 s) the node has to wait: it may still arrive.
  while (driver.simulator().time() < 0.495) ASSERT_TRUE(driver.step().ok);
  std::string missing;
  EXPECT_FALSE(driver.transformsReady(&missing));
  EXPECT_NE(missing.find("gripper"), std::string::npos) << missing;
}

TEST(Frames, BeforeItsFirstTransformAFrameIsServedTheNearestWithoutWaiting) {
  // The gripper appears at t = 0.3 s; the pin is commanded at t = 0.
  tf2::BufferCore tf(ros::Duration(100.0));
  for (int k = 30; k <= 60; ++k) tf.setTransform(gripperAt(0.01 * k), "test");
  SimulationDriver driver = makeDriver(&tf);
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
  SimulationDriver driver = makeDriver(&tf);
  const Status s = driver.submit(pinInGripper(12));
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().find("'gripper'"), std::string::npos) << s.error();
  EXPECT_NE(s.error().find("first transform"), std::string::npos) << s.error();
  EXPECT_FALSE(driver.simulator().isPinned(12));
}
