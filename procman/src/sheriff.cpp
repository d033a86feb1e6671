#include "procman/sheriff.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <iomanip>
#include <random>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "procman/clock.hpp"
#include "procman/deputy.hpp"
#include "procman_lcm/discovery_t.hpp"
#include "procman_lcm/orders_t.hpp"

namespace ips::procman {
namespace {

std::string hostName() {
  char host[256] = {0};
  gethostname(host, sizeof host - 1);
  return host;
}

}  // namespace

const char* statusName(CommandStatus s) {
  switch (s) {
    case CommandStatus::kUnknown:
      return "Unknown";
    case CommandStatus::kTryingToStart:
      return "Starting";
    case CommandStatus::kRunning:
      return "Running";
    case CommandStatus::kRestarting:
      return "Restarting";
    case CommandStatus::kTryingToStop:
      return "Stopping";
    case CommandStatus::kStoppedOk:
      return "Stopped(OK)";
    case CommandStatus::kStoppedError:
      return "Stopped(Error)";
  }
  return "?";
}

CommandStatus commandStatus(const SheriffCommand& c) {
  if (!c.reported) return CommandStatus::kUnknown;
  if (c.desired_runid != c.actual_runid && !c.force_quit)
    return c.pid == 0 ? CommandStatus::kTryingToStart : CommandStatus::kRestarting;
  if (c.pid > 0) return c.force_quit ? CommandStatus::kTryingToStop : CommandStatus::kRunning;
  if (c.exit_code == 0) return CommandStatus::kStoppedOk;
  // Ended by the stop we asked for: not an error.
  if (c.force_quit && WIFSIGNALED(c.exit_code)) {
    const int sig = WTERMSIG(c.exit_code);
    if (sig == SIGTERM || sig == SIGINT || sig == SIGKILL || sig == c.config.stop_signal)
      return CommandStatus::kStoppedOk;
  }
  return CommandStatus::kStoppedError;
}

std::string describeWaitStatus(int32_t status) {
  if (WIFEXITED(status)) return WEXITSTATUS(status) == 0 ? "0" : "exit(" + std::to_string(WEXITSTATUS(status)) + ")";
  if (WIFSIGNALED(status)) {
    const char* abbrev = sigabbrev_np(WTERMSIG(status));
    return abbrev ? std::string("SIG") + abbrev : "signal(" + std::to_string(WTERMSIG(status)) + ")";
  }
  return "status(" + std::to_string(status) + ")";
}

Sheriff::Sheriff(SheriffConfig config, SheriffOptions options) : opt_(std::move(options)), config_(std::move(config)) {
  if (opt_.sheriff_id.empty()) opt_.sheriff_id = "procman-sheriff@" + hostName();
  if (opt_.default_deputy.empty()) opt_.default_deputy = hostName();
  for (const auto& c : config_.commands) {
    SheriffCommand cmd;
    cmd.config = c;
    if (cmd.config.deputy.empty()) cmd.config.deputy = opt_.default_deputy;
    commands_.push_back(cmd);
  }
  for (const auto& c : commands_) {
    if (c.config.deputy == opt_.sheriff_id)
      throw ConfigError("sheriff id '" + opt_.sheriff_id + "' equals a deputy id; choose another --id");
    deputies_[c.config.deputy].id = c.config.deputy;
    deputies_[c.config.deputy].configured = true;
  }
  lcm_ = std::make_unique<lcm::LCM>(opt_.lcm_url);
  if (!lcm_->good()) throw std::runtime_error("procman-sheriff: cannot initialise LCM with URL '" + opt_.lcm_url + "'");
  subscriber_ = std::make_unique<SafeSubscriber>(
      *lcm_, [](const std::string& channel, const std::string& reason, uint64_t dropped) {
        for (uint64_t p = 1; p <= dropped; p *= 10)
          if (p == dropped)
            std::fprintf(stderr, "procman-sheriff: dropped a message on %s (%s); %llu dropped so far on it\n",
                         channel.c_str(), reason.c_str(), static_cast<unsigned long long>(dropped));
      });
  subscriber_->subscribe(kInfoChannel, &Sheriff::onInfo, this);
  subscriber_->subscribe(kOutputChannel, &Sheriff::onOutput, this);
}

std::vector<std::string> Sheriff::configuredDeputies() const {
  std::vector<std::string> out;
  for (const auto& c : commands_)
    if (std::find(out.begin(), out.end(), c.config.deputy) == out.end()) out.push_back(c.config.deputy);
  return out;
}

void Sheriff::onInfo(const lcm::ReceiveBuffer*, const std::string&, const procman_lcm::deputy_info_t* msg) {
  DeputyView& d = deputies_[msg->deputy_id];
  d.id = msg->deputy_id;
  d.seen = true;
  d.last_info_us = nowUs();
  d.cpu_load = msg->cpu_load;
  d.mem_total_bytes = msg->phys_mem_total_bytes;
  d.mem_free_bytes = msg->phys_mem_free_bytes;
  d.unknown_commands.clear();
  std::set<std::string> reported;
  for (const auto& s : msg->cmds) {
    reported.insert(s.cmd.command_id);
    auto it = std::find_if(commands_.begin(), commands_.end(), [&](const SheriffCommand& c) {
      return c.config.deputy == msg->deputy_id && c.config.id == s.cmd.command_id;
    });
    if (it == commands_.end()) {
      d.unknown_commands.push_back(s);
      continue;
    }
    it->reported = true;
    it->pid = s.pid;
    it->actual_runid = s.actual_runid;
    it->exit_code = s.exit_code;
    it->cpu_usage = s.cpu_usage;
    it->mem_rss_bytes = s.mem_rss_bytes;
    it->mem_vsize_bytes = s.mem_vsize_bytes;
    if (!d.adopted) {
      // Take over what the deputy does: a stopped command stays stopped, except an auto-respawn command,
      // which may be between two runs (the deputy is about to respawn it) and is left alone as upstream's
      // sheriff does; with desired = actual run id the deputy does not start it if it was stopped for good.
      it->desired_runid = s.actual_runid;
      it->force_quit = s.pid == 0 && !it->config.auto_respawn;
    }
  }
  for (auto& c : commands_) {
    if (c.config.deputy != msg->deputy_id) continue;
    if (!reported.count(c.config.id)) c.reported = false;
    // A restart is a stop and then a start on the next order: send it now rather than at the next period.
    if (d.adopted && c.reported && c.pid == 0 && !c.force_quit && c.desired_runid != c.actual_runid)
      orders_dirty_ = true;
  }
  if (!d.adopted) {
    d.adopted = true;
    orders_dirty_ = true;
  }
}

void Sheriff::onOutput(const lcm::ReceiveBuffer*, const std::string&, const procman_lcm::output_t* msg) {
  if (!output_handler_) return;
  const size_t n = std::min(msg->command_ids.size(), msg->text.size());
  for (size_t i = 0; i < n; ++i) output_handler_(msg->deputy_id, msg->command_ids[i], msg->text[i]);
}

void Sheriff::sendOrders() {
  if (opt_.observe_only) return;
  const int64_t now = nowUs();
  for (const auto& [deputy_id, d] : deputies_) {
    // Never order a deputy whose state we have not taken over, nor one outside our configuration (empty
    // orders would stop everything it runs for another sheriff).
    if (!d.adopted || !d.configured) continue;
    procman_lcm::orders_t orders;
    orders.utime = now;
    orders.deputy_id = deputy_id;
    orders.sheriff_id = opt_.sheriff_id;
    for (const auto& c : commands_) {
      if (c.config.deputy != deputy_id) continue;
      procman_lcm::cmd_desired_t desired;
      desired.cmd.command_id = c.config.id;
      desired.cmd.exec_str = c.config.exec;
      desired.cmd.group = c.config.group;
      desired.cmd.auto_respawn = c.config.auto_respawn;
      desired.cmd.stop_signal = static_cast<int8_t>(c.config.stop_signal);
      desired.cmd.stop_time_allowed = static_cast<float>(c.config.stop_time_allowed);
      desired.desired_runid = c.desired_runid;
      desired.force_quit = c.force_quit;
      orders.cmds.push_back(desired);
    }
    orders.ncmds = static_cast<int32_t>(orders.cmds.size());
    lcm_->publish(kOrdersChannel, &orders);
  }
  last_orders_us_ = now;
  orders_dirty_ = false;
}

void Sheriff::handle(int timeout_ms) {
  lcm_->handleTimeout(timeout_ms);
  if (orders_dirty_ || nowUs() - last_orders_us_ >= static_cast<int64_t>(opt_.orders_period_s * 1e6)) sendOrders();
}

std::vector<std::string> Sheriff::waitForDeputies(const std::vector<std::string>& wanted, double timeout_s) {
  procman_lcm::discovery_t msg;
  msg.utime = nowUs();
  msg.transmitter_id = opt_.sheriff_id;
  msg.nonce = static_cast<int64_t>(std::random_device{}()) << 16 ^ getpid();
  lcm_->publish(kDiscoverChannel, &msg);
  auto missing = [&] {
    std::vector<std::string> out;
    for (const auto& id : wanted) {
      auto it = deputies_.find(id);
      if (it == deputies_.end() || !it->second.adopted) out.push_back(id);
    }
    return out;
  };
  const int64_t deadline = nowUs() + static_cast<int64_t>(timeout_s * 1e6);
  int64_t next_discovery = nowUs() + 1000000;
  while (!missing().empty() && nowUs() < deadline && !(interrupted_ && interrupted_->load())) {
    handle(50);
    if (nowUs() >= next_discovery) {  // a deputy that was still starting did not hear the first one
      msg.utime = nowUs();
      lcm_->publish(kDiscoverChannel, &msg);
      next_discovery = nowUs() + 1000000;
    }
  }
  return missing();
}

std::vector<SheriffCommand*> Sheriff::select(const std::string& kind, const std::string& name) {
  std::vector<SheriffCommand*> out;
  for (auto& c : commands_) {
    const bool by_cmd = (kind == "cmd" || kind.empty()) && c.config.id == name;
    const bool by_group = (kind == "group" || kind.empty()) && !name.empty() && groupContains(name, c.config.group);
    if (kind == "everything" || by_cmd || by_group) out.push_back(&c);
  }
  if (out.empty())
    throw ConfigError("no " + (kind.empty() ? std::string("command or group") : kind) + " '" + name +
                      "' in the configuration");
  return out;
}

void Sheriff::start(const std::vector<SheriffCommand*>& cmds) {
  for (SheriffCommand* c : cmds) {
    if (c->pid > 0 && !c->force_quit) continue;  // already running
    c->desired_runid = std::max(c->desired_runid, c->actual_runid) + 1;
    c->force_quit = false;
  }
  orders_dirty_ = true;
  sendOrders();
}

void Sheriff::stop(const std::vector<SheriffCommand*>& cmds) {
  for (SheriffCommand* c : cmds) c->force_quit = true;
  orders_dirty_ = true;
  sendOrders();
}

void Sheriff::restart(const std::vector<SheriffCommand*>& cmds) {
  for (SheriffCommand* c : cmds) {
    c->desired_runid = std::max(c->desired_runid, c->actual_runid) + 1;
    c->force_quit = false;
  }
  orders_dirty_ = true;
  sendOrders();
}

bool Sheriff::spinUntil(const std::function<bool()>& done, double timeout_s) {
  const int64_t deadline = nowUs() + static_cast<int64_t>(timeout_s * 1e6);
  while (!done()) {
    if (interrupted_ && interrupted_->load()) return false;
    const int64_t left_ms = (deadline - nowUs()) / 1000;
    if (left_ms <= 0) return done();
    handle(static_cast<int>(std::min<int64_t>(left_ms, 50)));
  }
  return true;
}

bool Sheriff::waitStatus(const std::vector<SheriffCommand*>& cmds, const std::string& status, double timeout_s) {
  return spinUntil(
      [&] {
        return std::all_of(cmds.begin(), cmds.end(), [&](const SheriffCommand* c) {
          return status == "running" ? isRunning(*c) : isStopped(*c);
        });
      },
      timeout_s);
}

void Sheriff::runScript(const std::string& name, double wait_timeout_s, std::ostream& log) {
  runScriptDepth(name, wait_timeout_s, log, 0);
}

void Sheriff::runScriptDepth(const std::string& name, double wait_timeout_s, std::ostream& log, int depth) {
  if (depth > 16) throw std::runtime_error("script '" + name + "': run_script nested too deep (a loop?)");
  const Script* script = config_.findScript(name);
  if (!script) throw ConfigError("no script '" + name + "' in the configuration");
  for (const ScriptAction& a : script->actions) {
    log << "script " << name << ": " << a.describe() << std::endl;
    switch (a.type) {
      case ActionType::kStart:
      case ActionType::kStop:
      case ActionType::kRestart: {
        auto cmds = select(a.target_kind, a.target);
        if (a.type == ActionType::kStart)
          start(cmds);
        else if (a.type == ActionType::kStop)
          stop(cmds);
        else
          restart(cmds);
        if (!a.wait_status.empty() && !waitStatus(cmds, a.wait_status, wait_timeout_s))
          throw std::runtime_error("script '" + name + "': timed out on: " + a.describe());
        break;
      }
      case ActionType::kWaitMs:
        spinFor(a.delay_ms * 1e-3);
        break;
      case ActionType::kWaitStatus:
        if (!waitStatus(select(a.target_kind, a.target), a.wait_status, wait_timeout_s))
          throw std::runtime_error("script '" + name + "': timed out on: " + a.describe());
        break;
      case ActionType::kRunScript:
        runScriptDepth(a.target, wait_timeout_s, log, depth + 1);
        break;
    }
  }
}

void Sheriff::printStatus(std::ostream& out) const {
  const int64_t now = nowUs();
  out << std::left << std::setw(14) << "DEPUTY" << std::setw(10) << "SEEN_S" << std::setw(8) << "CPU%" << std::setw(12)
      << "MEM_FREE_MB"
      << "\n";
  for (const auto& [id, d] : deputies_) {
    std::ostringstream seen, cpu, mem;
    if (d.seen) {
      seen << std::fixed << std::setprecision(1) << (now - d.last_info_us) * 1e-6;
      cpu << std::fixed << std::setprecision(1) << d.cpu_load * 100.0;
      mem << (d.mem_free_bytes >> 20);
    } else {
      seen << "never";
      cpu << "-";
      mem << "-";
    }
    out << std::left << std::setw(14) << id << std::setw(10) << seen.str() << std::setw(8) << cpu.str() << std::setw(12)
        << mem.str() << "\n";
  }
  out << "\n"
      << std::left << std::setw(14) << "DEPUTY" << std::setw(16) << "COMMAND" << std::setw(14) << "GROUP"
      << std::setw(16) << "STATUS" << std::setw(8) << "PID" << std::setw(6) << "RUN" << std::setw(10) << "EXIT"
      << std::setw(7) << "CPU%" << std::setw(8) << "RSS_MB"
      << "RESPAWN\n";
  auto row = [&](const std::string& deputy, const std::string& id, const std::string& group, const std::string& status,
                 int pid, int run, int exit_code, float cpu, int64_t rss, bool respawn) {
    std::ostringstream cpu_s, rss_s;
    cpu_s << std::fixed << std::setprecision(1) << cpu * 100.0;
    rss_s << std::fixed << std::setprecision(1) << rss / 1048576.0;
    out << std::left << std::setw(14) << deputy << std::setw(16) << id << std::setw(14) << (group.empty() ? "-" : group)
        << std::setw(16) << status << std::setw(8) << pid << std::setw(6) << run << std::setw(10)
        << describeWaitStatus(exit_code) << std::setw(7) << cpu_s.str() << std::setw(8) << rss_s.str()
        << (respawn ? "yes" : "no") << "\n";
  };
  for (const auto& c : commands_)
    row(c.config.deputy, c.config.id, c.config.group, statusName(commandStatus(c)), c.pid, c.actual_runid, c.exit_code,
        c.cpu_usage, c.mem_rss_bytes, c.config.auto_respawn);
  for (const auto& [id, d] : deputies_)
    for (const auto& s : d.unknown_commands)
      row(id, s.cmd.command_id, s.cmd.group, s.pid > 0 ? "Running*" : "Stopped*", s.pid, s.actual_runid, s.exit_code,
          s.cpu_usage, s.mem_rss_bytes, s.cmd.auto_respawn);
  bool any_unknown = false;
  for (const auto& [id, d] : deputies_) any_unknown = any_unknown || !d.unknown_commands.empty();
  if (any_unknown) out << "(* reported by the deputy, not in this configuration)\n";
  out.flush();
}

}  // namespace ips::procman
