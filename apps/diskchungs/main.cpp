// diskchungs: the command-line front end. Errors end as one line on stderr and a non-zero exit.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <map>
#include <new>
#include <string>

#include "chungs/common/log.hpp"
#include "chungs/common/process_defaults.hpp"
#include "command.hpp"
#include "number_flags.hpp"

namespace chungs::app {

Command::Command(std::string n, std::string h, std::function<Action(CLI::App&)> s)
    : name(std::move(n)), help(std::move(h)), setup(std::move(s)) {
  commands().push_back(this);
}

std::vector<const Command*>& commands() {
  static std::vector<const Command*> list;
  return list;
}

namespace {

// The command as typed: what an out-of-memory error names, having no input of its own to name.
std::string g_command_line;
std::terminate_handler g_default_terminate = nullptr;

void print_out_of_memory() {
  std::fprintf(stderr, "diskchungs: error: out of memory running '%s'\n", g_command_line.c_str());
}

// Out of memory that escapes a thread of its own (a worker, an OpenMP region) ends here: the same
// one line and exit code as on the main thread. Anything else keeps the default end, core and all.
void on_terminate() {
  if (std::exception_ptr e = std::current_exception()) {
    try {
      std::rethrow_exception(e);
    } catch (const std::bad_alloc&) {
      print_out_of_memory();
      std::_Exit(1);
    } catch (...) {
    }
  }
  g_default_terminate();
}

void report_out_of_memory_as_error(int argc, char** argv) {
  g_command_line = "diskchungs";
  for (int i = 1; i < argc; ++i) g_command_line += std::string(" ") + argv[i];
  g_default_terminate = std::set_terminate(on_terminate);
}

}  // namespace
}  // namespace chungs::app

int main(int argc, char** argv) {
  using namespace chungs;
  set_process_defaults();
  app::report_out_of_memory_as_error(argc, argv);
  CLI::App cli{"DiskChunGS: Gaussian-splatting SLAM with out-of-core chunked maps"};
  cli.require_subcommand(1);
  bool quiet = false, verbose = false;
  CLI::Option* quiet_flag = cli.add_flag("-q,--quiet", quiet, "only warnings and errors");
  // Both together asked for two levels of messages at once; the later setting won without a word.
  cli.add_flag("-v,--verbose", verbose, "debug messages")->excludes(quiet_flag);

  auto cmds = app::commands();
  std::sort(cmds.begin(), cmds.end(), [](auto* a, auto* b) { return a->name < b->name; });
  std::map<CLI::App*, app::Action> actions;
  for (const auto* c : cmds) {
    CLI::App* sub = cli.add_subcommand(c->name, c->help);
    sub->fallthrough();  // -q / -v also after the subcommand, where users type them
    actions[sub] = c->setup(*sub);
  }
  // A mistyped command, or a mistyped kind of one (`synth castle`): CLI11 would only say that a
  // subcommand is required.
  CLI::App* level = &cli;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (!arg.empty() && arg[0] == '-') continue;  // global flags before the command
    const auto subs = level->get_subcommands([](CLI::App*) { return true; });
    if (subs.empty()) break;
    const auto it = std::find_if(subs.begin(), subs.end(), [&](CLI::App* s) { return s->get_name() == arg; });
    if (it == subs.end()) {
      const std::string what = level == &cli ? "command" : level->get_name() + " command";
      std::string names;
      for (const auto* s : subs) names += (names.empty() ? "" : ", ") + s->get_name();
      std::fprintf(stderr, "diskchungs: error: unknown %s '%s' (%ss: %s)\n", what.c_str(), arg.c_str(),
                   what.c_str(), names.c_str());
      return 2;
    }
    level = *it;
  }
  try {
    cli.parse(argc, argv);
  } catch (const CLI::ConversionError& e) {
    if (const std::string why = app::conversion_refusal(cli, e); !why.empty()) {
      std::fprintf(stderr, "diskchungs: error: %s\n", why.c_str());
      return 1;
    }
    return cli.exit(e);
  } catch (const CLI::ParseError& e) {
    return cli.exit(e);
  }
  if (const std::string why = app::misread_number(cli); !why.empty()) {
    std::fprintf(stderr, "diskchungs: error: %s\n", why.c_str());
    return 1;
  }
  if (quiet) log::set_level(log::Level::Warn);
  if (verbose) log::set_level(log::Level::Debug);
  try {
    for (auto& [sub, action] : actions)
      if (sub->parsed()) return action();
    return 2;
  } catch (const CLI::ParseError& e) {
    return cli.exit(e);
  } catch (const std::bad_alloc&) {
    app::print_out_of_memory();
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "diskchungs: error: %s\n", e.what());
    return 1;
  }
}
