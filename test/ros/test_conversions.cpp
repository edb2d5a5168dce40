// The free conversions (conversions.h) round-trip what their messages hold, and the frame
// resolver asks tf once per frame and time (frame_resolver.h). No master needed.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "fem_cloth/core/live_change.h"
#include "fem_cloth/io/live_change.h"
#include "fem_cloth/io/scene_yaml.h"
#include "fem_cloth/ros/conversions.h"
#include "fem_cloth/ros/frame_resolver.h"

using namespace fem_cloth;

namespace {

Mesh twoTriangles(int dim) {
  Mesh m;
  m.dim = dim;
  m.restPositions = dim == 3 ? VectorX((VectorX(12) << 0, 0, 0, 1, 0, 0.5, 1, 1, 0, 0, 1, -0.25).finished())
                             : VectorX((VectorX(8) << 0, 0, 1, 0, 1, 1, 0, 1).finished());
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  return m;
}

geometry_msgs::TransformStamped gripperAt(double t, double x) {
  geometry_msgs::TransformStamped tf;
  tf.header.stamp = ros::Time(100.0 + t);
  tf.header.frame_id = "world";
  tf.child_frame_id = "gripper";
  tf.transform.translation.x = x;
  tf.transform.rotation.w = 1.0;
  return tf;
}

}  // namespace

TEST(Conversions, MeshRoundTripsIn3DAnd2D) {
  for (int dim : {3, 2}) {
    const Mesh mesh = twoTriangles(dim);
    const shape_msgs::Mesh msg = toMsg(mesh);
    ASSERT_EQ(msg.vertices.size(), 4u);
    EXPECT_EQ(msg.vertices[1].z, dim == 3 ? 0.5 : 0.0);
    EXPECT_EQ(msg.triangles[1].vertex_indices[2], 3u);
    const Expected<Mesh> back = fromMsg(msg, dim);
    ASSERT_TRUE(back.ok()) << back.error();
    EXPECT_EQ(back->restPositions, mesh.restPositions);
    EXPECT_EQ(back->triangles, mesh.triangles);
  }
  shape_msgs::Mesh bad = toMsg(twoTriangles(3));
  bad.triangles[1].vertex_indices[0] = 9;
  const Expected<Mesh> refused = fromMsg(bad, 3);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().find("triangle 1 names vertex 9"), std::string::npos) << refused.error();
}

TEST(Conversions, StateRoundTripsWithItsHash) {
  State s;
  s.x = (VectorX(6) << 0.1, -0.2, 0.3, 1.5, 2.5, -3.5).finished();
  s.v = (VectorX(6) << 1, 2, 3, 4, 5, 6).finished();
  s.step = 42;
  const ClothState msg = toMsg(header(ros::Time(3.0), "world"), s, 3, true);
  EXPECT_EQ(msg.header.frame_id, "world");
  EXPECT_EQ(msg.step, 42u);
  EXPECT_EQ(msg.positions[1].y, 2.5);
  EXPECT_EQ(msg.velocities[0].z, 3.0);
  const State back = fromMsg(msg, 3);
  EXPECT_EQ(back.x, s.x);
  EXPECT_EQ(back.v, s.v);
  EXPECT_EQ(back.step, 42u);
  EXPECT_EQ(msg.state_hash, stateHash(back.x, back.v));
  // Without velocities: zeros come back, and the hash is still that of the state sent.
  const ClothState noVelocities = toMsg(header(ros::Time(3.0), "world"), s, 3, false);
  EXPECT_TRUE(noVelocities.velocities.empty());
  EXPECT_EQ(fromMsg(noVelocities, 3).v, VectorX::Zero(6));
  // 2D: z is 0 in the message and dropped on the way back.
  State planar;
  planar.x = (VectorX(4) << 1, 2, 3, 4).finished();
  planar.v = VectorX::Zero(4);
  const ClothState flat = toMsg(header(ros::Time(1.0), "w"), planar, 2, false);
  EXPECT_EQ(flat.positions[1].x, 3.0);
  EXPECT_EQ(flat.positions[1].z, 0.0);
  EXPECT_EQ(fromMsg(flat, 2).x, planar.x);
}

// ClothEnergy carries every term of the balance: its balance_error is recomputable from the
// message alone, by the formula its definition gives (msg/ClothEnergy.msg), in a run where each
// work term is at work: a pulled pin, a force, a table rising under the cloth, air, and a live
// stiffening. Each term is far larger than the tolerance, so leaving any one out fails.
TEST(Conversions, EnergyBalanceIsRecomputableFromTheMessage) {
  const YAML::Node doc = YAML::Load(R"(
name: every_work
mesh: {type: grid, rows: 5, cols: 5, width: 0.2, height: 0.2, origin: [0, 0, 0.001]}
material: {model: stvk, youngs_modulus: 2.0e5, poisson_ratio: 0.3, thickness: 5.0e-4, density: 400}
damping: {mass: 0.5}
air: {density: 1.2, wind: [0, 0, -2.0]}
integrator: {name: backward_euler, dt: 0.01}
pins:
  - grid_vertices: [[0, 0]]
    velocity: [-0.05, 0, 0.1]
forces:
  - grid_vertices: [[-1, -1]]
    force: [0.02, 0, 0]
obstacles:
  - {name: table, type: box, center: [0.1, 0.1, -0.25], size: [1.0, 1.0, 0.5], velocity: [0, 0, 0.1]}
contact: {distance: 2.0e-3}
)");
  Expected<Scene> scene = parseScene(doc);
  ASSERT_TRUE(scene.ok()) << scene.error();
  Expected<Simulation> sim = buildSimulation(*scene);
  ASSERT_TRUE(sim.ok()) << sim.error();
  auto steps = [](Simulation& s, int n) {
    for (int k = 0; k < n; ++k) {
      ASSERT_TRUE(s.script.applyDue(*s.simulator).ok());
      const StepReport r = s.simulator->step();
      ASSERT_TRUE(r.ok) << r.error;
    }
  };
  steps(*sim, 20);
  Expected<LiveChange> change = applyLiveChange(doc, {"material.youngs_modulus=4.0e5"});
  ASSERT_TRUE(change.ok()) << change.error();
  Expected<Simulation> next = changeLive(*sim, change->scene);
  ASSERT_TRUE(next.ok()) << next.error();
  steps(*next, 20);
  const ClothEnergy m = toMsg(header(ros::Time(1.0), "world"), 40, next->simulator->energies());
  for (double work : {m.external_work, m.pin_work, m.contact_work, m.air_work, m.live_work}) {
    EXPECT_GT(std::abs(work), 1e-6);
  }
  const double recomputed = m.total - m.external_work - m.pin_work - m.contact_work - m.air_work -
                            m.live_work + m.dissipated - m.initial_total;
  EXPECT_NEAR(recomputed, m.balance_error, 1e-12);
  // total holds the contact barriers' energy too (the cloth rests on the table, within d̂).
  const double barriers = next->simulator->energies().contactEnergy;
  EXPECT_NE(barriers, 0.0);
  EXPECT_EQ(m.total, m.kinetic + m.strain + m.bending + m.gravity + barriers);
  std::cout << "works: external " << m.external_work << ", pins " << m.pin_work << ", contact "
            << m.contact_work << ", air " << m.air_work << ", live " << m.live_work << " J; dissipated "
            << m.dissipated << " J; balance error " << m.balance_error << " J, recomputed " << recomputed
            << " J\n";
}

TEST(Conversions, EnergyAndWrenchRoundTrip) {
  EnergyReport e;
  e.kinetic = 1;
  e.strain = 2;
  e.bending = 3;
  e.gravity = -4;
  e.externalWork = 5;
  e.pinWork = 6;
  e.contactWork = 8;
  e.airWork = -9;
  e.liveWork = 10;
  e.dissipated = 7;
  e.total = 2;
  e.initialTotal = 11;
  e.balanceError = 1e-9;
  const EnergyReport back = fromMsg(toMsg(header(ros::Time(1.0), "world"), 7, e));
  EXPECT_EQ(back.kinetic, 1);
  EXPECT_EQ(back.strain, 2);
  EXPECT_EQ(back.bending, 3);
  EXPECT_EQ(back.gravity, -4);
  EXPECT_EQ(back.externalWork, 5);
  EXPECT_EQ(back.pinWork, 6);
  EXPECT_EQ(back.contactWork, 8);
  EXPECT_EQ(back.airWork, -9);
  EXPECT_EQ(back.liveWork, 10);
  EXPECT_EQ(back.dissipated, 7);
  EXPECT_EQ(back.total, 2);
  EXPECT_EQ(back.initialTotal, 11);
  EXPECT_EQ(back.balanceError, 1e-9);
  const GraspWrench w{"gripper", Eigen::Vector3d(1, -2, 3), Eigen::Vector3d(-0.5, 0.25, 4)};
  const geometry_msgs::WrenchStamped msg = toMsg(header(ros::Time(2.0), "world"), w);
  EXPECT_EQ(msg.header.frame_id, "gripper");
  EXPECT_EQ(msg.wrench.torque.z, 4.0);
  const GraspWrench wb = fromMsg(msg);
  EXPECT_EQ(wb.frame, "gripper");
  EXPECT_EQ(wb.force, w.force);
  EXPECT_EQ(wb.torque, w.torque);
}

TEST(Conversions, PinForcesListThePinnedVerticesReactions) {
  const VectorX reactions = (VectorX(9) << 0, 0, 0, 1, 2, 3, 0, 0, -9.5).finished();
  const PinForces msg = toMsg(header(ros::Time(1.0), "world"), {1, 2}, reactions, 3);
  ASSERT_EQ(msg.vertices, (std::vector<std::uint32_t>{1, 2}));
  EXPECT_EQ(msg.forces[0].y, 2.0);
  EXPECT_EQ(msg.forces[1].z, -9.5);
}

// The tf policy asks tf once per frame and time: the second question about the same frame at
// the same time is answered from what the first found, the same pose to the bit.
TEST(FrameResolver, OneLookupPerFrameAndTime) {
  tf2::BufferCore tf(ros::Duration(100.0));
  for (int k = 0; k <= 10; ++k) tf.setTransform(gripperAt(0.1 * k, 0.01 * k), "test");
  FrameResolver frames(&tf, "world", 1.0);
  const ros::Time at(100.25);
  const FramePose first = frames.pose("gripper", at);
  ASSERT_TRUE(first.pose) << first.why;
  EXPECT_TRUE(first.inexact.empty());
  EXPECT_NEAR(first.pose->translation().x(), 0.025, 1e-12);  // interpolated between 0.02 and 0.03
  const std::uint64_t lookups = frames.lookups();
  EXPECT_GE(lookups, 1u);
  const FramePose again = frames.pose("/gripper", at);
  EXPECT_EQ(frames.lookups(), lookups) << "asked tf again for the same frame and time";
  EXPECT_TRUE(again.pose->isApprox(*first.pose, 0.0));
  EXPECT_TRUE(frames.knownOrNeverWillBe("gripper", at));
  // Another time is another lookup; forgetting times before it drops the first.
  ASSERT_TRUE(frames.pose("gripper", ros::Time(100.5)).pose);
  EXPECT_GT(frames.lookups(), lookups);
  frames.forgetBefore(ros::Time(100.5));
  const std::uint64_t before = frames.lookups();
  ASSERT_TRUE(frames.pose("gripper", at).pose);
  EXPECT_GT(frames.lookups(), before);
}

TEST(FrameResolver, NamesWhyAFrameDoesNotResolve) {
  tf2::BufferCore tf(ros::Duration(100.0));
  tf.setTransform(gripperAt(0.0, 0.0), "test");
  FrameResolver frames(&tf, "world", 1.0);
  EXPECT_EQ(frames.pose("nothing", ros::Time(100.0)).why, "unknown frame 'nothing': tf has no such frame");
  FrameResolver elsewhere(&tf, "map", 1.0);
  EXPECT_EQ(elsewhere.pose("gripper", ros::Time(100.0)).why,
            "frame 'gripper' cannot be related to the simulation frame 'map': tf has no transform to it");
  // 0.5 s after the newest transform: it stands in, and says so; 2 s after: stale.
  const FramePose late = frames.pose("gripper", ros::Time(100.5));
  ASSERT_TRUE(late.pose);
  EXPECT_NE(late.inexact.find("its newest transform, 0.5 s older, stands in"), std::string::npos) << late.inexact;
  const FramePose stale = frames.pose("gripper", ros::Time(102.0));
  EXPECT_FALSE(stale.pose);
  EXPECT_NE(stale.why.find("frame 'gripper' is stale: its newest transform is 2 s older"), std::string::npos) << stale.why;
  FrameResolver noTf(nullptr, "world", 1.0);
  EXPECT_TRUE(noTf.pose("world", ros::Time(1.0)).pose);
  EXPECT_EQ(noTf.pose("gripper", ros::Time(1.0)).why, "frame 'gripper' needs tf, which is not available here");
}
