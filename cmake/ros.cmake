# ROS 1 (issue 26): CHUNGS_ROS=AUTO|ON|OFF. ROS 1 message headers do not compile as C++20, so the
# code that includes them (ros/) is built as C++17 and reaches the library only through plain structs
# (src/chungs/datasets/rosbag_io.hpp). Debian 12 ships ROS 1 without catkin CMake configs for most
# packages: pkg-config and plain find_path/find_library instead.
set(CHUNGS_ROS AUTO CACHE STRING "Build the rosbag dataset and the ROS 1 node: AUTO (when found), ON or OFF")
set_property(CACHE CHUNGS_ROS PROPERTY STRINGS AUTO ON OFF)
set(CHUNGS_WITH_ROS OFF)
if(NOT CHUNGS_ROS STREQUAL "OFF")
  find_package(PkgConfig QUIET)
  if(PkgConfig_FOUND)
    pkg_check_modules(ROS1_BAG QUIET IMPORTED_TARGET rostime roscpp_serialization tf2 roslz4)
    pkg_check_modules(ROS1_NODE QUIET IMPORTED_TARGET roscpp tf2_ros message_filters)
  endif()
  find_library(ROSBAG_STORAGE_LIBRARY rosbag_storage)
  find_library(ROS_CONSOLE_BRIDGE_LIBRARY console_bridge)
  find_path(ROSBAG_INCLUDE_DIR rosbag/bag.h)
  find_path(ROS_MSGS_INCLUDE_DIR sensor_msgs/Image.h)
  find_path(ROS_NAV_MSGS_INCLUDE_DIR nav_msgs/Path.h)
  find_path(ROS_STD_SRVS_INCLUDE_DIR std_srvs/Trigger.h)
  # Debian's rosbag headers reach pluginlib and class_loader of ROS 2, installed one folder down.
  find_path(ROS_PLUGINLIB_INCLUDE_DIR pluginlib/class_loader.hpp PATH_SUFFIXES pluginlib)
  find_path(ROS_CLASS_LOADER_INCLUDE_DIR class_loader/multi_library_class_loader.hpp PATH_SUFFIXES class_loader)
  find_path(ROS_RCPPUTILS_INCLUDE_DIR rcpputils/shared_library.hpp PATH_SUFFIXES rcpputils)
  find_path(ROS_RCUTILS_INCLUDE_DIR rcutils/types.h PATH_SUFFIXES rcutils)
  find_path(ROS_AMENT_INDEX_INCLUDE_DIR ament_index_cpp/get_resource.hpp PATH_SUFFIXES ament_index_cpp)
  set(ros_missing)
  foreach(v ROS1_BAG_FOUND ROS1_NODE_FOUND ROSBAG_STORAGE_LIBRARY ROS_CONSOLE_BRIDGE_LIBRARY ROSBAG_INCLUDE_DIR
            ROS_MSGS_INCLUDE_DIR ROS_NAV_MSGS_INCLUDE_DIR ROS_STD_SRVS_INCLUDE_DIR ROS_PLUGINLIB_INCLUDE_DIR
            ROS_CLASS_LOADER_INCLUDE_DIR ROS_RCPPUTILS_INCLUDE_DIR ROS_RCUTILS_INCLUDE_DIR ROS_AMENT_INDEX_INCLUDE_DIR)
    if(NOT ${v})
      list(APPEND ros_missing ${v})
    endif()
  endforeach()
  if(NOT ros_missing)
    set(CHUNGS_WITH_ROS ON)
  elseif(CHUNGS_ROS STREQUAL "ON")
    message(FATAL_ERROR "CHUNGS_ROS=ON but ROS 1 is incomplete (${ros_missing}); run scripts/setup.sh --ros")
  endif()
endif()
message(STATUS "ROS 1 (rosbag dataset, node): ${CHUNGS_WITH_ROS}")

if(CHUNGS_WITH_ROS)
  add_subdirectory(ros)
  # Only the adapter needs to know: the rest of the datasets module compiles the same either way.
  set_source_files_properties(${PROJECT_SOURCE_DIR}/src/chungs/datasets/rosbag_reader.cpp PROPERTIES
                              COMPILE_DEFINITIONS CHUNGS_WITH_ROS=1)
  target_link_libraries(chungs_datasets PUBLIC chungs_rosbag_io)
endif()

if(CHUNGS_WITH_ROS AND CHUNGS_TESTS)
  include(${PROJECT_SOURCE_DIR}/tests/ros/ros_tests.cmake)
endif()
