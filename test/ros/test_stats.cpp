// What the node's ~stats and /diagnostics say about the cloth's surface reaching into a box
// between its vertices, driven in process without a ROS master (SimulationDriver, statsMessage,
// the diagnostics entries the node publishes), for every integrator.
//
// The scene, test/data/contact/post_through_sheet.yaml: a box's top 10 mm through the middle of a
// triangle whose vertices are all outside it, by hand (the file says how), in every step.
#include <gtest/gtest.h>

#include <algorithm>

#include "fem_cloth/io/scene_yaml.h"
#include "fem_cloth/ros/simulation_driver.h"

using namespace fem_cloth;

namespace {

Scene postScene() {
  Expected<Scene> scene = loadScene(std::string(FEM_CLOTH_TEST_DATA_DIR) + "/contact/post_through_sheet.yaml");
  EXPECT_TRUE(scene) << scene.error();
  return *scene;
}

// The scene with `integrator`, its post's centre at height postZ (m; the file's 0.41 by default).
SimulationDriver postDriver(const std::string& integrator, double postZ = 0.41) {
  Scene scene = postScene();
  scene.integrator = integrator;
  scene.obstacles.at(0).center.z() = postZ;
  DriverSettings settings;
  settings.epoch = ros::Time(1000.0);
  return SimulationDriver(std::move(buildSimulation(scene).value()), settings, nullptr);
}

// The triangle whose projection on z = 0 holds (0.3, -0.1), from the mesh's vertices (2D
// barycentric coordinates, all positive).
std::size_t triangleUnderThePost(const Simulator& sim) {
  const auto& triangles = sim.model().mesh().triangles;
  const VectorX& x = sim.state().x;
  const Eigen::Vector2d p(0.3, -0.1);
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    const Eigen::Vector2d a = x.segment<2>(3 * triangles[t][0]), b = x.segment<2>(3 * triangles[t][1]),
                          c = x.segment<2>(3 * triangles[t][2]);
    Eigen::Matrix2d m;
    m << b - a, c - a;
    const Eigen::Vector2d l = m.inverse() * (p - a);
    if (l.minCoeff() > 0.0 && l.sum() < 1.0) return t;
  }
  ADD_FAILURE() << "no triangle under the post";
  return triangles.size();
}

}  // namespace

// symplectic_euler and xpbd measure the depth exactly: 10 mm, in the triangle over the post, from
// the first step on; the diagnostics say the same in mm. A reset forgets it.
TEST(StatsBoxDepth, ExplicitSteppersReportTheExactDepthAndWhere) {
  for (const std::string integrator : {"symplectic_euler", "xpbd"}) {
    SCOPED_TRACE(integrator);
    SimulationDriver driver = postDriver(integrator);
    const std::string where = "triangle " + std::to_string(triangleUnderThePost(driver.simulator())) + " in box 'post'";
    for (int k = 0; k < 3; ++k) {
      const StepReport report = driver.step();
      ASSERT_TRUE(report.ok) << report.error;
      const StepStats msg = statsMessage(driver, report, 0.0, 0.0);
      EXPECT_NEAR(msg.box_depth, 0.01, 1e-12);
      EXPECT_EQ(msg.box_depth_where, where);
      EXPECT_NEAR(msg.max_box_depth, 0.01, 1e-12);
      EXPECT_EQ(msg.max_box_depth_where, where);
      EXPECT_EQ(msg.max_box_depth_step, 1u) << "the first step that reached it";
    }
    const auto entries = boxDepthDiagnostics(driver.deepestIntoBox());
    ASSERT_EQ(entries.size(), 3u);
    EXPECT_EQ(entries[0].second, "10");
    EXPECT_EQ(entries[1].second, where);
    EXPECT_EQ(entries[2].second, "1");
    const std::string warning = boxDepthWarning(driver.deepestIntoBox());
    EXPECT_NE(warning.find("reached 10 mm into " + where + " between its vertices (step 1)"), std::string::npos)
        << warning;
    driver.reset();
    EXPECT_EQ(driver.deepestIntoBox().depth, 0.0);
    EXPECT_EQ(driver.deepestIntoBox().step, 0u);
    EXPECT_EQ(boxDepthWarning(driver.deepestIntoBox()), "");
  }
}

// The implicit steppers keep the whole surface out of boxes (corner and edge barriers,
// docs/contact.md), so they refuse this start: building the scene fails, naming the post and the
// triangle through which it stands (found from the mesh), instead of reporting a depth.
TEST(StatsBoxDepth, ImplicitSteppersRefuseTheSurfaceThroughABoxAtTheStart) {
  SimulationDriver reference = postDriver("symplectic_euler");
  const std::string triangle = "triangle " + std::to_string(triangleUnderThePost(reference.simulator())) + " ";
  for (const std::string integrator : {"backward_euler", "bdf2"}) {
    SCOPED_TRACE(integrator);
    Scene scene = postScene();
    scene.integrator = integrator;
    const Expected<Simulation> built = buildSimulation(scene);
    ASSERT_FALSE(built.ok());
    EXPECT_NE(built.error().find("obstacles[0] ('post'): " + triangle), std::string::npos) << built.error();
    EXPECT_NE(built.error().find("reaches into box 'post'"), std::string::npos) << built.error();
    EXPECT_NE(built.error().find("at the start"), std::string::npos) << built.error();
  }
}

// A sheet far above the post: nothing reached, nothing reported.
TEST(StatsBoxDepth, NothingWhenTheSurfaceStaysOut) {
  SimulationDriver driver = postDriver("symplectic_euler", 0.2);  // top at 0.3 m, 0.2 m below the sheet
  const StepReport report = driver.step();
  ASSERT_TRUE(report.ok) << report.error;
  const StepStats msg = statsMessage(driver, report, 0.0, 0.0);
  EXPECT_EQ(msg.box_depth, 0.0);
  EXPECT_EQ(msg.box_depth_where, "");
  EXPECT_EQ(msg.max_box_depth, 0.0);
  EXPECT_EQ(boxDepthWarning(driver.deepestIntoBox()), "");
}
