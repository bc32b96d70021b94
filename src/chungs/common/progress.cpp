#include "chungs/common/progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>

#include "chungs/common/log.hpp"

namespace chungs {
namespace {

// "42s", "7m05s", "75h10m": an estimate of days read as seconds means nothing to a person.
std::string duration_words(double seconds) {
  const long long s = seconds < 0 || !(seconds < 1e15) ? 0 : (long long)(seconds + 0.5);
  char buf[64];
  if (s < 60)
    std::snprintf(buf, sizeof buf, "%llds", s);
  else if (s < 3600)
    std::snprintf(buf, sizeof buf, "%lldm%02llds", s / 60, s % 60);
  else
    std::snprintf(buf, sizeof buf, "%lldh%02lldm", s / 3600, s % 3600 / 60);
  return buf;
}

}  // namespace

Progress::Progress(std::string label, long long total, std::chrono::milliseconds quiet_gap)
    : label_(std::move(label)),
      total_(std::max(total, 1LL)),
      tty_(isatty(STDERR_FILENO)),
      enabled_(log::enabled(log::Level::Info)),
      quiet_gap_(quiet_gap),
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
  double eta = frac > 0 ? elapsed * (1 - frac) / frac : 0;
  // One step of 33,732 (its chunks still loading) said "eta 1h04m" for a 75 s refinement: an estimate
  // waits for a hundredth of the work or two seconds.
  const bool eta_known = frac >= 0.01 || elapsed >= 2;
  if (tty_) {
    if (!final && now - last_draw_ < std::chrono::milliseconds(100)) return;
    last_draw_ = now;
    const int width = 30;
    int filled = int(frac * width);
    std::string bar(filled, '#');
    bar.resize(width, '.');
    std::fprintf(stderr, "\r%s [%s] %lld/%lld %.0fs eta %s ", label_.c_str(), bar.c_str(), done_,
                 total_, elapsed, eta_known ? duration_words(eta).c_str() : "--");
    if (final) std::fprintf(stderr, "\n");
  } else {
    if (decile == last_decile_ && now - last_draw_ < quiet_gap_) return;  // printed lately
    last_decile_ = decile;
    last_draw_ = now;
    if (final || done_ == 0 || done_ == total_ || !eta_known)
      std::fprintf(stderr, "[info] %s: %lld/%lld (%d%%) %.1fs\n", label_.c_str(), done_, total_,
                   int(frac * 100), elapsed);
    else
      std::fprintf(stderr, "[info] %s: %lld/%lld (%d%%) %.1fs, eta %s\n", label_.c_str(), done_, total_,
                   int(frac * 100), elapsed, duration_words(eta).c_str());
  }
  std::fflush(stderr);
}

}  // namespace chungs
