#include "stop_signal.hpp"

#include <unistd.h>

#include <csignal>
#include <cstring>

namespace chungs::app {
namespace {

std::atomic<bool> g_stop{false};
const char* g_message = "";
struct sigaction g_before[2];
constexpr int kSignals[2] = {SIGINT, SIGTERM};

void on_signal(int) {
  g_stop = true;  // lock-free: safe in a handler
  const ssize_t ignored = ::write(STDERR_FILENO, g_message, std::strlen(g_message));
  (void)ignored;
}

}  // namespace

StopSignal::StopSignal(const char* message) {
  static_assert(std::atomic<bool>::is_always_lock_free);
  g_stop = false;
  g_message = message;
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESETHAND | SA_RESTART;  // the second signal finds the default action
  for (int i = 0; i < 2; ++i) {
    sigaction(kSignals[i], nullptr, &g_before[i]);
    if (g_before[i].sa_handler != SIG_IGN) sigaction(kSignals[i], &sa, nullptr);
  }
}

StopSignal::~StopSignal() {
  for (int i = 0; i < 2; ++i) sigaction(kSignals[i], &g_before[i], nullptr);
}

const std::atomic<bool>& StopSignal::stop() const { return g_stop; }

}  // namespace chungs::app
