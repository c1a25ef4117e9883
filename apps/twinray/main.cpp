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

#include "build_helper.hpp"
#include "cli_common.hpp"
#include "cluster.hpp"
#include "command.hpp"

namespace {

int run_command(int argc, char** argv);

}  // namespace

// Under mpirun or srun every rank runs this same program (docs/distributed.md); only
// rank 0 prints help, versions and errors of the command line, which every rank finds
// alike.
int main(int argc, char** argv) {
  // A second twinray that builds an OpenCL program for the first (build_helper.hpp).
  if (twinray_cli::is_build_helper(argc, argv)) return twinray_cli::run_build_helper(argc, argv);
  try {
    twinray_cli::cluster::start(&argc, &argv);
  } catch (const twinray::Error& e) {
    std::cerr << "twinray: " << e.what() << "\n";
    return twinray_cli::kExitBadInput;
  }
  // One process per rank is enough: the ranks of an MPI job build on threads.
  if (!twinray_cli::cluster::distributed()) twinray_cli::register_build_helper();
  const int status = run_command(argc, argv);
  twinray_cli::cluster::finish(status);
  return status;
}

namespace {

int run_command(int argc, char** argv) {
  using twinray_cli::kExitBadInput;
  using twinray_cli::kExitRuntimeFailure;
  namespace cluster = twinray_cli::cluster;
  const bool speaks = cluster::rank() == 0;
  CLI::App app("twinray " TWINRAY_VERSION_STRING
               ": a ray tracer whose CPU and OpenCL backends render the same image, bit "
               "for bit",
               "twinray");
  app.set_version_flag("--version", "twinray " TWINRAY_VERSION_STRING);
  app.require_subcommand(1, 1);
  app.footer(
      "Exit status: 0 success, 1 rendering failed at run time, 2 bad command line or scene,\n"
      "3 the requested backend is not available. `twinray SUBCOMMAND --help` for more.");

  struct Subcommand {
    CLI::App* app;
    twinray_cli::Run run;
    bool across_ranks;
  };
  std::vector<Subcommand> runs;
  std::string across_ranks;  // "render and movie"
  for (const twinray_cli::CommandEntry& c : twinray_cli::registered_commands()) {
    CLI::App* sub = app.add_subcommand(c.name, c.description);
    runs.push_back({sub, c.setup(*sub), c.across_ranks});
    if (c.across_ranks) across_ranks += (across_ranks.empty() ? "" : " and ") + c.name;
  }

  // CLI11 reads an unknown word as a stray argument ("A subcommand is required"); name it.
  if (argc > 1 && argv[1][0] != '-') {
    std::string names;
    bool known = false;
    for (const Subcommand& entry : runs) {
      names += (names.empty() ? "" : ", ") + entry.app->get_name();
      known = known || entry.app->get_name() == argv[1];
    }
    if (!known) {
      cluster::fail_alike();
      if (speaks)
        std::cerr << "twinray: unknown subcommand \"" << argv[1] << "\"; the subcommands are "
                  << names << " (twinray --help)\n";
      return kExitBadInput;
    }
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // Prints help, the version, or the error.
    int code = speaks ? app.exit(e) : e.get_exit_code();
    cluster::fail_alike();
    return code == 0 ? 0 : kExitBadInput;
  }

  for (const Subcommand& sub : runs) {
    if (!sub.app->parsed()) continue;
    if (cluster::distributed() && !sub.across_ranks) {
      cluster::fail_alike();
      if (speaks)
        std::cerr << "twinray: " << sub.app->get_name() << " runs in one process; " << across_ranks
                  << " run across the ranks of an MPI job (docs/distributed.md)\n";
      return kExitBadInput;
    }
    // A rank other than 0 speaks only for failures that are its own; rank 0 reports
    // those that every rank shares.
    const std::string who = cluster::message_prefix();
    try {
      return sub.run();
    } catch (const twinray_cli::QuietExit& e) {
      return e.status;
    } catch (const twinray::Error& e) {
      int status = twinray_cli::exit_status(e.kind());
      std::cerr << who
                << (status == twinray_cli::kExitBackendUnavailable
                        ? "the requested backend is not available: "
                        : "")
                << e.what() << "\n";
      return status;
    } catch (const std::bad_alloc&) {
      std::cerr << who << "out of memory\n";
      return kExitRuntimeFailure;
    } catch (const std::exception& e) {
      std::cerr << who << e.what() << "\n";
      return kExitRuntimeFailure;
    }
  }
  cluster::fail_alike();
  if (speaks) std::cerr << "twinray: no subcommand given; see twinray --help\n";
  return kExitBadInput;
}

}  // namespace
