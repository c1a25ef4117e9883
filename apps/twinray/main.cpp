// twinray: render scene files from the command line (docs/command-line.md).
//
//   twinray render SCENE -o OUT [options]
//   twinray info
//
// Subcommands register themselves (command.hpp); this file parses the command line,
// runs the chosen one and turns what went wrong into the exit status of docs/command-line.md:
// 0 success, 1 run-time failure, 2 bad command line or scene, 3 backend unavailable.
#include <exception>
#include <iostream>
#include <memory>
#include <new>
#include <string>
#include <utility>
#include <vector>

#include <twinray/version.hpp>

#include "cli_common.hpp"
#include "command.hpp"

int main(int argc, char** argv) {
  using twinray_cli::kExitBadInput;
  using twinray_cli::kExitRuntimeFailure;
  CLI::App app("twinray " TWINRAY_VERSION_STRING
               ": a ray tracer whose CPU and OpenCL backends render the same image, bit "
               "for bit",
               "twinray");
  app.set_version_flag("--version", "twinray " TWINRAY_VERSION_STRING);
  app.require_subcommand(1, 1);
  app.footer(
      "Exit status: 0 success, 1 rendering failed at run time, 2 bad command line or scene,\n"
      "3 the requested backend is not available. `twinray SUBCOMMAND --help` for more.");

  std::vector<std::pair<CLI::App*, twinray_cli::Run>> runs;
  for (const twinray_cli::CommandEntry& c : twinray_cli::registered_commands()) {
    CLI::App* sub = app.add_subcommand(c.name, c.description);
    runs.emplace_back(sub, c.setup(*sub));
  }

  // CLI11 reads an unknown word as a stray argument ("A subcommand is required"); name it.
  if (argc > 1 && argv[1][0] != '-') {
    std::string names;
    bool known = false;
    for (auto& entry : runs) {
      names += (names.empty() ? "" : ", ") + entry.first->get_name();
      known = known || entry.first->get_name() == argv[1];
    }
    if (!known) {
      std::cerr << "twinray: unknown subcommand \"" << argv[1] << "\"; the subcommands are "
                << names << " (twinray --help)\n";
      return kExitBadInput;
    }
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    int code = app.exit(e);  // prints help, the version, or the error
    return code == 0 ? 0 : kExitBadInput;
  }

  for (auto& [sub, run] : runs) {
    if (!sub->parsed()) continue;
    try {
      return run();
    } catch (const twinray::Error& e) {
      int status = twinray_cli::exit_status(e.kind());
      std::cerr << "twinray: "
                << (status == twinray_cli::kExitBackendUnavailable
                        ? "the requested backend is not available: "
                        : "")
                << e.what() << "\n";
      return status;
    } catch (const std::bad_alloc&) {
      std::cerr << "twinray: out of memory\n";
      return kExitRuntimeFailure;
    } catch (const std::exception& e) {
      std::cerr << "twinray: " << e.what() << "\n";
      return kExitRuntimeFailure;
    }
  }
  std::cerr << "twinray: no subcommand given; see twinray --help\n";
  return kExitBadInput;
}
