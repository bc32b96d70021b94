find_package(Threads REQUIRED)
find_package(OpenMP REQUIRED)
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(PNG REQUIRED)
find_package(JPEG REQUIRED)
find_package(ZLIB REQUIRED)
find_package(yaml-cpp REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
find_package(CLI11 REQUIRED)
# Only the OpenCV modules we use: imgcodecs would drag GDAL and ~150 libraries in (DESIGN.md).
# Debian ships OpenCVConfig.cmake only in the all-modules libopencv-dev, so we find them by hand.
find_path(OPENCV_INCLUDE_DIR opencv2/core.hpp PATH_SUFFIXES opencv4 REQUIRED)
foreach(m core imgproc calib3d features2d flann)
  find_library(OPENCV_${m}_LIB opencv_${m} REQUIRED)
  add_library(opencv_${m} UNKNOWN IMPORTED)
  set_target_properties(opencv_${m} PROPERTIES IMPORTED_LOCATION ${OPENCV_${m}_LIB}
    INTERFACE_INCLUDE_DIRECTORIES ${OPENCV_INCLUDE_DIR})
endforeach()
find_package(PkgConfig REQUIRED)
pkg_check_modules(ZSTD REQUIRED IMPORTED_TARGET libzstd)
find_package(Ceres 2 REQUIRED)
# cpp-httplib (the viewer's server): Debian ships it compiled, with the flags its library was built
# with in its .pc file (TLS, zlib, brotli change class layouts), so it is found through pkg-config.
pkg_check_modules(HTTPLIB REQUIRED IMPORTED_TARGET cpp-httplib)
