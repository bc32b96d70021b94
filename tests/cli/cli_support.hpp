// Runs the diskchungs binary as a user would and captures its exit code and output.
#pragma once
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace chungs::test {

struct CliResult {
  int code = -1;
  std::string out;  // stdout and stderr together
};

// Runs a shell command line; its stderr joins its stdout.
inline CliResult run_shell(const std::string& line) {
  std::string cmd = line + " 2>&1";
  CliResult r;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

inline CliResult run_cli(const std::string& args) { return run_shell(std::string(CHUNGS_CLI) + " " + args); }

// As run_cli, with the process's address space limited to `megabytes` (the shell's ulimit -v).
inline CliResult run_cli_with_memory_limit(size_t megabytes, const std::string& args) {
  return run_shell("ulimit -v " + std::to_string(megabytes * 1024) + " && exec " + CHUNGS_CLI + " " + args);
}

}  // namespace chungs::test
