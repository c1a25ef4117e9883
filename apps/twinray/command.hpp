// The subcommand registry of the `twinray` program.
//
// Each subcommand lives in its own cmd_<name>.cpp and registers itself with a static
// Command object; apps/twinray/CMakeLists.txt compiles every cmd_*.cpp, so adding a
// subcommand touches no shared file:
//
//   namespace {
//   const twinray_cli::Command kHello("hello", "print a greeting", [](CLI::App& app) {
//     auto name = std::make_shared<std::string>("world");
//     app.add_option("--name", *name, "who to greet");
//     return [name] { std::cout << "hello " << *name << "\n"; return 0; };
//   });
//   }  // namespace
//
// The setup function adds the subcommand's options to its CLI::App and returns what
// runs it once the command line is parsed. The function returns an exit status
// (docs/command-line.md: 0 success, 1 run-time failure, 2 bad command line or scene, 3 backend
// unavailable); or it throws twinray::Error, which main() maps to the same statuses.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace twinray_cli {

using Run = std::function<int()>;

class Command {
 public:
  using Setup = std::function<Run(CLI::App& app)>;
  // `order` sorts the subcommands in --help (lower first; ties by name).
  // `across_ranks`: the subcommand runs as the ranks of an MPI job (cluster.hpp); the
  // others refuse to start as one of several ranks.
  Command(std::string name, std::string description, Setup setup, int order = 100,
          bool across_ranks = false);
};

struct CommandEntry {
  std::string name;
  std::string description;
  Command::Setup setup;
  int order = 100;
  bool across_ranks = false;
};

// Every registered subcommand, sorted by order, then name.
std::vector<CommandEntry> registered_commands();

}  // namespace twinray_cli
