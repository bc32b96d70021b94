// The node's mapper settings come from ROS parameters with the names of the YAML settings
// (`diskchungs info --config`): ~mapper/resolution is mapper.resolution, and so on. This turns the
// parameter tree into the YAML text the library's loader reads, so defaults, ranges and the error
// for an unknown key are the library's own.
#pragma once
#include <ros/node_handle.h>

#include <string>

namespace chungs::ros_node {

// YAML for every section of the default configuration that is given under `nh` (private namespace).
std::string settings_yaml(const ros::NodeHandle& nh);

}  // namespace chungs::ros_node
