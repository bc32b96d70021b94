// Host side of a backend's phase timings (StepPhaseTimes): the wall time from one phase boundary to
// the next on the thread that runs the step. A phase that is skipped in a step simply gets no time.
#pragma once
#include <chrono>

#include "chungs/mapping/optim_backend.hpp"

namespace chungs {

class StepPhaseClock {
 public:
  void set_on(bool on) {
    on_ = on;
    times_ = {};
  }
  bool on() const { return on_; }
  void begin() {
    if (on_) start_ = last_ = clock::now();
  }
  // The phase that ends now.
  void mark(StepPhaseTimes::Phase phase) {
    if (!on_) return;
    const auto now = clock::now();
    times_.host_ms[phase] += ms(last_, now);
    last_ = now;
  }
  void end() {
    if (!on_) return;
    times_.host_total_ms += ms(start_, clock::now());
    ++times_.steps;
  }
  StepPhaseTimes& times() { return times_; }
  const StepPhaseTimes& times() const { return times_; }

 private:
  using clock = std::chrono::steady_clock;
  static double ms(clock::time_point a, clock::time_point b) {
    return std::chrono::duration<double, std::milli>(b - a).count();
  }
  bool on_ = false;
  StepPhaseTimes times_;
  clock::time_point start_, last_;
};

}  // namespace chungs
