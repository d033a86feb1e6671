#include "procman/deputy.hpp"

#include <poll.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <random>
#include <set>
#include <stdexcept>
#include <vector>

#include "procman/clock.hpp"

namespace ips::procman {
namespace {

std::string stamp() {
  char buf[64];
  const std::time_t t = std::time(nullptr);
  struct tm tm_utc;
  gmtime_r(&t, &tm_utc);
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm_utc);
  return buf;
}

const int kHandledSignals[] = {SIGCHLD, SIGINT, SIGTERM, SIGHUP, SIGQUIT};

}  // namespace

Deputy::Deputy(DeputyOptions options) : opt_(std::move(options)) {
  if (opt_.deputy_id.empty()) {
    char host[256] = {0};
    gethostname(host, sizeof host - 1);
    opt_.deputy_id = host;
  }
  lcm_ = std::make_unique<lcm::LCM>(opt_.lcm_url);
  if (!lcm_->good()) throw std::runtime_error("procman-deputy: cannot initialise LCM with URL '" + opt_.lcm_url + "'");

  sigset_t mask;
  sigemptyset(&mask);
  for (int s : kHandledSignals) sigaddset(&mask, s);
  if (sigprocmask(SIG_BLOCK, &mask, nullptr) != 0) throw std::runtime_error("procman-deputy: sigprocmask failed");
  signal_fd_ = signalfd(-1, &mask, SFD_NONBLOCK | SFD_CLOEXEC);
  if (signal_fd_ < 0) throw std::runtime_error(std::string("procman-deputy: signalfd: ") + std::strerror(errno));

  std::random_device rd;
  nonce_ = (static_cast<int64_t>(rd()) << 32) ^ static_cast<int64_t>(rd()) ^ static_cast<int64_t>(getpid());
  start_us_ = nowUs();
  pending_output_.deputy_id = opt_.deputy_id;
  pending_output_.num_commands = 0;

  subscriber_ = std::make_unique<SafeSubscriber>(
      *lcm_, [this](const std::string& channel, const std::string& reason, uint64_t dropped) {
        // Noted at the 1st, 10th, 100th, ... so that a flood of bad packets does not flood the output.
        for (uint64_t p = 1; p <= dropped; p *= 10)
          if (p == dropped)
            note("", "dropped a message on " + channel + " (" + reason + "); " + std::to_string(dropped) +
                         " dropped so far on it");
      });
  info_sub_ = subscriber_->subscribe(kInfoChannel, &Deputy::onInfo, this);
  subscriber_->subscribe(kDiscoverChannel, &Deputy::onDiscovery, this);
  ProcessTableOptions table_options;
  table_options.respawn_min_ms = opt_.respawn_min_ms;
  table_options.respawn_max_ms = opt_.respawn_max_ms;
  table_options.respawn_backoff_factor = opt_.respawn_backoff_factor;
  table_options.verbose = opt_.verbose;
  table_ = std::make_unique<ProcessTable>(
      table_options, [this](const std::string& id, const std::string& text) { transmit(id, text); },
      [this](const std::string& id, const std::string& text) { note(id, text); });
}

Deputy::~Deputy() {
  table_.reset();  // kills what still runs
  if (signal_fd_ >= 0) close(signal_fd_);
}

void Deputy::note(const std::string& command_id, const std::string& text) {
  std::fprintf(stderr, "%s procman-deputy[%s] %s%s%s", stamp().c_str(), opt_.deputy_id.c_str(),
               command_id.empty() ? "" : ("[" + command_id + "] ").c_str(), text.c_str(),
               (!text.empty() && text.back() == '\n') ? "" : "\n");
  transmit(command_id, "procman-deputy: " + text + ((!text.empty() && text.back() == '\n') ? "" : "\n"));
}

void Deputy::transmit(const std::string& command_id, const std::string& text) {
  if (text.empty()) return;
  bool found = false;
  for (int i = 0; i < pending_output_.num_commands; ++i) {
    if (pending_output_.command_ids[i] == command_id) {
      pending_output_.text[i] += text;
      found = true;
      break;
    }
  }
  if (!found) {
    pending_output_.command_ids.push_back(command_id);
    pending_output_.text.push_back(text);
    pending_output_.num_commands = static_cast<int16_t>(pending_output_.command_ids.size());
  }
  pending_bytes_ += text.size();
  flushOutput(false);
}

void Deputy::flushOutput(bool force) {
  if (pending_bytes_ == 0 && pending_output_.num_commands == 0) return;
  const int64_t now = nowUs();
  if (!force && pending_bytes_ <= opt_.output_flush_bytes && now - last_flush_us_ < opt_.output_flush_ms * 1000LL)
    return;
  pending_output_.utime = now;
  lcm_->publish(kOutputChannel, &pending_output_);
  pending_output_.command_ids.clear();
  pending_output_.text.clear();
  pending_output_.num_commands = 0;
  pending_bytes_ = 0;
  last_flush_us_ = now;
}

void Deputy::onDiscovery(const lcm::ReceiveBuffer*, const std::string&, const procman_lcm::discovery_t* msg) {
  if (discovering_) {
    if (msg->transmitter_id == opt_.deputy_id && msg->nonce != nonce_) {
      std::fprintf(stderr, "%s procman-deputy: another deputy with id '%s' is running; exiting\n", stamp().c_str(),
                   opt_.deputy_id.c_str());
      exit_code_ = kExitConflict;
      quit_ = true;
    }
  } else {
    publishInfo();  // a sheriff (or a starting deputy) asks who is there
  }
}

void Deputy::onInfo(const lcm::ReceiveBuffer*, const std::string&, const procman_lcm::deputy_info_t* msg) {
  if (discovering_ && msg->deputy_id == opt_.deputy_id) {
    std::fprintf(stderr, "%s procman-deputy: another deputy with id '%s' is running; exiting\n", stamp().c_str(),
                 opt_.deputy_id.c_str());
    exit_code_ = kExitConflict;
    quit_ = true;
  }
}

void Deputy::discoveryTick(int64_t now) {
  if (!discovering_ || now < next_discovery_us_) return;
  if (now < start_us_ + opt_.discovery_ms * 1000LL) {
    procman_lcm::discovery_t msg;
    msg.utime = now;
    msg.transmitter_id = opt_.deputy_id;
    msg.nonce = nonce_;
    lcm_->publish(kDiscoverChannel, &msg);
    next_discovery_us_ = std::min(now + opt_.discovery_period_ms * 1000LL, start_us_ + opt_.discovery_ms * 1000LL);
    return;
  }
  // Discovery is over: no conflicting deputy; from now on take orders.
  discovering_ = false;
  lcm_->unsubscribe(info_sub_);
  info_sub_ = nullptr;
  orders_sub_ = subscriber_->subscribe(kOrdersChannel, &Deputy::onOrders, this);
  if (opt_.verbose)
    std::fprintf(stderr, "%s procman-deputy[%s]: listening for orders\n", stamp().c_str(), opt_.deputy_id.c_str());
  table_->sampleCpuAndMemory();
  publishInfo();
  next_info_us_ = now + opt_.info_period_ms * 1000LL;
}

void Deputy::onOrders(const lcm::ReceiveBuffer*, const std::string&, const procman_lcm::orders_t* orders) {
  if (exiting_ || quit_) return;
  if (orders->deputy_id != opt_.deputy_id) {
    if (opt_.verbose)
      std::fprintf(stderr, "%s procman-deputy: ignoring orders for deputy '%s'\n", stamp().c_str(),
                   orders->deputy_id.c_str());
    return;
  }
  const int64_t now = nowUs();
  const double age_s = static_cast<double>(now - orders->utime) * 1e-6;
  if (age_s > opt_.max_order_age_s) {
    char buf[200];
    std::snprintf(buf, sizeof buf, "ignoring stale orders from sheriff '%s' (%.0f s old); check the clocks",
                  orders->sheriff_id.c_str(), age_s);
    note("", buf);
    return;
  }

  bool changed = false;
  std::set<std::string> listed;
  for (const auto& desired : orders->cmds) {
    const procman_lcm::cmd_t& order = desired.cmd;
    if (order.command_id.empty()) {  // the empty id marks the deputy's own output
      note("", "ignoring a command with an empty id in orders from '" + orders->sheriff_id + "'");
      continue;
    }
    CommandSpec spec;
    spec.id = order.command_id;
    spec.exec_str = order.exec_str;
    spec.group = order.group;
    spec.auto_respawn = order.auto_respawn;
    spec.stop_signal = order.stop_signal > 0 ? order.stop_signal : opt_.default_stop_signal;
    // A stop time that is not a number, negative or absurd would break the SIGKILL timer.
    spec.stop_time_allowed = std::isfinite(order.stop_time_allowed) && order.stop_time_allowed >= 0.f
                                 ? std::min(order.stop_time_allowed, opt_.max_stop_time_allowed_s)
                                 : 0.f;
    listed.insert(spec.id);
    changed = table_->apply(spec, desired.desired_runid, !desired.force_quit) || changed;
  }
  // Each order is the whole desired state: commands missing from it are stopped and forgotten.
  changed = table_->retainOnly(listed) || changed;
  if (changed) publishInfo();
}

void Deputy::handleTimers(int64_t now) {
  discoveryTick(now);
  if (table_->handleTimers(now)) publishInfo();
  if (!discovering_ && now >= next_info_us_) {
    table_->sampleCpuAndMemory();
    publishInfo();
    next_info_us_ = now + opt_.info_period_ms * 1000LL;
  }
  if (exiting_) {
    if (!table_->anyRunning()) {
      quit_ = true;
    } else if (now >= exit_deadline_us_) {
      table_->killAll();
      quit_ = true;
    }
  }
  flushOutput(false);
}

void Deputy::publishInfo() {
  procman_lcm::deputy_info_t msg;
  msg.utime = nowUs();
  msg.deputy_id = opt_.deputy_id;
  msg.cpu_load = table_->cpuLoad();
  const SystemTimes& sys = table_->system();
  msg.phys_mem_total_bytes = sys.mem_total_bytes;
  msg.phys_mem_free_bytes = sys.mem_free_bytes;
  msg.swap_total_bytes = sys.swap_total_bytes;
  msg.swap_free_bytes = sys.swap_free_bytes;
  for (const ProcessStatus& c : table_->status()) {
    procman_lcm::cmd_status_t s;
    s.cmd.command_id = c.spec.id;
    s.cmd.exec_str = c.spec.exec_str;
    s.cmd.group = c.spec.group;
    s.cmd.auto_respawn = c.spec.auto_respawn;
    s.cmd.stop_signal = static_cast<int8_t>(c.spec.stop_signal);
    s.cmd.stop_time_allowed = c.spec.stop_time_allowed;
    s.pid = c.pid;
    s.actual_runid = c.actual_runid;
    s.exit_code = c.exit_status;
    s.cpu_usage = c.cpu_usage;
    s.mem_vsize_bytes = c.mem_vsize_bytes;
    s.mem_rss_bytes = c.mem_rss_bytes;
    msg.cmds.push_back(s);
  }
  msg.ncmds = static_cast<int32_t>(msg.cmds.size());
  lcm_->publish(kInfoChannel, &msg);
}

void Deputy::beginExit() {
  if (exiting_) return;
  exiting_ = true;
  exit_deadline_us_ = nowUs() + static_cast<int64_t>(table_->stopAll() * 1e6);
  std::fprintf(stderr, "%s procman-deputy[%s]: stopping all commands and exiting\n", stamp().c_str(),
               opt_.deputy_id.c_str());
}

int Deputy::run() {
  next_discovery_us_ = start_us_;
  while (!quit_) {
    const int64_t now = nowUs();
    handleTimers(now);
    if (quit_) break;

    // Sleep until the next thing is due, at most one output-flush period.
    int64_t next = now + opt_.info_period_ms * 1000LL;
    if (discovering_)
      next = std::min(next, next_discovery_us_);
    else
      next = std::min(next, next_info_us_);
    if (pending_output_.num_commands > 0)
      next = std::min<int64_t>(next, last_flush_us_ + opt_.output_flush_ms * 1000LL);
    next = table_->nextDeadline(next);
    if (exiting_) next = std::min(next, exit_deadline_us_);
    const int timeout_ms = static_cast<int>(std::clamp<int64_t>((next - now + 999) / 1000, 0, 1000));

    std::vector<pollfd> fds;
    std::vector<std::string> fd_cmds;
    fds.push_back({signal_fd_, POLLIN, 0});
    fds.push_back({lcm_->getFileno(), POLLIN, 0});
    table_->pollFds(fds, fd_cmds);
    const int n = poll(fds.data(), fds.size(), timeout_ms);
    if (n < 0) {
      if (errno == EINTR) continue;
      std::fprintf(stderr, "procman-deputy: poll: %s\n", std::strerror(errno));
      return kExitError;
    }
    for (size_t i = 2; i < fds.size(); ++i)
      if (fds[i].revents) table_->readOutput(fd_cmds[i - 2]);  // before reaping, so the last words come first
    if (fds[0].revents & POLLIN) {
      signalfd_siginfo si;
      while (read(signal_fd_, &si, sizeof si) == static_cast<ssize_t>(sizeof si)) {
        if (si.ssi_signo == SIGCHLD) {
          if (table_->reap(nowUs())) publishInfo();
        } else {
          beginExit();
        }
      }
    }
    if (fds[1].revents & POLLIN) {
      if (lcm_->handleTimeout(0) < 0) {
        std::fprintf(stderr, "procman-deputy: LCM error\n");
        return kExitError;
      }
    }
  }
  flushOutput(true);
  return exit_code_;
}

}  // namespace ips::procman
