#include "procman/sheriff_cli.hpp"

#include <getopt.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <set>

namespace ips::procman {

bool SheriffCli::ordersNeeded() const {
  return start_all || stop_all || restart_all || !starts.empty() || !stops.empty() || !restarts.empty() ||
         !script.empty() || keep;
}

void printSheriffUsage(FILE* out) {
  std::fprintf(
      out,
      "usage: procman-sheriff [--config FILE] [options] ACTION...\n"
      "\n"
      "Headless procman sheriff: sends orders to procman deputies over LCM and reports their state.\n"
      "Actions run in this order: --stop*, --start*, --restart*, --script, then --status, --follow, --keep-running.\n"
      "\n"
      "Actions:\n"
      "  --start-all, --stop-all, --restart-all   every command in the configuration\n"
      "  --start NAME, --stop NAME, --restart NAME  a command id or a group path (\"a/b\" includes its\n"
      "                       subgroups); repeatable\n"
      "  --script NAME        run a script of the configuration\n"
      "  --status             print the deputies and the status table (works without --config: then\n"
      "                       it only observes and shows what the deputies report)\n"
      "  --follow CMD         print the output of command CMD (repeatable; with several, lines are\n"
      "                       prefixed [CMD]) until SIGINT/SIGTERM or --duration\n"
      "  --keep-running       stay: resend orders every second (and print the table every\n"
      "                       --status-period s) until SIGINT/SIGTERM or --duration\n"
      "  --check              parse the configuration, print it, and exit (no LCM)\n"
      "\n"
      "Options:\n"
      "  --config FILE        procman configuration (groups, cmd, script); required for all but\n"
      "                       --status/--follow\n"
      "  -u, --lcm-url URL    LCM URL (default: $LCM_DEFAULT_URL or LCM's default)\n"
      "  --id NAME            sheriff id (default procman-sheriff@HOST; must not be a deputy id)\n"
      "  --default-deputy ID  deputy of commands that name none (default: this host's name)\n"
      "  --timeout S          wait this long for deputies to report and for commands to reach their\n"
      "                       state (default 15)\n"
      "  --wait STATE         what --start/--restart wait for: started (default: the deputy started the\n"
      "                       command), running, none; --stop always waits until stopped unless none\n"
      "  --duration S         end --follow/--keep-running after S seconds\n"
      "  --status-period S    with --keep-running: print the table every S seconds (default 0: never)\n"
      "  --stop-on-exit       with --follow/--keep-running: stop everything before exiting\n"
      "\n"
      "Exit status: 0 done; 1 error (usage, configuration, LCM); 3 timed out (a deputy did not report or a\n"
      "command did not reach its state).\n");
}

SheriffCliParse parseSheriffCli(int argc, char** argv) {
  enum Opt {
    kStartAll = 1000,
    kStopAll,
    kRestartAll,
    kStart,
    kStop,
    kRestart,
    kScript,
    kStatus,
    kFollow,
    kKeep,
    kCheck,
    kConfig,
    kId,
    kDefaultDeputy,
    kTimeout,
    kWait,
    kDuration,
    kStatusPeriod,
    kStopOnExit
  };
  const option long_opts[] = {{"help", no_argument, nullptr, 'h'},
                              {"start-all", no_argument, nullptr, kStartAll},
                              {"stop-all", no_argument, nullptr, kStopAll},
                              {"restart-all", no_argument, nullptr, kRestartAll},
                              {"start", required_argument, nullptr, kStart},
                              {"stop", required_argument, nullptr, kStop},
                              {"restart", required_argument, nullptr, kRestart},
                              {"script", required_argument, nullptr, kScript},
                              {"status", no_argument, nullptr, kStatus},
                              {"follow", required_argument, nullptr, kFollow},
                              {"keep-running", no_argument, nullptr, kKeep},
                              {"check", no_argument, nullptr, kCheck},
                              {"config", required_argument, nullptr, kConfig},
                              {"lcm-url", required_argument, nullptr, 'u'},
                              {"lcmurl", required_argument, nullptr, 'u'},
                              {"id", required_argument, nullptr, kId},
                              {"default-deputy", required_argument, nullptr, kDefaultDeputy},
                              {"timeout", required_argument, nullptr, kTimeout},
                              {"wait", required_argument, nullptr, kWait},
                              {"duration", required_argument, nullptr, kDuration},
                              {"status-period", required_argument, nullptr, kStatusPeriod},
                              {"stop-on-exit", no_argument, nullptr, kStopOnExit},
                              {nullptr, 0, nullptr, 0}};
  const SheriffCliParse error{std::nullopt, kSheriffExitError};
  SheriffCli cli;
  auto number = [](const char* opt, const char* text, double& value) {
    char* end = nullptr;
    value = std::strtod(text, &end);
    if (!end || *end != '\0' || value < 0) {
      std::fprintf(stderr, "procman-sheriff: %s needs a non-negative number, got '%s'\n", opt, text);
      return false;
    }
    return true;
  };
  optind = 0;  // getopt's state is global: start afresh on every command line
  int c;
  while ((c = getopt_long(argc, argv, "hu:", long_opts, nullptr)) >= 0) {
    switch (c) {
      case 'h':
        printSheriffUsage(stdout);
        return {std::nullopt, kSheriffExitOk};
      case 'u':
        cli.options.lcm_url = optarg;
        break;
      case kStartAll:
        cli.start_all = true;
        break;
      case kStopAll:
        cli.stop_all = true;
        break;
      case kRestartAll:
        cli.restart_all = true;
        break;
      case kStart:
        cli.starts.push_back(optarg);
        break;
      case kStop:
        cli.stops.push_back(optarg);
        break;
      case kRestart:
        cli.restarts.push_back(optarg);
        break;
      case kScript:
        if (!cli.script.empty()) {
          std::fprintf(stderr, "procman-sheriff: only one --script\n");
          return error;
        }
        cli.script = optarg;
        break;
      case kStatus:
        cli.status = true;
        break;
      case kFollow:
        cli.follows.push_back(optarg);
        break;
      case kKeep:
        cli.keep = true;
        break;
      case kCheck:
        cli.check = true;
        break;
      case kConfig:
        cli.config_path = optarg;
        break;
      case kId:
        cli.options.sheriff_id = optarg;
        break;
      case kDefaultDeputy:
        cli.options.default_deputy = optarg;
        break;
      case kTimeout:
        if (!number("--timeout", optarg, cli.timeout_s)) return error;
        break;
      case kWait:
        if (std::strcmp(optarg, "started") == 0) {
          cli.wait_mode = SheriffCli::Wait::kStarted;
        } else if (std::strcmp(optarg, "running") == 0) {
          cli.wait_mode = SheriffCli::Wait::kRunning;
        } else if (std::strcmp(optarg, "none") == 0) {
          cli.wait_mode = SheriffCli::Wait::kNone;
        } else {
          std::fprintf(stderr, "procman-sheriff: --wait must be started, running or none\n");
          return error;
        }
        break;
      case kDuration:
        if (!number("--duration", optarg, cli.duration_s)) return error;
        break;
      case kStatusPeriod:
        if (!number("--status-period", optarg, cli.status_period_s)) return error;
        break;
      case kStopOnExit:
        cli.stop_on_exit = true;
        break;
      default:
        printSheriffUsage(stderr);
        return error;
    }
  }
  if (optind < argc) {
    std::fprintf(stderr, "procman-sheriff: unexpected argument '%s'\n", argv[optind]);
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
