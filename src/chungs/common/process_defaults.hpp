// Settings of the whole process that a long mapping run needs from its first line: the CLI's main()
// and the ROS node's call set_process_defaults() before any thread starts (why: process_defaults.cpp).
#pragma once
#include <string>

namespace chungs {

// Caps glibc's malloc arenas at one unless MALLOC_ARENA_MAX or GLIBC_TUNABLES say otherwise, and
// keeps OpenCV off OpenCL unless OPENCV_OPENCL_DEVICE says otherwise. Call first, before any thread.
void set_process_defaults();
// e.g. "glibc malloc, 1 arena", for `diskchungs info` and the node's start line.
std::string allocator_description();

}  // namespace chungs
