#pragma once
// The headless procman sheriff: holds a configuration (sheriff_config.hpp), learns the actual state of the
// deputies from PM_INFO, and sends each deputy its whole desired state on PM_ORDERS (now and every second).
//
// Taking over: a sheriff starting up adopts what each deputy reports (desired run id = actual run id, stopped
// commands stay stopped), and only then sends that deputy orders, so that starting a sheriff (or running one
// command line after another) never restarts or stops anything by itself.
#include <atomic>
#include <functional>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include "procman/safe_subscribe.hpp"
#include "procman/sheriff_config.hpp"
#include "procman_lcm/deputy_info_t.hpp"
#include "procman_lcm/output_t.hpp"

namespace ips::procman {

enum class CommandStatus { kUnknown, kTryingToStart, kRunning, kRestarting, kTryingToStop, kStoppedOk, kStoppedError };
const char* statusName(CommandStatus s);

struct SheriffCommand {
  CommandConfig config;  // deputy resolved (never empty)
  int32_t desired_runid = 0;
  bool force_quit = true;
  // As last reported by the deputy.
  bool reported = false;
  int32_t pid = 0;
  int32_t actual_runid = 0;
  int32_t exit_code = 0;  // raw wait status
  float cpu_usage = 0.f;
  int64_t mem_rss_bytes = 0;
  int64_t mem_vsize_bytes = 0;
};

// Status as the upstream sheriff derives it from desired and reported state.
CommandStatus commandStatus(const SheriffCommand& c);
// "0", "exit(3)", "SIGTERM", ... for a raw wait status (one word, for the status table).
std::string describeWaitStatus(int32_t status);

struct DeputyView {
  std::string id;
  bool seen = false;
  bool configured = false;  // has commands in our configuration: the only deputies we ever send orders
  bool adopted = false;     // state taken over; orders may be sent
  int64_t last_info_us = 0;
  float cpu_load = 0.f;
  int64_t mem_total_bytes = 0, mem_free_bytes = 0;
  std::vector<procman_lcm::cmd_status_t> unknown_commands;  // reported but not in the configuration
};

struct SheriffOptions {
  std::string lcm_url;
  std::string sheriff_id;      // default "procman-sheriff@<host>"; must differ from every deputy id
  std::string default_deputy;  // for commands without deputy; default: the host name
  bool observe_only = false;   // never send orders (status, follow)
  double orders_period_s = 1.0;
};

class Sheriff {
 public:
  Sheriff(SheriffConfig config, SheriffOptions options);

  // Asks deputies to report (PM_DISCOVER) and handles LCM until every deputy in `deputies` has reported and
  // been adopted, or `timeout_s` passed. Returns the deputies still missing.
  std::vector<std::string> waitForDeputies(const std::vector<std::string>& deputies, double timeout_s);
  // Every deputy named in the configuration.
  std::vector<std::string> configuredDeputies() const;

  // Commands selected by a command id or group path (kind "cmd", "group", "everything", or "" = either
  // command id or group path). Throws ConfigError if nothing matches.
  std::vector<SheriffCommand*> select(const std::string& kind, const std::string& name);
  void start(const std::vector<SheriffCommand*>& cmds);
  void stop(const std::vector<SheriffCommand*>& cmds);
  void restart(const std::vector<SheriffCommand*>& cmds);

  // Handles LCM and sends orders every period until `done()` is true, the time is up or `interrupted`
  // (if set, e.g. by a signal handler) becomes true; returns done().
  bool spinUntil(const std::function<bool()>& done, double timeout_s);
  void spinFor(double seconds) {
    spinUntil([] { return false; }, seconds);
  }
  void sendOrders();
  void setInterruptFlag(const std::atomic<bool>* interrupted) { interrupted_ = interrupted; }

  // Runs a script of the configuration; each wait in it may last up to `wait_timeout_s`. Throws
  // std::runtime_error naming the action that timed out.
  void runScript(const std::string& name, double wait_timeout_s, std::ostream& log);

  void printStatus(std::ostream& out) const;
  void setOutputHandler(
      std::function<void(const std::string& deputy, const std::string& command_id, const std::string& text)> handler) {
    output_handler_ = std::move(handler);
  }

  std::vector<SheriffCommand>& commands() { return commands_; }
  const std::map<std::string, DeputyView>& deputies() const { return deputies_; }
  lcm::LCM& lcm() { return *lcm_; }
  const std::string& sheriffId() const { return opt_.sheriff_id; }

  static bool isRunning(const SheriffCommand& c) { return commandStatus(c) == CommandStatus::kRunning; }
  static bool isStopped(const SheriffCommand& c) {
    const auto s = commandStatus(c);
    return s == CommandStatus::kStoppedOk || s == CommandStatus::kStoppedError;
  }
  // The deputy has acted on the latest start/restart (the run id matches), whether or not it still runs.
  static bool hasStarted(const SheriffCommand& c) {
    return c.reported && !c.force_quit && c.actual_runid == c.desired_runid;
  }

 private:
  void onInfo(const lcm::ReceiveBuffer*, const std::string&, const procman_lcm::deputy_info_t* msg);
  void onOutput(const lcm::ReceiveBuffer*, const std::string&, const procman_lcm::output_t* msg);
  void handle(int timeout_ms);
  bool waitStatus(const std::vector<SheriffCommand*>& cmds, const std::string& status, double timeout_s);
  void runScriptDepth(const std::string& name, double wait_timeout_s, std::ostream& log, int depth);

  SheriffOptions opt_;
  SheriffConfig config_;
  std::unique_ptr<lcm::LCM> lcm_;
  std::unique_ptr<SafeSubscriber> subscriber_;  // drops (and reports) messages that do not decode
  std::vector<SheriffCommand> commands_;
  std::map<std::string, DeputyView> deputies_;
  int64_t last_orders_us_ = 0;
  bool orders_dirty_ = false;
  std::function<void(const std::string&, const std::string&, const std::string&)> output_handler_;
  const std::atomic<bool>* interrupted_ = nullptr;
};

}  // namespace ips::procman
