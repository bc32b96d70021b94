// Runs a reader on a hostile file in a forked child whose address space may grow by a bounded amount,
// so that a reader trusting a size in the file ends in std::bad_alloc there instead of taking the test
// machine's memory, and the test sees which way it went.
#pragma once
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <functional>
#include <new>
#include <string>

#include "chungs/common/error.hpp"

namespace chungs::test {

struct BoundedRun {
  std::string outcome;  // "error" (chungs::Error), "bad_alloc", "exception", "returned" or "died"
  std::string message;  // the exception's text

  std::string describe() const { return outcome + ": " + message; }
};

// `body` runs in a child that may map at most `extra_bytes` more than this process maps now.
inline BoundedRun run_with_memory_limit(size_t extra_bytes, const std::function<void()>& body) {
  size_t pages = 0;
  std::ifstream("/proc/self/statm") >> pages;
  int fds[2];
  if (pipe(fds) != 0) return {"died", "pipe() failed"};
  std::fflush(nullptr);
  const pid_t pid = fork();
  if (pid < 0) return {"died", "fork() failed"};
  if (pid == 0) {
    close(fds[0]);
    const rlim_t limit = rlim_t(pages) * rlim_t(sysconf(_SC_PAGESIZE)) + extra_bytes;
    const rlimit lim{limit, limit};
    std::string report = "died\nsetrlimit failed";
    if (setrlimit(RLIMIT_AS, &lim) == 0) {
      try {
        body();
        report = "returned\n";
      } catch (const Error& e) {
        report = std::string("error\n") + e.what();
      } catch (const std::bad_alloc& e) {
        report = std::string("bad_alloc\n") + e.what();
      } catch (const std::exception& e) {
        report = std::string("exception\n") + e.what();
      }
    }
    const ssize_t written = write(fds[1], report.data(), report.size());
    _exit(written == ssize_t(report.size()) ? 0 : 1);  // no atexit handlers: they belong to the parent
  }
  close(fds[1]);
  std::string text;
  char buf[4096];
  for (ssize_t n; (n = read(fds[0], buf, sizeof buf)) > 0;) text.append(buf, size_t(n));
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  const size_t eol = text.find('\n');
  if (!WIFEXITED(status) || eol == std::string::npos)
    return {"died", "child ended with status " + std::to_string(status)};
  return {text.substr(0, eol), text.substr(eol + 1)};
}

}  // namespace chungs::test
