# ONNX Runtime for --mono-depth-model (src/chungs/depth/learned_depth.hpp, issue 25). Nothing links
# it: learned_depth_runtime.cpp opens the library at run time, so the project builds and runs without
# it and a model given without it is refused saying what to install.
#
# Where it comes from: the npm package onnxruntime-node carries the CPU library for linux-x64
# (bin/napi-v6/linux/x64/libonnxruntime.so.1, glibc 2.28+) beside its Node.js binding; Debian 12 has no
# ONNX Runtime, and libtorch (Debian's, 1.13) would be a C++ link dependency of several hundred MB.
# `npm ci --ignore-scripts` from the lockfile in cmake/onnxruntime/ installs it into
# ${CMAKE_BINARY_DIR}/onnxruntime (the package's install script would fetch GPU providers from
# outside the registry), and that path is compiled into chungs_depth as the first place to look after
# the CHUNGS_ONNXRUNTIME environment variable (a library file).
# CHUNGS_ONNXRUNTIME_NPM: AUTO installs it when npm is found (a failed download only warns: the tests that
# need it then skip), ON requires it, OFF skips it.
set(CHUNGS_ONNXRUNTIME_NPM AUTO CACHE STRING "Install ONNX Runtime's library from npm for --mono-depth-model: AUTO, ON or OFF")
set_property(CACHE CHUNGS_ONNXRUNTIME_NPM PROPERTY STRINGS AUTO ON OFF)
set(ort_src ${PROJECT_SOURCE_DIR}/cmake/onnxruntime)
file(READ ${ort_src}/package.json ort_package)
string(JSON ort_version GET "${ort_package}" dependencies onnxruntime-node)
target_compile_definitions(chungs_depth PRIVATE CHUNGS_ONNXRUNTIME_NPM_VERSION="${ort_version}")
if(NOT CHUNGS_ONNXRUNTIME_NPM STREQUAL "OFF")
  find_program(NPM_EXECUTABLE npm)
  if(NPM_EXECUTABLE AND CMAKE_SYSTEM_NAME STREQUAL "Linux" AND CMAKE_SYSTEM_PROCESSOR MATCHES "x86_64|AMD64")
    set(ort_bin ${CMAKE_BINARY_DIR}/onnxruntime)
    set(ort_required OFF)
    if(CHUNGS_ONNXRUNTIME_NPM STREQUAL "ON")
      set(ort_required ON)
    endif()
    add_custom_command(
      OUTPUT ${ort_bin}/npm-ci.stamp
      COMMAND ${CMAKE_COMMAND} -DNPM=${NPM_EXECUTABLE} -DSRC=${ort_src} -DDIR=${ort_bin} -DREQUIRED=${ort_required}
              -P ${PROJECT_SOURCE_DIR}/cmake/onnxruntime_install.cmake
      DEPENDS ${ort_src}/package.json ${ort_src}/package-lock.json ${PROJECT_SOURCE_DIR}/cmake/onnxruntime_install.cmake
      COMMENT "npm ci (ONNX Runtime ${ort_version}, for --mono-depth-model)"
      VERBATIM)
    add_custom_target(onnxruntime ALL DEPENDS ${ort_bin}/npm-ci.stamp)
    target_compile_definitions(chungs_depth PRIVATE
      CHUNGS_ONNXRUNTIME_BUILD_LIB="${ort_bin}/node_modules/onnxruntime-node/bin/napi-v6/linux/x64/libonnxruntime.so.1")
    message(STATUS "ONNX Runtime ${ort_version}: installed from npm into ${ort_bin} (for --mono-depth-model)")
  elseif(CHUNGS_ONNXRUNTIME_NPM STREQUAL "ON")
    message(FATAL_ERROR "CHUNGS_ONNXRUNTIME_NPM=ON needs npm (apt-get install npm) on linux-x64")
  else()
    message(STATUS "ONNX Runtime: not installed (npm not found or not linux-x64); --mono-depth-model then needs the CHUNGS_ONNXRUNTIME environment variable")
  endif()
endif()
