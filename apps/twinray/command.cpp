// The subcommand registry (command.hpp).
#include "command.hpp"

#include <algorithm>
#include <stdexcept>

namespace twinray_cli {

namespace {
// A function-local static: filled by the static Command objects of the cmd_*.cpp files,
// whatever order the linker runs their initializers in.
std::vector<CommandEntry>& registry() {
  static std::vector<CommandEntry> entries;
  return entries;
}
}  // namespace

Command::Command(std::string name, std::string description, Setup setup, int order,
                 bool across_ranks) {
  for (const CommandEntry& e : registry())
    if (e.name == name) throw std::logic_error("twinray: subcommand registered twice: " + name);
  registry().push_back(
      {std::move(name), std::move(description), std::move(setup), order, across_ranks});
}

std::vector<CommandEntry> registered_commands() {
  std::vector<CommandEntry> entries = registry();
  std::sort(entries.begin(), entries.end(), [](const CommandEntry& a, const CommandEntry& b) {
    return a.order != b.order ? a.order < b.order : a.name < b.name;
  });
  return entries;
}

}  // namespace twinray_cli
