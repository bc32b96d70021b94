// Ctrl-C (SIGINT) and SIGTERM for a command that stops cleanly: the first sets a flag the command
// polls at its safe points (and says so on stderr); a second ends the process at once, as the
// default action is back in place by then. A signal the shell set to be ignored (a background job
// without job control, nohup) stays ignored.
#pragma once
#include <atomic>

namespace chungs::app {

class StopSignal {
 public:
  // `message`: written to stderr on the first signal (a string literal: it must outlive the handler).
  explicit StopSignal(const char* message);
  ~StopSignal();  // the dispositions found at construction come back
  StopSignal(const StopSignal&) = delete;
  StopSignal& operator=(const StopSignal&) = delete;
  const std::atomic<bool>& stop() const;
};

}  // namespace chungs::app
