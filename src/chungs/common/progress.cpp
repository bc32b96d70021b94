#include "chungs/common/progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>

#include "chungs/common/log.hpp"

namespace chungs {

Progress::Progress(std::string label, long long total)
    : label_(std::move(label)),
      total_(std::max(total, 1LL)),
      tty_(isatty(STDERR_FILENO)),
      enabled_(log::enabled(log::Level::Info)),
      start_(std::chrono::steady_clock::now()),
      last_draw_(start_) {}

Progress::~Progress() { finish(); }

void Progress::step(long long n) {
  done_ = std::min(done_ + n, total_);
  draw(false);
}

void Progress::finish() {
  if (finished_) return;
  finished_ = true;
  draw(true);
}

void Progress::draw(bool final) {
  if (!enabled_) return;
  auto now = std::chrono::steady_clock::now();
  double elapsed = std::chrono::duration<double>(now - start_).count();
  double frac = double(done_) / double(total_);
  int decile = int(frac * 10);
  if (tty_) {
    if (!final && now - last_draw_ < std::chrono::milliseconds(100)) return;
    last_draw_ = now;
    const int width = 30;
    int filled = int(frac * width);
    std::string bar(filled, '#');
    bar.resize(width, '.');
    double eta = frac > 0 ? elapsed * (1 - frac) / frac : 0;
    std::fprintf(stderr, "\r%s [%s] %lld/%lld %.0fs eta %.0fs ", label_.c_str(), bar.c_str(), done_,
                 total_, elapsed, eta);
    if (final) std::fprintf(stderr, "\n");
  } else {
    if (decile == last_decile_) return;  // this state was printed already
    last_decile_ = decile;
    std::fprintf(stderr, "[info] %s: %lld/%lld (%d%%) %.1fs\n", label_.c_str(), done_, total_,
                 int(frac * 100), elapsed);
  }
  std::fflush(stderr);
}

}  // namespace chungs
