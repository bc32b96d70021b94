// rosbag:FILE.bag?key=value&... as a Dataset (see rosbag_reader.cpp for the keys). Built in every
// configuration; without ROS (CHUNGS_ROS=OFF or not found) opening one says so.
#pragma once
#include <memory>
#include <string>

#include "chungs/datasets/dataset.hpp"

namespace chungs::ds {

// `spec` is what follows "rosbag:". Throws Error naming the bag and the topic or key at fault.
std::unique_ptr<Dataset> open_rosbag(const std::string& spec);
bool rosbag_supported();

}  // namespace chungs::ds
