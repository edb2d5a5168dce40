// publish_world_frame (perception_world_frame.test): /fem_cloth_node runs on frame `world` with
// the default (auto) and nothing else in tf, so it broadcasts `world` itself, as the identity
// to a frame named after the node: RViz finds its fixed frame. /quiet_node runs on
// `quiet_world` with publish_world_frame false: that frame never appears in tf.
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include "node_test_support.h"

TEST(WorldFrame, AutoPublishesAFrameNobodyElseDoesAndFalseDoesNot) {
  tf2_ros::Buffer tf;
  tf2_ros::TransformListener listener(tf);
  ASSERT_TRUE(tf.canTransform("world", "fem_cloth_node", ros::Time(0), ros::Duration(20.0)))
      << "no transform from world to fem_cloth_node";
  const geometry_msgs::TransformStamped t = tf.lookupTransform("world", "fem_cloth_node", ros::Time(0));
  EXPECT_EQ(t.transform.translation.x, 0.0);
  EXPECT_EQ(t.transform.translation.y, 0.0);
  EXPECT_EQ(t.transform.translation.z, 0.0);
  EXPECT_EQ(t.transform.rotation.w, 1.0);
  // The auto node decided a second after its start; the quiet one would have by now as well.
  ros::WallDuration(1.5).sleep();
  EXPECT_FALSE(tf._frameExists("quiet_world"));
  EXPECT_FALSE(tf._frameExists("quiet_node"));
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_perception_world_frame");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
