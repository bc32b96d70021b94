// Helpers for the dataset tests: writing small files, expecting an Error with given message parts,
// and depth statistics.
#pragma once
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "chungs/common/error.hpp"
#include "chungs/image/image.hpp"

namespace chungs::test {

inline void write_text(const std::filesystem::path& file, const std::string& text) {
  std::filesystem::create_directories(file.parent_path());
  std::ofstream out(file, std::ios::binary);
  out << text;
}

// Runs f, which must throw chungs::Error whose message contains every one of `parts`; returns it.
inline std::string expect_error(const std::function<void()>& f, const std::vector<std::string>& parts) {
  try {
    f();
  } catch (const Error& e) {
    std::string msg = e.what();
    if (std::getenv("CHUNGS_SHOW_ERRORS")) std::printf("  error: %s\n", msg.c_str());  // to read them by eye
    for (const auto& p : parts) EXPECT_NE(msg.find(p), std::string::npos) << "'" << p << "' not in: " << msg;
    return msg;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "threw a non-chungs exception: " << e.what();
    return {};
  }
  ADD_FAILURE() << "did not throw";
  return {};
}

// Median of the valid (> 0) depths, and the fraction of pixels that are valid.
inline double median_valid(const ImageF& depth, double* valid_fraction = nullptr) {
  std::vector<float> v;
  for (float d : depth.vec())
    if (d > 0) v.push_back(d);
  if (valid_fraction) *valid_fraction = depth.size() ? double(v.size()) / double(depth.size()) : 0;
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace chungs::test
