// fem_cloth_node: see include/fem_cloth/ros/cloth_node.h for its parameters and docs/node.md
// for its topics and services.
//
// Exit status: 0 after a normal shutdown; 2 when a parameter or the scene is invalid (one FATAL
// line names it); 3 when the simulation fails in a way the node cannot recover from, at start-up
// or while running (one FATAL line says what). Bad commands never end the node: they are rejected
// and it runs on.
#include <ros/ros.h>
#include <yaml-cpp/exceptions.h>

#include <exception>

#include "fem_cloth/core/threads.h"
#include "fem_cloth/ros/cloth_node.h"

int main(int argc, char** argv) {
  fem_cloth::preferPassiveThreadWaiting(argv);
  ros::init(argc, argv, "fem_cloth_node");
  std::unique_ptr<fem_cloth::ClothNode> node;
  try {
    node = std::make_unique<fem_cloth::ClothNode>(ros::NodeHandle(), ros::NodeHandle("~"));
    std::string error;
    if (!node->start(&error)) {
      ROS_FATAL_STREAM("fem_cloth_node: " << error);
      return 2;
    }
  } catch (const YAML::Exception& e) {  // a scene the reader did not expect
    ROS_FATAL_STREAM("fem_cloth_node: scene: " << e.what());
    return 2;
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM("fem_cloth_node: the simulation could not be set up: " << e.what());
    return 3;
  }
  try {
    node->run();
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM("fem_cloth_node: the simulation failed: " << e.what());
    return 3;
  }
  return 0;
}
