// Subcommands register themselves: each cmd_*.cpp defines one static Command with the function that
// adds its options to the CLI and returns the action to run once parsing succeeded.
#pragma once
#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <vector>

namespace chungs::app {

using Action = std::function<int()>;  // returns the exit code

struct Command {
  std::string name, help;
  std::function<Action(CLI::App&)> setup;  // adds options to the subcommand, returns its action
  Command(std::string name, std::string help, std::function<Action(CLI::App&)> setup);
};

std::vector<const Command*>& commands();

}  // namespace chungs::app
