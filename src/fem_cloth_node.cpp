// fem_cloth_node: see include/fem_cloth/ros/cloth_node.h for its parameters and docs/node.md
// for its topics and services.
#include <ros/ros.h>

#include "fem_cloth/ros/cloth_node.h"
#include "fem_cloth/core/threads.h"

int main(int argc, char** argv) {
  fem_cloth::preferPassiveThreadWaiting(argv);
  ros::init(argc, argv, "fem_cloth_node");
  fem_cloth::ClothNode node{ros::NodeHandle(), ros::NodeHandle("~")};
  std::string error;
  if (!node.start(&error)) {
    ROS_FATAL_STREAM("fem_cloth_node: " << error);
    return 1;
  }
  node.run();
  return 0;
}
