# ROS 1 tests (issue 26), run with Debian's python3: it has the rosbag module the tests use to craft
# bags (a pyenv or venv python3 first on PATH does not).
find_program(ROS_PYTHON3 python3 PATHS /usr/bin NO_DEFAULT_PATH)
if(NOT ROS_PYTHON3)
  message(WARNING "ROS tests need /usr/bin/python3 with python3-rosbag; not registered")
  return()
endif()

# rosbag: dataset vs the dataset read directly (KITTI stereo, synthetic RGB-D room), and damaged bags.
add_test(NAME ros_rosbag_dataset
         COMMAND ${ROS_PYTHON3} ${CMAKE_CURRENT_LIST_DIR}/rosbag_dataset_test.py
                 --cli $<TARGET_FILE:diskchungs> --to-bag $<TARGET_FILE:chungs_dataset_to_bag>
                 --data ${PROJECT_SOURCE_DIR}/../shared/data)
set_tests_properties(ros_rosbag_dataset PROPERTIES TIMEOUT 600 LABELS ros SKIP_RETURN_CODE 77)

# The node end to end: its own roscore on 127.0.0.1, the launch files, `rosbag play` of a KITTI and an
# RGB-D room bag with poses from tf; renders, clouds, the export service, a clean SIGINT, resume, and
# the map's quality against `diskchungs run` on the same frames.
add_test(NAME ros_node
         COMMAND ${ROS_PYTHON3} ${CMAKE_CURRENT_LIST_DIR}/node_test.py
                 --cli $<TARGET_FILE:diskchungs> --to-bag $<TARGET_FILE:chungs_dataset_to_bag>
                 --package-dir $<TARGET_FILE_DIR:diskchungs_node> --data ${PROJECT_SOURCE_DIR}/../shared/data)
set_tests_properties(ros_node PROPERTIES TIMEOUT 1800 LABELS ros SKIP_RETURN_CODE 77)
