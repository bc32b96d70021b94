#!/usr/bin/env bash
# Installs the Debian 12 packages DiskChunGS needs, then configures and builds it in Release.
# Safe to run again: apt-get skips what is installed and the build is incremental.
# Options through the environment: BUILD_DIR (default build), CHUNGS_CUDA (AUTO|ON|OFF),
# CHUNGS_SKIP_APT=1 to skip the package step (no root needed then), CHUNGS_SKIP_FUZZ=1 to skip the
# fuzz targets' build (build-fuzz, with clang; ctest's fuzz_short runs them). The build runs `npm ci` in
# $BUILD_DIR/web for the viewer page when node and npm are found (CHUNGS_WEB=AUTO|ON|OFF), and in
# $BUILD_DIR/onnxruntime for ONNX Runtime's library, which --mono-depth-model opens at run time
# (CHUNGS_ONNXRUNTIME_NPM=AUTO|ON|OFF; python3-onnx writes the tiny models its tests load).
# --ros (or CI=true) also installs Debian's ROS 1 packages (about 140 packages, 220 MB) for the rosbag:
# dataset, the node (ros/) and their tests (with gdb, which the node test uses to show where a stalled
# node waits); the build finds them (CHUNGS_ROS=AUTO|ON|OFF).
set -euo pipefail
WITH_ROS=0
for arg in "$@"; do
  case "$arg" in
    --ros) WITH_ROS=1 ;;
    *) echo "setup.sh: unknown argument '$arg' (known: --ros)" >&2; exit 2 ;;
  esac
done
[ "${CI:-}" = true ] && WITH_ROS=1
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build}

if [ "${CHUNGS_SKIP_APT:-0}" != 1 ]; then
  SUDO=""
  [ "$(id -u)" = 0 ] || SUDO="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends build-essential cmake ninja-build ccache pkg-config libeigen3-dev libpng-dev libjpeg-dev zlib1g-dev libzstd-dev libyaml-cpp-dev libgtest-dev libbenchmark-dev libcli11-dev nlohmann-json3-dev libopencv-core-dev libopencv-imgproc-dev libopencv-calib3d-dev libopencv-features2d-dev libceres-dev python3 clang libomp-dev libcpp-httplib-dev chromium fonts-liberation python3-onnx >/dev/null
  # The viewer page (web/) is built with the machine's Node.js and npm where it has them (npm ci from the
  # committed lockfile during the build); Debian's only where none is installed.
  command -v npm >/dev/null || $SUDO apt-get install -y -qq --no-install-recommends nodejs npm >/dev/null
  if [ "$WITH_ROS" = 1 ]; then
    # ROS 1 (ros_comm 1.15): C++ headers for the bag reader and the node; roscore, roslaunch, rosbag
    # play and the python messages the ROS tests use (they run with Debian's /usr/bin/python3).
    $SUDO apt-get install -y -qq --no-install-recommends librosbag-storage-dev libroscpp-dev libsensor-msgs-dev libgeometry-msgs-dev libnav-msgs-dev libtf2-ros-dev libtf2-msgs-dev libmessage-filters-dev libstd-srvs-dev python3-rosbag python3-roslaunch rosout python3-sensor-msgs python3-geometry-msgs python3-nav-msgs python3-tf2-msgs python3-std-srvs gdb >/dev/null
  fi
fi

jobs=$(nproc)
ros=${CHUNGS_ROS:-AUTO}
[ "$WITH_ROS" = 1 ] && ros=${CHUNGS_ROS:-ON}
cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCHUNGS_CUDA="${CHUNGS_CUDA:-AUTO}" \
  -DCHUNGS_WEB="${CHUNGS_WEB:-AUTO}" -DCHUNGS_ROS="$ros"
cmake --build "$BUILD_DIR" -j "$jobs"
if [ "${CHUNGS_SKIP_FUZZ:-0}" != 1 ] && command -v clang++ >/dev/null; then
  # Only the modules the targets link are compiled (fuzz/CMakeLists.txt).
  cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER=clang++ -DCHUNGS_FUZZ=ON
  cmake --build build-fuzz -j "$jobs"
fi
echo "built: $BUILD_DIR/apps/diskchungs/diskchungs"
