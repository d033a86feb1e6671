// procman-sheriff: the headless procman sheriff. Loads a procman configuration, takes over the state the
// deputies report, starts/stops/restarts commands and groups or runs a script, prints a status table and
// follows output. See procman/README.md.
#include <getopt.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <set>
#include <string>
#include <vector>

#include "procman/sheriff.hpp"

namespace {

constexpr int kExitOk = 0;
constexpr int kExitError = 1;
constexpr int kExitTimeout = 3;

std::atomic<bool> g_stop{false};
void onSignal(int) { g_stop = true; }

void usage(FILE* out) {
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

}  // namespace

int main(int argc, char** argv) {
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
  std::string config_path, wait_mode = "started", script;
  ips::procman::SheriffOptions options;
  bool start_all = false, stop_all = false, restart_all = false, status = false, keep = false, check = false;
  bool stop_on_exit = false;
  std::vector<std::string> starts, stops, restarts, follows;
  double timeout_s = 15.0, duration_s = -1.0, status_period_s = 0.0;
  auto number = [](const char* opt, const char* text) {
    char* end = nullptr;
    const double v = std::strtod(text, &end);
    if (!end || *end != '\0' || v < 0) {
      std::fprintf(stderr, "procman-sheriff: %s needs a non-negative number, got '%s'\n", opt, text);
      std::exit(kExitError);
    }
    return v;
  };
  int c;
  while ((c = getopt_long(argc, argv, "hu:", long_opts, nullptr)) >= 0) {
    switch (c) {
      case 'h':
        usage(stdout);
        return kExitOk;
      case 'u':
        options.lcm_url = optarg;
        break;
      case kStartAll:
        start_all = true;
        break;
      case kStopAll:
        stop_all = true;
        break;
      case kRestartAll:
        restart_all = true;
        break;
      case kStart:
        starts.push_back(optarg);
        break;
      case kStop:
        stops.push_back(optarg);
        break;
      case kRestart:
        restarts.push_back(optarg);
        break;
      case kScript:
        if (!script.empty()) {
          std::fprintf(stderr, "procman-sheriff: only one --script\n");
          return kExitError;
        }
        script = optarg;
        break;
      case kStatus:
        status = true;
        break;
      case kFollow:
        follows.push_back(optarg);
        break;
      case kKeep:
        keep = true;
        break;
      case kCheck:
        check = true;
        break;
      case kConfig:
        config_path = optarg;
        break;
      case kId:
        options.sheriff_id = optarg;
        break;
      case kDefaultDeputy:
        options.default_deputy = optarg;
        break;
      case kTimeout:
        timeout_s = number("--timeout", optarg);
        break;
      case kWait:
        wait_mode = optarg;
        if (wait_mode != "started" && wait_mode != "running" && wait_mode != "none") {
          std::fprintf(stderr, "procman-sheriff: --wait must be started, running or none\n");
          return kExitError;
        }
        break;
      case kDuration:
        duration_s = number("--duration", optarg);
        break;
      case kStatusPeriod:
        status_period_s = number("--status-period", optarg);
        break;
      case kStopOnExit:
        stop_on_exit = true;
        break;
      default:
        usage(stderr);
        return kExitError;
    }
  }
  if (optind < argc) {
    std::fprintf(stderr, "procman-sheriff: unexpected argument '%s'\n", argv[optind]);
    return kExitError;
  }
  const bool orders_needed = start_all || stop_all || restart_all || !starts.empty() || !stops.empty() ||
                             !restarts.empty() || !script.empty() || keep;
  if (!orders_needed && !status && follows.empty() && !check) {
    usage(stderr);
    return kExitError;
  }
  if ((orders_needed || check) && config_path.empty()) {
    std::fprintf(stderr, "procman-sheriff: this action needs --config FILE\n");
    return kExitError;
  }

  try {
    ips::procman::SheriffConfig config;
    if (!config_path.empty()) config = ips::procman::loadSheriffConfig(config_path);
    if (check) {
      std::printf("%s: %zu commands, %zu groups, %zu scripts\n", config_path.c_str(), config.commands.size(),
                  config.groups.size(), config.scripts.size());
      for (const auto& cmd : config.commands)
        std::printf("cmd %s deputy=%s group=%s auto_respawn=%d stop_signal=%d stop_time_allowed=%g exec=%s\n",
                    cmd.id.c_str(), cmd.deputy.empty() ? "(default)" : cmd.deputy.c_str(),
                    cmd.group.empty() ? "-" : cmd.group.c_str(), cmd.auto_respawn ? 1 : 0, cmd.stop_signal,
                    cmd.stop_time_allowed, cmd.exec.c_str());
      for (const auto& s : config.scripts) {
        std::printf("script %s:\n", s.name.c_str());
        for (const auto& a : s.actions) std::printf("  %s;\n", a.describe().c_str());
      }
      return kExitOk;
    }
    options.observe_only = !orders_needed && !stop_on_exit;
    ips::procman::Sheriff sheriff(config, options);
    std::signal(SIGINT, onSignal);
    std::signal(SIGTERM, onSignal);
    sheriff.setInterruptFlag(&g_stop);

    // Take over the deputies' state first (only those the actions need; all of them for --status).
    std::vector<std::string> wanted = sheriff.configuredDeputies();
    if (!wanted.empty()) {
      const auto missing = sheriff.waitForDeputies(wanted, timeout_s);
      if (!missing.empty()) {
        std::string list;
        for (const auto& m : missing) list += (list.empty() ? "" : ", ") + m;
        std::fprintf(stderr,
                     "procman-sheriff: no report from deputy %s within %.0f s (is procman-deputy running "
                     "with that id and the same LCM URL?)\n",
                     list.c_str(), timeout_s);
        if (orders_needed) return kExitTimeout;
      }
    } else {
      sheriff.waitForDeputies({}, 0);
      sheriff.spinFor(std::min(timeout_s, 1.5));  // observe: deputies report once per second
    }

    using ips::procman::Sheriff;
    using ips::procman::SheriffCommand;
    auto waitAll = [&](const std::vector<SheriffCommand*>& cmds, bool (*ok)(const SheriffCommand&), const char* what) {
      if (sheriff.spinUntil(
              [&] {
                for (auto* c : cmds)
                  if (!ok(*c)) return false;
                return true;
              },
              timeout_s))
        return true;
      for (auto* c : cmds)
        if (!ok(*c))
          std::fprintf(stderr, "procman-sheriff: %s on deputy %s not %s within %.0f s (status %s)\n",
                       c->config.id.c_str(), c->config.deputy.c_str(), what, timeout_s,
                       ips::procman::statusName(ips::procman::commandStatus(*c)));
      return false;
    };
    bool ok = true;
    std::vector<SheriffCommand*> to_stop, to_start, to_restart;
    auto add = [&](std::vector<SheriffCommand*>& list, const std::vector<SheriffCommand*>& more) {
      for (auto* m : more)
        if (std::find(list.begin(), list.end(), m) == list.end()) list.push_back(m);
    };
    if (stop_all) add(to_stop, sheriff.select("everything", ""));
    for (const auto& n : stops) add(to_stop, sheriff.select("", n));
    if (start_all) add(to_start, sheriff.select("everything", ""));
    for (const auto& n : starts) add(to_start, sheriff.select("", n));
    if (restart_all) add(to_restart, sheriff.select("everything", ""));
    for (const auto& n : restarts) add(to_restart, sheriff.select("", n));
    if (!to_stop.empty()) {
      sheriff.stop(to_stop);
      if (wait_mode != "none") ok = waitAll(to_stop, &Sheriff::isStopped, "stopped") && ok;
    }
    for (auto* list : {&to_start, &to_restart}) {
      if (list->empty()) continue;
      if (list == &to_start)
        sheriff.start(*list);
      else
        sheriff.restart(*list);
      if (wait_mode == "started") ok = waitAll(*list, &Sheriff::hasStarted, "started") && ok;
      if (wait_mode == "running") ok = waitAll(*list, &Sheriff::isRunning, "running") && ok;
    }
    if (!script.empty()) {
      try {
        sheriff.runScript(script, timeout_s, std::cout);
      } catch (const std::runtime_error& e) {
        std::fprintf(stderr, "procman-sheriff: %s\n", e.what());
        ok = false;
      }
    }
    if (status) {
      sheriff.spinFor(0.2);  // let the deputies report what the actions changed
      sheriff.printStatus(std::cout);
    }
    if (!follows.empty() || keep) {
      std::set<std::string> followed(follows.begin(), follows.end());
      const bool prefix = followed.size() > 1;
      sheriff.setOutputHandler([&](const std::string&, const std::string& id, const std::string& text) {
        if (!followed.count(id)) return;
        if (!prefix) {
          std::fwrite(text.data(), 1, text.size(), stdout);
        } else {
          size_t start = 0;
          while (start < text.size()) {
            const size_t nl = text.find('\n', start);
            const size_t end = nl == std::string::npos ? text.size() : nl + 1;
            std::printf("[%s] %.*s", id.c_str(), static_cast<int>(end - start), text.data() + start);
            start = end;
          }
        }
        std::fflush(stdout);
      });
      const auto begin = std::chrono::steady_clock::now();
      auto next_table = begin + std::chrono::duration<double>(status_period_s);
      while (!g_stop) {
        const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
        if (duration_s >= 0 && elapsed >= duration_s) break;
        sheriff.spinFor(0.1);
        if (keep && status_period_s > 0 && std::chrono::steady_clock::now() >= next_table) {
          sheriff.printStatus(std::cout);
          std::cout << std::endl;
          next_table += std::chrono::duration<double>(status_period_s);
        }
      }
      if (stop_on_exit) {
        g_stop = false;  // a second SIGINT/SIGTERM abandons the stop
        auto all = sheriff.select("everything", "");
        sheriff.stop(all);
        ok = waitAll(all, &Sheriff::isStopped, "stopped") && ok;
      }
    }
    return ok ? kExitOk : kExitTimeout;
  } catch (const ips::procman::ConfigError& e) {
    std::fprintf(stderr, "procman-sheriff: %s\n", e.what());
    return kExitError;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "procman-sheriff: %s\n", e.what());
    return kExitError;
  }
}
