# Included before the modules are declared, so that every library a fuzz target links is built
# with the same coverage and sanitizers: a bug in a helper the parser calls counts as much as one
# in the parser.
if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
  message(FATAL_ERROR "CHUNGS_FUZZ=ON needs clang (libFuzzer), not ${CMAKE_CXX_COMPILER_ID}: configure a "
                      "separate folder with -DCMAKE_CXX_COMPILER=clang++ (Debian 12: apt-get install clang libomp-dev)")
endif()
set(CHUNGS_CUDA OFF CACHE STRING "" FORCE)
set(CHUNGS_TESTS OFF CACHE BOOL "" FORCE)
set(CHUNGS_BENCH OFF CACHE BOOL "" FORCE)
# -O1 with debug lines: the sanitizers' stacks stay readable and libFuzzer still runs fast.
add_compile_options(-O1 -g -fno-omit-frame-pointer -fsanitize=fuzzer-no-link,address,undefined
                    -fno-sanitize-recover=undefined -Wno-unknown-warning-option)
add_link_options(-fsanitize=address,undefined)
