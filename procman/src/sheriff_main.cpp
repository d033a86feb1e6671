// procman-sheriff: the headless procman sheriff. Loads a procman configuration, takes over the state the
// deputies report, starts/stops/restarts commands and groups or runs a script, prints a status table and
// follows output. See procman/README.md; the command line is procman/sheriff_cli.hpp's.
#include <atomic>
#include <csignal>

#include "procman/sheriff_cli.hpp"

namespace {

std::atomic<bool> g_stop{false};
void onSignal(int) { g_stop = true; }

}  // namespace

int main(int argc, char** argv) {
  const ips::procman::SheriffCliParse parsed = ips::procman::parseSheriffCli(argc, argv);
  if (!parsed.cli) return parsed.exit_status;
  return ips::procman::runSheriffCli(*parsed.cli, g_stop, [] {
    std::signal(SIGINT, onSignal);
    std::signal(SIGTERM, onSignal);
  });
}
