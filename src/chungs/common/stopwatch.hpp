// Milliseconds since a steady-clock time point: the one helper the phase timings in reports use.
#pragma once
#include <chrono>

namespace chungs {

inline double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace chungs
