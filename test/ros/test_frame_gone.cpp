// A transform tf no longer holds is named as gone, never replaced by the oldest one tf kept
// (issue 32, part 1). tf2 keeps, per frame, the transforms from its newest back to its cache
// length: with a 2 s cache and 'finger' published every 0.1 s from 0 to 10 s (x = t), tf keeps
// 8..10 s. Before, a time just before 8 s (within tf_timeout of the oldest kept) was served by
// the transform at 8 s: a finger that moved meanwhile jumped. No ROS master needed.
#include <gtest/gtest.h>
#include <tf2/buffer_core.h>

#include "../rostest/node_test_support.h"  // frameAt
#include "fem_cloth/ros/frame_resolver.h"
#include "fem_cloth/ros/tf_intake.h"

#include <limits>

using namespace fem_cloth;

namespace {

const ros::Time kEpoch(1000.0);

// 'finger' at x = t (1 m/s), at ROS time kEpoch + t.
geometry_msgs::TransformStamped fingerAt(double t) {
  return fem_cloth_test::frameAt("world", "finger", kEpoch + ros::Duration(t), t, 0.0, 0.0);
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

}  // namespace

TEST(FrameGone, ATimeTfNoLongerHoldsIsNamedNotReplaced) {
  tf2::BufferCore tf(ros::Duration(2.0));
  for (int k = 0; k <= 100; ++k) tf.setTransform(fingerAt(0.1 * k), "test");
  const FrameResolver frames(&tf, "world", 1.0);  // tf_timeout 1 s

  // Within what tf keeps: exact, x = t.
  const FramePose kept = frames.pose("finger", kEpoch + ros::Duration(8.55));
  ASSERT_TRUE(kept.pose) << kept.why;
  EXPECT_NEAR(kept.pose->translation().x(), 8.55, 1e-9);
  EXPECT_TRUE(kept.inexact.empty()) << kept.inexact;

  // 7.5 s: 2.5 s before the newest (10 s), beyond the 2 s tf keeps. The oldest kept transform
  // (8 s, 0.5 s away: within tf_timeout) must not stand in.
  const FramePose gone = frames.pose("finger", kEpoch + ros::Duration(7.5));
  EXPECT_FALSE(gone.pose) << "served x = " << gone.pose->translation().x() << " for t = 7.5 s: " << gone.inexact;
  EXPECT_TRUE(contains(gone.why, "tf no longer holds frame 'finger' at 1007.500000000 s")) << gone.why;
  EXPECT_TRUE(contains(gone.why, "2.5 s before its newest transform")) << gone.why;
  EXPECT_TRUE(contains(gone.why, "tf keeps 2 s")) << gone.why;
}

TEST(FrameGone, AFrameThatHasJustAppearedStillServesItsFirstTransform) {
  // 'finger' first published at 9.8 s; at 9.5 s (0.5 s before its newest, within the 2 s cache)
  // its first transform stands in, with a warning, as before (the frame did not exist earlier).
  tf2::BufferCore tf(ros::Duration(2.0));
  tf.setTransform(fingerAt(9.8), "test");
  tf.setTransform(fingerAt(10.0), "test");
  const FrameResolver frames(&tf, "world", 1.0);
  const FramePose first = frames.pose("finger", kEpoch + ros::Duration(9.5));
  ASSERT_TRUE(first.pose) << first.why;
  EXPECT_NEAR(first.pose->translation().x(), 9.8, 1e-5);  // the bisection stops within 1e-6 s
  EXPECT_TRUE(contains(first.inexact, "first transform")) << first.inexact;
}

// tf2 refuses a transform whose stamp it holds for the frame already (TF_REPEATED_DATA), and one
// further before the frame's newest than it keeps (TF_OLD_DATA), saying so only on its console.
// The node's tf intake names them: a publisher that repeats stamps (robot_state_publisher fed the
// same joint state twice) is told apart from a node too far behind. Same cache and finger as above.
TEST(FrameGone, ARefusedTransformSaysWhetherItsStampIsRepeatedOrTooOld) {
  tf2::BufferCore tf(ros::Duration(2.0));
  for (int k = 0; k <= 100; ++k) ASSERT_TRUE(insertTransform(tf, fingerAt(0.1 * k), "test", false).ok());
  // 9.5 s again: tf holds it (within the cache, 8..10 s).
  const Status repeated = insertTransform(tf, fingerAt(9.5), "test", false);
  ASSERT_FALSE(repeated.ok());
  EXPECT_TRUE(contains(repeated.error(), "transform 'world' -> 'finger': refused by tf2: a repeated timestamp, "
                                         "1009.500000000 s")) << repeated.error();
  EXPECT_TRUE(contains(repeated.error(), "TF_REPEATED_DATA")) << repeated.error();
  // 7.5 s: 2.5 s before the newest (10 s), more than the 2 s tf keeps.
  const Status old = insertTransform(tf, fingerAt(7.5), "test", false);
  ASSERT_FALSE(old.ok());
  EXPECT_TRUE(contains(old.error(), "its stamp 1007.500000000 s is more than the 2 s tf keeps")) << old.error();
  EXPECT_TRUE(contains(old.error(), "TF_OLD_DATA")) << old.error();
  EXPECT_FALSE(contains(old.error(), "repeated")) << old.error();
  // Not a timestamp at all: a NaN is refused as such, not taken for a repeat.
  geometry_msgs::TransformStamped nan = fingerAt(9.5);
  nan.transform.translation.x = std::numeric_limits<double>::quiet_NaN();
  const Status bad = insertTransform(tf, nan, "test", false);
  ASSERT_FALSE(bad.ok());
  EXPECT_TRUE(contains(bad.error(), "not finite")) << bad.error();
}
