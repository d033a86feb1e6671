#pragma once
// The headless sheriff's command line: the actions and options parsed from argv, and the actions carried out with a
// Sheriff in the order the usage text gives (--stop*, --start*, --restart*, --script, then --status, --follow,
// --keep-running). procman-sheriff's main only adds the signal handlers.
#include <atomic>
#include <cstdio>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "procman/sheriff.hpp"
#include "procman/sheriff_config.hpp"

namespace ips::procman {

constexpr int kSheriffExitOk = 0;
constexpr int kSheriffExitError = 1;    // usage, configuration, LCM
constexpr int kSheriffExitTimeout = 3;  // a deputy did not report or a command did not reach its state

struct SheriffCli {
  std::string config_path;
  enum class Wait { kStarted, kRunning, kNone };
  Wait wait_mode = Wait::kStarted;  // --wait started|running|none
  std::string script;
  SheriffOptions options;
  bool start_all = false, stop_all = false, restart_all = false, status = false, keep = false, check = false;
  bool stop_on_exit = false;
  std::vector<std::string> starts, stops, restarts, follows;
  double timeout_s = 15.0, duration_s = -1.0, status_period_s = 0.0;

  // Whether any action sends orders: those need a configuration, and the deputies they concern.
  bool ordersNeeded() const;
};

void printSheriffUsage(FILE* out);

// A command line, or the exit status when there is nothing to run: --help (usage on stdout, 0), or an error (its
// message or the usage on stderr, 1).
struct SheriffCliParse {
  std::optional<SheriffCli> cli;
  int exit_status = kSheriffExitOk;
};
SheriffCliParse parseSheriffCli(int argc, char** argv);

// --check: the configuration as parsed.
void printSheriffConfig(const std::string& path, const SheriffConfig& config, FILE* out);

// A followed command's output as printed: as it came with one command followed, else every line prefixed "[id] ".
std::string followedOutput(const std::string& id, const std::string& text, bool prefix);

// Loads the configuration, takes over the deputies and carries out the actions; returns the exit status.
// `stop` is the flag the signal handlers raise; `install_signal_handlers` is called once the sheriff is up.
int runSheriffCli(const SheriffCli& cli, std::atomic<bool>& stop, const std::function<void()>& install_signal_handlers);

}  // namespace ips::procman
