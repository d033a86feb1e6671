#include "procman/deputy.hpp"

#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <sys/prctl.h>
#include <sys/signalfd.h>
#include <sys/wait.h>
#include <termios.h>
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
#include <stdexcept>
#include <vector>

#include "procman/exec_string.hpp"
#include "procman/proc_info.hpp"

namespace ips::procman {
namespace {

// The deputy compares order stamps with its clock, as the protocol requires, so it uses the wall clock.
int64_t nowUs() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

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

struct Deputy::SystemSample {
  SystemTimes prev, cur;
  bool have_prev = false;
  float cpu_load = 0.f;
};

struct Deputy::Command {
  std::string id, exec_str, group;
  bool auto_respawn = false;
  int stop_signal = SIGINT;
  float stop_time_allowed = 7.f;

  pid_t pid = 0;
  int pty_fd = -1;
  bool pty_open = false;  // still worth polling (no hang-up seen yet)
  int exit_status = 0;    // raw wait status of the last run
  int32_t actual_runid = 0;
  bool should_be_running = false;
  bool remove_requested = false;

  int64_t last_start_us = 0;
  int respawn_backoff_ms = 0;
  int64_t respawn_at_us = 0;  // 0: none scheduled
  int64_t first_kill_us = 0;  // when the stop signal was sent; 0: not stopping
  bool sigkill_sent = false;

  ProcessTimes prev_times, cur_times;
  bool have_prev_times = false;
  float cpu_usage = 0.f;
};

Deputy::Deputy(DeputyOptions options) : opt_(std::move(options)), sys_(std::make_unique<SystemSample>()) {
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
                         " dropped so far");
      });
  info_sub_ = subscriber_->subscribe(kInfoChannel, &Deputy::onInfo, this);
  subscriber_->subscribe(kDiscoverChannel, &Deputy::onDiscovery, this);
  readSystemTimes(sys_->prev);
  sys_->have_prev = true;
}

Deputy::~Deputy() {
  for (auto& [id, cmd] : commands_) {
    if (cmd->pid > 0) kill(-cmd->pid, SIGKILL);
    if (cmd->pty_fd >= 0) close(cmd->pty_fd);
  }
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
  updateCpuAndMemory();
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
  for (const auto& order : orders->cmds) {
    procman_lcm::cmd_desired_t desired = order;
    procman_lcm::cmd_t& spec = desired.cmd;
    if (spec.command_id.empty()) {  // the empty id marks the deputy's own output
      note("", "ignoring a command with an empty id in orders from '" + orders->sheriff_id + "'");
      continue;
    }
    // A stop time that is not a number, negative or absurd would break the SIGKILL timer.
    if (!std::isfinite(spec.stop_time_allowed) || spec.stop_time_allowed < 0.f) spec.stop_time_allowed = 0.f;
    spec.stop_time_allowed = std::min(spec.stop_time_allowed, opt_.max_stop_time_allowed_s);
    auto it = commands_.find(spec.command_id);
    if (it == commands_.end()) {
      auto cmd = std::make_unique<Command>();
      cmd->id = spec.command_id;
      cmd->exec_str = spec.exec_str;
      cmd->group = spec.group;
      cmd->auto_respawn = spec.auto_respawn;
      cmd->stop_signal = spec.stop_signal > 0 ? spec.stop_signal : opt_.default_stop_signal;
      cmd->stop_time_allowed = spec.stop_time_allowed;
      cmd->respawn_backoff_ms = opt_.respawn_min_ms;
      it = commands_.emplace(spec.command_id, std::move(cmd)).first;
      if (opt_.verbose)
        std::fprintf(stderr, "%s procman-deputy: [%s] added: %s\n", stamp().c_str(), spec.command_id.c_str(),
                     spec.exec_str.c_str());
      changed = true;
    }
    Command& cmd = *it->second;
    // A new exec string, group or stop setting applies from the next start; it does not restart the command.
    if (cmd.exec_str != spec.exec_str || cmd.group != spec.group) changed = true;
    cmd.exec_str = spec.exec_str;
    cmd.group = spec.group;
    cmd.auto_respawn = spec.auto_respawn;
    cmd.stop_signal = spec.stop_signal > 0 ? spec.stop_signal : opt_.default_stop_signal;
    cmd.stop_time_allowed = spec.stop_time_allowed;
    cmd.remove_requested = false;
    cmd.should_be_running = !desired.force_quit;

    const bool running = cmd.pid > 0;
    if (!running && cmd.actual_runid != desired.desired_runid && cmd.should_be_running) {
      startCommand(cmd, desired.desired_runid);
      changed = true;
    } else if (running && (!cmd.should_be_running || desired.desired_runid != cmd.actual_runid)) {
      stopCommand(cmd);
      changed = true;
    } else {
      cmd.actual_runid = desired.desired_runid;
    }
  }

  // Each order is the whole desired state: commands missing from it are stopped and forgotten.
  std::vector<std::string> orphans;
  for (auto& [id, cmd] : commands_) {
    const bool listed = std::any_of(orders->cmds.begin(), orders->cmds.end(),
                                    [&](const procman_lcm::cmd_desired_t& d) { return d.cmd.command_id == id; });
    if (!listed) orphans.push_back(id);
  }
  for (const std::string& id : orphans) {
    Command& cmd = *commands_.at(id);
    changed = true;
    if (cmd.pid > 0) {
      cmd.remove_requested = true;
      stopCommand(cmd);
    } else {
      removeCommand(id);
    }
  }
  if (changed) publishInfo();
}

void Deputy::removeCommand(const std::string& id) {
  auto it = commands_.find(id);
  if (it == commands_.end()) return;
  if (it->second->pty_fd >= 0) close(it->second->pty_fd);
  if (opt_.verbose) std::fprintf(stderr, "%s procman-deputy: [%s] removed\n", stamp().c_str(), id.c_str());
  commands_.erase(it);
}

void Deputy::startCommand(Command& cmd, int32_t runid) {
  if (exiting_) return;
  cmd.should_be_running = true;
  cmd.respawn_at_us = 0;
  const int64_t now = nowUs();
  // Back-off: a command that dies soon after its start waits ever longer before the next respawn.
  const int64_t ms_since_start = (now - cmd.last_start_us) / 1000;
  if (ms_since_start < opt_.respawn_max_ms) {
    cmd.respawn_backoff_ms = std::min(opt_.respawn_max_ms, cmd.respawn_backoff_ms * opt_.respawn_backoff_factor);
  } else {
    const int64_t halvings = std::min<int64_t>(ms_since_start / std::max(1, opt_.respawn_max_ms), 30);
    cmd.respawn_backoff_ms = std::max(opt_.respawn_min_ms, cmd.respawn_backoff_ms >> halvings);
  }
  cmd.last_start_us = now;
  cmd.actual_runid = runid;
  cmd.first_kill_us = 0;
  cmd.sigkill_sent = false;
  cmd.have_prev_times = false;
  cmd.cpu_usage = 0.f;

  ExecSpec spec;
  try {
    spec = parseExecString(cmd.exec_str);
  } catch (const ExecStringError& e) {
    note(cmd.id, std::string("cannot start: ") + e.what());
    cmd.exit_status = 127 << 8;  // as a shell reports a command it cannot run
    return;
  }
  std::vector<char*> argv;
  for (auto& a : spec.argv) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);

  int master = -1;
  const pid_t deputy_pid = getpid();
  const pid_t pid = forkpty(&master, nullptr, nullptr, nullptr);
  if (pid < 0) {
    note(cmd.id, std::string("cannot start: forkpty: ") + std::strerror(errno));
    cmd.exit_status = 127 << 8;
    return;
  }
  if (pid == 0) {
    // Child: the pseudo-terminal is stdin/stdout/stderr and controlling terminal, in a new session (so the
    // whole process group can be signalled). Plain "\n" line ends, no echo.
    struct termios tio;
    if (tcgetattr(STDIN_FILENO, &tio) == 0) {
      tio.c_oflag &= ~static_cast<tcflag_t>(ONLCR);
      tio.c_lflag &= ~static_cast<tcflag_t>(ECHO);
      tcsetattr(STDIN_FILENO, TCSANOW, &tio);
    }
    // A deputy killed with SIGKILL cannot stop its commands; closing the pseudo-terminal only sends them SIGHUP,
    // which lcm-logger (log rotation) and others catch. The kernel kills the command when the deputy dies; if it
    // died before this line, the command must not start at all.
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (getppid() != deputy_pid) _exit(127);
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, nullptr);
    for (int s = 1; s < NSIG; ++s) signal(s, SIG_DFL);
    for (auto& [name, value] : spec.env) setenv(name.c_str(), value.c_str(), 1);
    close_range(3, ~0U, 0);  // the deputy's LCM sockets and other descriptors are not the command's business
    execvp(argv[0], argv.data());
    std::fprintf(stderr, "procman-deputy: cannot run '%s': %s\n", argv[0], std::strerror(errno));
    _exit(127);
  }
  fcntl(master, F_SETFL, fcntl(master, F_GETFL) | O_NONBLOCK);
  fcntl(master, F_SETFD, FD_CLOEXEC);
  if (cmd.pty_fd >= 0) close(cmd.pty_fd);
  cmd.pty_fd = master;
  cmd.pty_open = true;
  cmd.pid = pid;
  if (opt_.verbose)
    std::fprintf(stderr, "%s procman-deputy: [%s] started pid %d run %d: %s\n", stamp().c_str(), cmd.id.c_str(), pid,
                 runid, cmd.exec_str.c_str());
}

void Deputy::stopCommand(Command& cmd) {
  if (cmd.pid <= 0) return;
  cmd.should_be_running = false;
  cmd.respawn_at_us = 0;
  if (cmd.first_kill_us != 0) return;  // already stopping; SIGKILL follows from handleTimers
  if (kill(-cmd.pid, cmd.stop_signal) != 0 && kill(cmd.pid, cmd.stop_signal) != 0)
    note(cmd.id, std::string("kill: ") + std::strerror(errno));
  cmd.first_kill_us = nowUs();
  if (opt_.verbose)
    std::fprintf(stderr, "%s procman-deputy: [%s] stop: signal %d\n", stamp().c_str(), cmd.id.c_str(), cmd.stop_signal);
}

void Deputy::readOutput(Command& cmd) {
  if (cmd.pty_fd < 0) return;
  char buf[4096];
  for (;;) {
    const ssize_t n = read(cmd.pty_fd, buf, sizeof buf);
    if (n > 0) {
      transmit(cmd.id, std::string(buf, static_cast<size_t>(n)));
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && errno == EAGAIN) return;
    cmd.pty_open = false;  // EIO (all slave ends closed) or end of file
    return;
  }
}

void Deputy::reapChildren() {
  for (;;) {
    int status = 0;
    const pid_t pid = waitpid(-1, &status, WNOHANG);
    if (pid <= 0) return;
    Command* found = nullptr;
    for (auto& [id, cmd] : commands_)
      if (cmd->pid == pid) found = cmd.get();
    if (!found) continue;
    Command& cmd = *found;
    readOutput(cmd);
    cmd.pid = 0;
    cmd.exit_status = status;
    cmd.first_kill_us = 0;
    cmd.sigkill_sent = false;
    cmd.cpu_usage = 0.f;
    if (cmd.pty_fd >= 0) close(cmd.pty_fd);
    cmd.pty_fd = -1;
    cmd.pty_open = false;
    if (WIFSIGNALED(status)) {
      transmit(cmd.id, std::string(strsignal(WTERMSIG(status))) + (WCOREDUMP(status) ? " (core dumped)\n" : "\n"));
    }
    if (opt_.verbose)
      std::fprintf(stderr, "%s procman-deputy: [%s] ended, wait status %d\n", stamp().c_str(), cmd.id.c_str(), status);
    if (cmd.remove_requested) {
      removeCommand(cmd.id);
    } else if (cmd.auto_respawn && cmd.should_be_running && !exiting_) {
      cmd.respawn_at_us = nowUs() + cmd.respawn_backoff_ms * 1000LL;
      note(cmd.id, "respawning in " + std::to_string(cmd.respawn_backoff_ms) + " ms");
    }
    publishInfo();
  }
}

void Deputy::handleTimers(int64_t now) {
  discoveryTick(now);
  std::vector<Command*> to_respawn;
  for (auto& [id, cmd] : commands_) {
    if (cmd->pid > 0 && cmd->first_kill_us != 0 && !cmd->sigkill_sent &&
        now >= cmd->first_kill_us + static_cast<int64_t>(cmd->stop_time_allowed * 1e6)) {
      note(cmd->id, "still running " + std::to_string(cmd->stop_time_allowed) + " s after the stop signal: SIGKILL");
      kill(-cmd->pid, SIGKILL);
      kill(cmd->pid, SIGKILL);
      cmd->sigkill_sent = true;
    }
    if (cmd->respawn_at_us != 0 && now >= cmd->respawn_at_us) to_respawn.push_back(cmd.get());
  }
  for (Command* cmd : to_respawn) {
    cmd->respawn_at_us = 0;
    if (cmd->auto_respawn && cmd->should_be_running && cmd->pid == 0 && !exiting_) {
      startCommand(*cmd, cmd->actual_runid);
      publishInfo();
    }
  }
  if (!discovering_ && now >= next_info_us_) {
    updateCpuAndMemory();
    publishInfo();
    next_info_us_ = now + opt_.info_period_ms * 1000LL;
  }
  if (exiting_) {
    bool all_dead = true;
    for (auto& [id, cmd] : commands_) all_dead = all_dead && cmd->pid == 0;
    if (all_dead) {
      quit_ = true;
    } else if (now >= exit_deadline_us_) {
      for (auto& [id, cmd] : commands_) {
        if (cmd->pid > 0) {
          kill(-cmd->pid, SIGKILL);
          kill(cmd->pid, SIGKILL);
          int status = 0;
          waitpid(cmd->pid, &status, 0);
          cmd->pid = 0;
        }
      }
      quit_ = true;
    }
  }
  flushOutput(false);
}

void Deputy::updateCpuAndMemory() {
  SystemTimes now_sys;
  if (!readSystemTimes(now_sys)) return;
  sys_->cur = now_sys;
  if (sys_->have_prev) sys_->cpu_load = cpuLoad(sys_->prev, sys_->cur);
  for (auto& [id, cmd] : commands_) {
    if (cmd->pid <= 0) continue;
    ProcessTimes t;
    if (!readProcessTimes(cmd->pid, t)) continue;
    cmd->cur_times = t;
    cmd->cpu_usage = (cmd->have_prev_times && sys_->have_prev)
                         ? processCpuUsage(cmd->prev_times, cmd->cur_times, sys_->prev, sys_->cur)
                         : 0.f;
    cmd->prev_times = t;
    cmd->have_prev_times = true;
  }
  sys_->prev = sys_->cur;
  sys_->have_prev = true;
}

void Deputy::publishInfo() {
  procman_lcm::deputy_info_t msg;
  msg.utime = nowUs();
  msg.deputy_id = opt_.deputy_id;
  msg.cpu_load = sys_->cpu_load;
  msg.phys_mem_total_bytes = sys_->cur.mem_total_bytes;
  msg.phys_mem_free_bytes = sys_->cur.mem_free_bytes;
  msg.swap_total_bytes = sys_->cur.swap_total_bytes;
  msg.swap_free_bytes = sys_->cur.swap_free_bytes;
  for (auto& [id, cmd] : commands_) {
    procman_lcm::cmd_status_t s;
    s.cmd.command_id = cmd->id;
    s.cmd.exec_str = cmd->exec_str;
    s.cmd.group = cmd->group;
    s.cmd.auto_respawn = cmd->auto_respawn;
    s.cmd.stop_signal = static_cast<int8_t>(cmd->stop_signal);
    s.cmd.stop_time_allowed = cmd->stop_time_allowed;
    s.pid = cmd->pid;
    s.actual_runid = cmd->actual_runid;
    s.exit_code = cmd->exit_status;
    s.cpu_usage = cmd->pid > 0 ? cmd->cpu_usage : 0.f;
    s.mem_vsize_bytes = cmd->pid > 0 ? cmd->cur_times.vsize_bytes : 0;
    s.mem_rss_bytes = cmd->pid > 0 ? cmd->cur_times.rss_bytes : 0;
    msg.cmds.push_back(s);
  }
  msg.ncmds = static_cast<int32_t>(msg.cmds.size());
  lcm_->publish(kInfoChannel, &msg);
}

void Deputy::beginExit() {
  if (exiting_) return;
  exiting_ = true;
  float longest = 1.f;
  for (auto& [id, cmd] : commands_) {
    if (cmd->pid > 0) {
      longest = std::max(longest, cmd->stop_time_allowed);
      stopCommand(*cmd);
    }
  }
  exit_deadline_us_ = nowUs() + static_cast<int64_t>(longest * 1e6);
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
    for (auto& [id, cmd] : commands_) {
      if (cmd->respawn_at_us) next = std::min(next, cmd->respawn_at_us);
      if (cmd->pid > 0 && cmd->first_kill_us && !cmd->sigkill_sent)
        next = std::min(next, cmd->first_kill_us + static_cast<int64_t>(cmd->stop_time_allowed * 1e6));
    }
    if (exiting_) next = std::min(next, exit_deadline_us_);
    const int timeout_ms = static_cast<int>(std::clamp<int64_t>((next - now + 999) / 1000, 0, 1000));

    std::vector<pollfd> fds;
    std::vector<Command*> fd_cmds;
    fds.push_back({signal_fd_, POLLIN, 0});
    fds.push_back({lcm_->getFileno(), POLLIN, 0});
    for (auto& [id, cmd] : commands_) {
      if (cmd->pty_fd >= 0 && cmd->pty_open) {
        fds.push_back({cmd->pty_fd, POLLIN, 0});
        fd_cmds.push_back(cmd.get());
      }
    }
    const int n = poll(fds.data(), fds.size(), timeout_ms);
    if (n < 0) {
      if (errno == EINTR) continue;
      std::fprintf(stderr, "procman-deputy: poll: %s\n", std::strerror(errno));
      return kExitError;
    }
    for (size_t i = 2; i < fds.size(); ++i)
      if (fds[i].revents) readOutput(*fd_cmds[i - 2]);  // before reaping, so the last words come first
    if (fds[0].revents & POLLIN) {
      signalfd_siginfo si;
      while (read(signal_fd_, &si, sizeof si) == static_cast<ssize_t>(sizeof si)) {
        if (si.ssi_signo == SIGCHLD)
          reapChildren();
        else
          beginExit();
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
