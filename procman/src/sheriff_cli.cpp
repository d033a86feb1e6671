#include "procman/sheriff_cli.hpp"

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <iostream>
#include <set>

#include "ips/args.hpp"

namespace ips::procman {

bool SheriffCli::ordersNeeded() const {
  return start_all || stop_all || restart_all || !starts.empty() || !stops.empty() || !restarts.empty() ||
         !script.empty() || keep;
}

namespace {

// The sheriff's options, declared once for parsing and for the usage text.
ips::Args sheriffArgs(int argc, char** argv) {
  ips::Args args(argc, argv,
                 "headless procman sheriff: sends orders to procman deputies over LCM and reports their state");
  args.usage(
      "procman-sheriff [--config FILE] [options] ACTION...\n\n"
      "Actions run in this order: --stop*, --start*, --restart*, --script, then --status, --follow, --keep-running.");
  args.section("Actions");
  args.flag("--start-all", "start every command in the configuration");
  args.flag("--stop-all", "stop every command in the configuration");
  args.flag("--restart-all", "restart every command in the configuration");
  args.repeated("--start", "NAME", "a command id or a group path (\"a/b\" includes its subgroups)");
  args.repeated("--stop", "NAME", "as --start");
  args.repeated("--restart", "NAME", "as --start");
  args.option("--script", "NAME", "run a script of the configuration");
  args.flag("--status",
            "print the deputies and the status table (works without --config: then\n"
            "it only observes and shows what the deputies report)");
  args.repeated("--follow", "CMD",
                "print the output of command CMD (with several, lines are prefixed\n"
                "[CMD]) until SIGINT/SIGTERM or --duration");
  args.flag("--keep-running",
            "stay: resend orders every second (and print the table every\n"
            "--status-period s) until SIGINT/SIGTERM or --duration");
  args.flag("--check", "parse the configuration, print it, and exit (no LCM)");
  args.section("Options");
  args.option("--config", "FILE",
              "procman configuration (groups, cmd, script); required for all but\n--status/--follow");
  args.option("--lcm-url", "URL", "LCM URL [default: $LCM_DEFAULT_URL or LCM's default]").alias("-u", "--lcm-url");
  args.alias("--lcmurl", "--lcm-url");
  args.option("--id", "NAME", "sheriff id [default: procman-sheriff@HOST; must not be a deputy id]");
  args.option("--default-deputy", "ID", "deputy of commands that name none [default: this host's name]");
  args.option("--timeout", "S", "wait this long for deputies to report and for commands to reach\ntheir state", "15");
  args.option("--wait", "STATE",
              "what --start/--restart wait for: started (the deputy started the\n"
              "command), running, none; --stop always waits until stopped unless none",
              "started");
  args.option("--duration", "S", "end --follow/--keep-running after S seconds");
  args.option("--status-period", "S", "with --keep-running: print the table every S seconds (0: never)", "0");
  args.flag("--stop-on-exit", "with --follow/--keep-running: stop everything before exiting");
  args.epilog(
      "Exit status: 0 done; 1 error (usage, configuration, LCM); 3 timed out (a deputy did not report or a\n"
      "command did not reach its state).");
  return args;
}

// A non-negative number of seconds (Args::getDouble, which names the option when it is no number).
double seconds(const ips::Args& args, const std::string& name) {
  const double value = args.getDouble(name);
  if (value < 0) throw ips::ArgError("procman-sheriff: " + name + " must not be negative, got " + args.get(name));
  return value;
}

}  // namespace

void printSheriffUsage(FILE* out) {
  char program[] = "procman-sheriff";
  char* argv[] = {program, nullptr};
  std::fputs(sheriffArgs(1, argv).help().c_str(), out);
}

SheriffCliParse parseSheriffCli(int argc, char** argv) {
  const SheriffCliParse error{std::nullopt, kSheriffExitError};
  SheriffCli cli;
  try {
    ips::Args args = sheriffArgs(argc, argv);
    if (!args.parse()) return {std::nullopt, kSheriffExitOk};
    cli.start_all = args.getFlag("--start-all");
    cli.stop_all = args.getFlag("--stop-all");
    cli.restart_all = args.getFlag("--restart-all");
    cli.starts = args.getAll("--start");
    cli.stops = args.getAll("--stop");
    cli.restarts = args.getAll("--restart");
    cli.script = args.get("--script");
    cli.status = args.getFlag("--status");
    cli.follows = args.getAll("--follow");
    cli.keep = args.getFlag("--keep-running");
    cli.check = args.getFlag("--check");
    cli.config_path = args.get("--config");
    cli.options.lcm_url = args.get("--lcm-url");
    if (args.has("--id")) cli.options.sheriff_id = args.get("--id");
    if (args.has("--default-deputy")) cli.options.default_deputy = args.get("--default-deputy");
    cli.timeout_s = seconds(args, "--timeout");
    if (args.has("--duration")) cli.duration_s = seconds(args, "--duration");
    cli.status_period_s = seconds(args, "--status-period");
    cli.stop_on_exit = args.getFlag("--stop-on-exit");
    const std::string wait = args.get("--wait");
    if (wait == "started") {
      cli.wait_mode = SheriffCli::Wait::kStarted;
    } else if (wait == "running") {
      cli.wait_mode = SheriffCli::Wait::kRunning;
    } else if (wait == "none") {
      cli.wait_mode = SheriffCli::Wait::kNone;
    } else {
      throw ips::ArgError("procman-sheriff: --wait must be started, running or none");
    }
  } catch (const ips::ArgError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return error;
  }
  if (!cli.ordersNeeded() && !cli.status && cli.follows.empty() && !cli.check) {
    printSheriffUsage(stderr);
    return error;
  }
  if ((cli.ordersNeeded() || cli.check) && cli.config_path.empty()) {
    std::fprintf(stderr, "procman-sheriff: this action needs --config FILE\n");
    return error;
  }
  return {std::move(cli), kSheriffExitOk};
}

void printSheriffConfig(const std::string& path, const SheriffConfig& config, FILE* out) {
  std::fprintf(out, "%s: %zu commands, %zu groups, %zu scripts\n", path.c_str(), config.commands.size(),
               config.groups.size(), config.scripts.size());
  for (const auto& cmd : config.commands)
    std::fprintf(out, "cmd %s deputy=%s group=%s auto_respawn=%d stop_signal=%d stop_time_allowed=%g exec=%s\n",
                 cmd.id.c_str(), cmd.deputy.empty() ? "(default)" : cmd.deputy.c_str(),
                 cmd.group.empty() ? "-" : cmd.group.c_str(), cmd.auto_respawn ? 1 : 0, cmd.stop_signal,
                 cmd.stop_time_allowed, cmd.exec.c_str());
  for (const auto& s : config.scripts) {
    std::fprintf(out, "script %s:\n", s.name.c_str());
    for (const auto& a : s.actions) std::fprintf(out, "  %s;\n", a.describe().c_str());
  }
}

std::string followedOutput(const std::string& id, const std::string& text, bool prefix) {
  if (!prefix) return text;
  std::string out;
  size_t start = 0;
  while (start < text.size()) {
    const size_t nl = text.find('\n', start);
    const size_t end = nl == std::string::npos ? text.size() : nl + 1;
    // Printed as a C string: a line ends at a NUL byte.
    const size_t nul = text.find('\0', start);
    out += "[" + id + "] " + text.substr(start, (nul < end ? nul : end) - start);
    start = end;
  }
  return out;
}

namespace {

// Takes over the deputies' state (only those the actions need; all of them for --status). False when a deputy
// the orders need did not report.
bool takeOver(const SheriffCli& cli, Sheriff& sheriff) {
  std::vector<std::string> wanted = sheriff.configuredDeputies();
  if (wanted.empty()) {
    sheriff.waitForDeputies({}, 0);
    sheriff.spinFor(std::min(cli.timeout_s, 1.5));  // observe: deputies report once per second
    return true;
  }
  const auto missing = sheriff.waitForDeputies(wanted, cli.timeout_s);
  if (missing.empty()) return true;
  std::string list;
  for (const auto& m : missing) list += (list.empty() ? "" : ", ") + m;
  std::fprintf(stderr,
               "procman-sheriff: no report from deputy %s within %.0f s (is procman-deputy running "
               "with that id and the same LCM URL?)\n",
               list.c_str(), cli.timeout_s);
  return !cli.ordersNeeded();
}

// Waits until every command is `ok`; names those that are not on a timeout.
bool waitAll(const SheriffCli& cli, Sheriff& sheriff, const std::vector<SheriffCommand*>& cmds,
             bool (*ok)(const SheriffCommand&), const char* what) {
  if (sheriff.spinUntil(
          [&] {
            for (auto* c : cmds)
              if (!ok(*c)) return false;
            return true;
          },
          cli.timeout_s))
    return true;
  for (auto* c : cmds)
    if (!ok(*c))
      std::fprintf(stderr, "procman-sheriff: %s on deputy %s not %s within %.0f s (status %s)\n", c->config.id.c_str(),
                   c->config.deputy.c_str(), what, cli.timeout_s, statusName(commandStatus(*c)));
  return false;
}

// --stop*, --start*, --restart*, each list once per command, then --script. False when anything timed out.
bool runOrders(const SheriffCli& cli, Sheriff& sheriff) {
  bool ok = true;
  std::vector<SheriffCommand*> to_stop, to_start, to_restart;
  auto add = [&](std::vector<SheriffCommand*>& list, const std::vector<SheriffCommand*>& more) {
    for (auto* m : more)
      if (std::find(list.begin(), list.end(), m) == list.end()) list.push_back(m);
  };
  if (cli.stop_all) add(to_stop, sheriff.select("everything", ""));
  for (const auto& n : cli.stops) add(to_stop, sheriff.select("", n));
  if (cli.start_all) add(to_start, sheriff.select("everything", ""));
  for (const auto& n : cli.starts) add(to_start, sheriff.select("", n));
  if (cli.restart_all) add(to_restart, sheriff.select("everything", ""));
  for (const auto& n : cli.restarts) add(to_restart, sheriff.select("", n));
  if (!to_stop.empty()) {
    sheriff.stop(to_stop);
    if (cli.wait_mode != SheriffCli::Wait::kNone)
      ok = waitAll(cli, sheriff, to_stop, &Sheriff::isStopped, "stopped") && ok;
  }
  for (auto* list : {&to_start, &to_restart}) {
    if (list->empty()) continue;
    if (list == &to_start)
      sheriff.start(*list);
    else
      sheriff.restart(*list);
    if (cli.wait_mode == SheriffCli::Wait::kStarted)
      ok = waitAll(cli, sheriff, *list, &Sheriff::hasStarted, "started") && ok;
    if (cli.wait_mode == SheriffCli::Wait::kRunning)
      ok = waitAll(cli, sheriff, *list, &Sheriff::isRunning, "running") && ok;
  }
  if (!cli.script.empty()) {
    try {
      sheriff.runScript(cli.script, cli.timeout_s, std::cout);
    } catch (const std::runtime_error& e) {
      std::fprintf(stderr, "procman-sheriff: %s\n", e.what());
      ok = false;
    }
  }
  return ok;
}

// --follow and --keep-running until a signal or --duration, then --stop-on-exit. False when the stop timed out.
bool stay(const SheriffCli& cli, Sheriff& sheriff, std::atomic<bool>& stop) {
  std::set<std::string> followed(cli.follows.begin(), cli.follows.end());
  const bool prefix = followed.size() > 1;
  sheriff.setOutputHandler([&](const std::string&, const std::string& id, const std::string& text) {
    if (!followed.count(id)) return;
    const std::string out = followedOutput(id, text, prefix);
    std::fwrite(out.data(), 1, out.size(), stdout);
    std::fflush(stdout);
  });
  const auto begin = std::chrono::steady_clock::now();
  auto next_table = begin + std::chrono::duration<double>(cli.status_period_s);
  while (!stop) {
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
    if (cli.duration_s >= 0 && elapsed >= cli.duration_s) break;
    sheriff.spinFor(0.1);
    if (cli.keep && cli.status_period_s > 0 && std::chrono::steady_clock::now() >= next_table) {
      sheriff.printStatus(std::cout);
      std::cout << std::endl;
      next_table += std::chrono::duration<double>(cli.status_period_s);
    }
  }
  if (!cli.stop_on_exit) return true;
  stop = false;  // a second SIGINT/SIGTERM abandons the stop
  auto all = sheriff.select("everything", "");
  sheriff.stop(all);
  return waitAll(cli, sheriff, all, &Sheriff::isStopped, "stopped");
}

}  // namespace

int runSheriffCli(const SheriffCli& cli, std::atomic<bool>& stop,
                  const std::function<void()>& install_signal_handlers) {
  try {
    SheriffConfig config;
    if (!cli.config_path.empty()) config = loadSheriffConfig(cli.config_path);
    if (cli.check) {
      printSheriffConfig(cli.config_path, config, stdout);
      return kSheriffExitOk;
    }
    SheriffOptions options = cli.options;
    options.observe_only = !cli.ordersNeeded() && !cli.stop_on_exit;
    Sheriff sheriff(config, options);
    install_signal_handlers();
    sheriff.setInterruptFlag(&stop);
    if (!takeOver(cli, sheriff)) return kSheriffExitTimeout;
    bool ok = runOrders(cli, sheriff);
    if (cli.status) {
      sheriff.spinFor(0.2);  // let the deputies report what the actions changed
      sheriff.printStatus(std::cout);
    }
    if (!cli.follows.empty() || cli.keep) ok = stay(cli, sheriff, stop) && ok;
    return ok ? kSheriffExitOk : kSheriffExitTimeout;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "procman-sheriff: %s\n", e.what());
    return kSheriffExitError;
  }
}

}  // namespace ips::procman
