// Progress bar for long work, on stderr. On a terminal it redraws one line; otherwise (CI, logs) it
// prints a line every 10 %, and between them at most every `quiet_gap` (30 s by default), so a log
// of long work (a million refinement steps, an hour's drive) never goes silent for hours. Silent when
// the log level is above Info (--quiet).
#pragma once
#include <chrono>
#include <string>

namespace chungs {

class Progress {
 public:
  Progress(std::string label, long long total,
           std::chrono::milliseconds quiet_gap = std::chrono::seconds(30));
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void step(long long n = 1);  // thread-compatible, not thread-safe: call from one thread
  void finish();

 private:
  void draw(bool final);
  std::string label_;
  long long total_, done_ = 0;
  int last_decile_ = -1;
  bool tty_, enabled_, finished_ = false;
  std::chrono::milliseconds quiet_gap_;
  std::chrono::steady_clock::time_point start_, last_draw_;
};

}  // namespace chungs
