// The pin set (core/pin_set.h), without ROS: pins that follow frames are written into the
// simulator once per step, at the frame's pose for the end of the step; a frame that is lost or
// jumps leaves its pins where they are; grasp wrenches are the summed reactions in the grasp's
// frame, torque about its origin.
#include <gtest/gtest.h>

#include "fem_cloth/core/pin_set.h"
#include "test_support.h"

using namespace fem_cloth;
using namespace fem_cloth::test;

namespace {

Simulation cloth() { return mustBuild(gridScene(3, 3, 1.0, "backward_euler", 1000.0)); }

Eigen::Isometry3d translation(double x, double y, double z) {
  return Eigen::Isometry3d(Eigen::Translation3d(x, y, z));
}

}  // namespace

TEST(PinSet, FollowingPinIsWrittenOnceAtTheFramesPoseForTheEndOfTheStep) {
  Simulation sim = cloth();
  Simulator& s = *sim.simulator;
  PinSet pins(1.0);
  const Index v = 4;  // the middle vertex
  const Eigen::Vector3d at = vertexPosition(s, v);
  // The gripper is 0.1 m above the vertex now: pinned in place, its local target is -0.1 z.
  ASSERT_TRUE(pins.pin(s, {v}, {}, "gripper", translation(at.x(), at.y(), at.z() + 0.1)).ok());
  EXPECT_FALSE(s.isPinned(v)) << "a following pin waits for the pose at the end of the step";
  ASSERT_NE(pins.frameOf(v), nullptr);
  EXPECT_EQ(*pins.frameOf(v), "gripper");
  int calls = 0;
  const std::vector<std::string> problems = pins.follow(s, [&](const std::string& frame) {
    ++calls;
    EXPECT_EQ(frame, "gripper");
    return FramePose(translation(at.x() + 0.02, at.y(), at.z() + 0.1));  // moved 2 cm in x
  });
  EXPECT_TRUE(problems.empty());
  EXPECT_EQ(calls, 1);
  ASSERT_TRUE(s.isPinned(v));
  const Eigen::Vector3d expected(at.x() + 0.02, at.y(), at.z());  // local (0, 0, -0.1) moved
  EXPECT_LT((s.pinTarget(v) - expected).norm(), 1e-15) << s.pinTarget(v).transpose();
}

TEST(PinSet, FixedPinIsWrittenAtOnceAndJumpsAreRefusedWhole) {
  Simulation sim = cloth();
  Simulator& s = *sim.simulator;
  PinSet pins(0.05);
  const Eigen::Vector3d a = vertexPosition(s, 0), b = vertexPosition(s, 1);
  // Vertex 1's target is 0.06 m away: refused, and vertex 0 is not pinned either.
  const Status far = pins.pin(s, {0, 1}, {a, b + Eigen::Vector3d(0.06, 0, 0)}, "", Eigen::Isometry3d::Identity());
  ASSERT_FALSE(far.ok());
  EXPECT_NE(far.error().find("vertex 1"), std::string::npos) << far.error();
  EXPECT_NE(far.error().find("max_pin_jump = 0.05"), std::string::npos) << far.error();
  EXPECT_FALSE(s.isPinned(0));
  ASSERT_TRUE(pins.pin(s, {0}, {a + Eigen::Vector3d(0, 0, 0.01)}, "", Eigen::Isometry3d::Identity()).ok());
  EXPECT_TRUE(s.isPinned(0));
  EXPECT_EQ(s.pinTarget(0), a + Eigen::Vector3d(0, 0, 0.01));
  EXPECT_EQ(pins.frameOf(0), nullptr);
}

TEST(PinSet, LostFrameLeavesItsPinsWhereTheyWereApplied) {
  Simulation sim = cloth();
  Simulator& s = *sim.simulator;
  PinSet pins(1.0);
  const Eigen::Vector3d at = vertexPosition(s, 2);
  ASSERT_TRUE(pins.pin(s, {2}, {Eigen::Vector3d(0, 0, 0.01)}, "gripper", translation(at.x(), at.y(), at.z())).ok());
  const std::vector<std::string> problems =
      pins.follow(s, [](const std::string&) { return FramePose::unknown("frame 'gripper' is stale"); });
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_NE(problems[0].find("vertex 2 stop following frame 'gripper'"), std::string::npos) << problems[0];
  EXPECT_NE(problems[0].find("stale"), std::string::npos) << problems[0];
  ASSERT_TRUE(s.isPinned(2));
  EXPECT_EQ(s.pinTarget(2), at + Eigen::Vector3d(0, 0, 0.01));
  EXPECT_EQ(pins.frameOf(2), nullptr);
}

TEST(PinSet, GraspWrenchIsTheSummedReactionInTheGraspFrame) {
  Simulation sim = cloth();
  Simulator& s = *sim.simulator;
  PinSet pins(1.0);
  const Eigen::Vector3d p0 = vertexPosition(s, 0), p2 = vertexPosition(s, 2);
  // The grasp frame sits at vertex 0, turned 90 degrees about z.
  Eigen::Isometry3d grasp = translation(p0.x(), p0.y(), p0.z());
  grasp.rotate(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  ASSERT_TRUE(pins.pin(s, {0, 2}, {}, "gripper", grasp).ok());
  ASSERT_TRUE(pins.follow(s, [&](const std::string&) { return FramePose(grasp); }).empty());
  ASSERT_TRUE(pins.pin(s, {8}, {}, "", Eigen::Isometry3d::Identity()).ok());
  VectorX reactions = VectorX::Zero(s.model().numDofs());
  reactions.segment<3>(0) = Eigen::Vector3d(0, 0, -1);  // vertex 0: 1 N down
  reactions.segment<3>(6) = Eigen::Vector3d(0, 0, -2);  // vertex 2: 2 N down
  reactions.segment<3>(24) = Eigen::Vector3d(1, 0, 0);  // vertex 8 (fixed): 1 N along x
  const std::vector<GraspWrench> w =
      pins.wrenches(s, reactions, "world", [&](const std::string&) { return FramePose(grasp); });
  ASSERT_EQ(w.size(), 2u);
  EXPECT_EQ(w[0].frame, "gripper");  // sorted by name
  EXPECT_EQ(w[1].frame, "world");
  // Force: 3 N down, the same in the turned frame. Torque about vertex 0: only vertex 2 has an
  // arm, d = p2 - p0; tau = d x (0, 0, -2) = (-2 d_y, 2 d_x, 0) in the world, and in the frame
  // turned by +90 degrees about z, (x, y) -> (y, -x).
  const Eigen::Vector3d d = p2 - p0;
  const Eigen::Vector3d tauWorld(-2 * d.y(), 2 * d.x(), 0);
  const Eigen::Vector3d tauFrame(tauWorld.y(), -tauWorld.x(), 0);
  EXPECT_LT((w[0].force - Eigen::Vector3d(0, 0, -3)).norm(), 1e-12);
  EXPECT_LT((w[0].torque - tauFrame).norm(), 1e-12) << w[0].torque.transpose();
  // The fixed pin: about the simulation frame's origin, r x f with f along x.
  const Eigen::Vector3d p8 = vertexPosition(s, 8);
  EXPECT_LT((w[1].force - Eigen::Vector3d(1, 0, 0)).norm(), 1e-12);
  EXPECT_LT((w[1].torque - Eigen::Vector3d(0, p8.z(), -p8.y())).norm(), 1e-12) << w[1].torque.transpose();
}
