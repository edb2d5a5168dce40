// The node's report of the cloth's surface reaching into a box between its vertices
// (test/data/contact/post_through_sheet.yaml, symplectic_euler: a box's top 10 mm through the
// middle of a triangle whose vertices are all outside it, by hand, from the first step on):
// ~stats carries the depth and where, /diagnostics the same in mm, as a warning.
#include <diagnostic_msgs/DiagnosticArray.h>

#include "fem_cloth/StepStats.h"
#include "node_test_support.h"

using namespace fem_cloth_test;

namespace {

std::string value(const diagnostic_msgs::DiagnosticStatus& s, const std::string& key) {
  for (const auto& kv : s.values) {
    if (kv.key == key) return kv.value;
  }
  return "(no key '" + key + "')";
}

}  // namespace

TEST(BoxDepth, StatsCarryTheDepthAndWhere) {
  Latest<fem_cloth::StepStats> stats(topic("stats"));
  auto st = stats.waitFor([](const fem_cloth::StepStats& m) { return m.step >= 1; });
  ASSERT_TRUE(st);
  EXPECT_NEAR(st->box_depth, 0.01, 1e-12);
  EXPECT_NE(st->box_depth_where.find("in box 'post'"), std::string::npos) << st->box_depth_where;
  EXPECT_NEAR(st->max_box_depth, 0.01, 1e-12);
  EXPECT_EQ(st->max_box_depth_where, st->box_depth_where);
  EXPECT_EQ(st->max_box_depth_step, 1u);
}

TEST(BoxDepth, DiagnosticsWarnWithTheDepthInMillimetres) {
  Latest<diagnostic_msgs::DiagnosticArray> diagnostics("/diagnostics");
  auto d = diagnostics.waitFor([](const diagnostic_msgs::DiagnosticArray& a) {
    return !a.status.empty() && value(a.status[0], "deepest into a box between the vertices (mm)") != "0";
  });
  ASSERT_TRUE(d);
  const diagnostic_msgs::DiagnosticStatus& s = d->status[0];
  EXPECT_EQ(value(s, "deepest into a box between the vertices (mm)"), "10");
  EXPECT_NE(value(s, "deepest into a box: where").find("in box 'post'"), std::string::npos);
  EXPECT_EQ(value(s, "deepest into a box: step"), "1");
  EXPECT_GE(s.level, diagnostic_msgs::DiagnosticStatus::WARN);
  EXPECT_NE(s.message.find("reached 10 mm into triangle "), std::string::npos) << s.message;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_box_depth");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
