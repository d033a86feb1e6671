#include "procman/process_table.hpp"

#include <fcntl.h>
#include <pty.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>

#include "procman/clock.hpp"
#include "procman/exec_string.hpp"

namespace ips::procman {
struct ProcessTable::Command {
  CommandSpec spec;
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

ProcessTable::ProcessTable(ProcessTableOptions options, TextSink output, TextSink note)
    : opt_(options), output_(std::move(output)), note_(std::move(note)) {
  have_sys_prev_ = readSystemTimes(sys_prev_);
  sys_cur_ = sys_prev_;
}

ProcessTable::~ProcessTable() {
  for (auto& [id, cmd] : commands_) {
    if (cmd->pid > 0) kill(-cmd->pid, SIGKILL);
    if (cmd->pty_fd >= 0) close(cmd->pty_fd);
  }
}

bool ProcessTable::apply(const CommandSpec& spec, int32_t desired_runid, bool run) {
  bool changed = false;
  auto it = commands_.find(spec.id);
  if (it == commands_.end()) {
    auto cmd = std::make_unique<Command>();
    cmd->spec = spec;
    cmd->respawn_backoff_ms = opt_.respawn_min_ms;
    it = commands_.emplace(spec.id, std::move(cmd)).first;
    if (opt_.verbose) std::fprintf(stderr, "procman: [%s] added: %s\n", spec.id.c_str(), spec.exec_str.c_str());
    changed = true;
  }
  Command& cmd = *it->second;
  // A new exec string, group or stop setting applies from the next start; it does not restart the command.
  if (cmd.spec.exec_str != spec.exec_str || cmd.spec.group != spec.group) changed = true;
  cmd.spec = spec;
  cmd.remove_requested = false;
  cmd.should_be_running = run;

  const bool running = cmd.pid > 0;
  if (!running && cmd.actual_runid != desired_runid && cmd.should_be_running) {
    start(cmd, desired_runid, nowUs());
    changed = true;
  } else if (running && (!cmd.should_be_running || desired_runid != cmd.actual_runid)) {
    stop(cmd, nowUs());
    changed = true;
  } else {
    cmd.actual_runid = desired_runid;
  }
  return changed;
}

bool ProcessTable::retainOnly(const std::set<std::string>& keep) {
  std::vector<std::string> orphans;
  for (auto& [id, cmd] : commands_)
    if (!keep.count(id)) orphans.push_back(id);
  for (const std::string& id : orphans) {
    Command& cmd = *commands_.at(id);
    if (cmd.pid > 0) {
      cmd.remove_requested = true;
      stop(cmd, nowUs());
    } else {
      remove(id);
    }
  }
  return !orphans.empty();
}

void ProcessTable::remove(const std::string& id) {
  auto it = commands_.find(id);
  if (it == commands_.end()) return;
  if (it->second->pty_fd >= 0) close(it->second->pty_fd);
  if (opt_.verbose) std::fprintf(stderr, "procman: [%s] removed\n", id.c_str());
  commands_.erase(it);
}

void ProcessTable::start(Command& cmd, int32_t runid, int64_t now) {
  if (stopping_all_) return;
  cmd.should_be_running = true;
  cmd.respawn_at_us = 0;
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
    spec = parseExecString(cmd.spec.exec_str);
  } catch (const ExecStringError& e) {
    note_(cmd.spec.id, std::string("cannot start: ") + e.what());
    cmd.exit_status = 127 << 8;  // as a shell reports a command it cannot run
    return;
  }
  std::vector<char*> argv;
  for (auto& a : spec.argv) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);

  int master = -1;
  const pid_t parent_pid = getpid();
  const pid_t pid = forkpty(&master, nullptr, nullptr, nullptr);
  if (pid < 0) {
    note_(cmd.spec.id, std::string("cannot start: forkpty: ") + std::strerror(errno));
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
    if (getppid() != parent_pid) _exit(127);
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
    std::fprintf(stderr, "procman: [%s] started pid %d run %d: %s\n", cmd.spec.id.c_str(), pid, runid,
                 cmd.spec.exec_str.c_str());
}

void ProcessTable::stop(Command& cmd, int64_t now) {
  if (cmd.pid <= 0) return;
  cmd.should_be_running = false;
  cmd.respawn_at_us = 0;
  if (cmd.first_kill_us != 0) return;  // already stopping; SIGKILL follows from handleTimers
  if (kill(-cmd.pid, cmd.spec.stop_signal) != 0 && kill(cmd.pid, cmd.spec.stop_signal) != 0)
    note_(cmd.spec.id, std::string("kill: ") + std::strerror(errno));
  cmd.first_kill_us = now;
  if (opt_.verbose) std::fprintf(stderr, "procman: [%s] stop: signal %d\n", cmd.spec.id.c_str(), cmd.spec.stop_signal);
}

void ProcessTable::readOutput(const std::string& id) {
  auto it = commands_.find(id);
  if (it != commands_.end()) readOutput(*it->second);
}

void ProcessTable::readOutput(Command& cmd) {
  if (cmd.pty_fd < 0) return;
  char buf[4096];
  for (;;) {
    const ssize_t n = read(cmd.pty_fd, buf, sizeof buf);
    if (n > 0) {
      output_(cmd.spec.id, std::string(buf, static_cast<size_t>(n)));
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && errno == EAGAIN) return;
    cmd.pty_open = false;  // EIO (all slave ends closed) or end of file
    return;
  }
}

bool ProcessTable::reap(int64_t now) {
  bool any = false;
  for (;;) {
    int status = 0;
    const pid_t pid = waitpid(-1, &status, WNOHANG);
    if (pid <= 0) return any;
    Command* found = nullptr;
    for (auto& [id, cmd] : commands_)
      if (cmd->pid == pid) found = cmd.get();
    if (!found) continue;
    any = true;
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
    if (WIFSIGNALED(status))
      output_(cmd.spec.id, std::string(strsignal(WTERMSIG(status))) + (WCOREDUMP(status) ? " (core dumped)\n" : "\n"));
    if (opt_.verbose) std::fprintf(stderr, "procman: [%s] ended, wait status %d\n", cmd.spec.id.c_str(), status);
    if (cmd.remove_requested) {
      remove(cmd.spec.id);
    } else if (cmd.spec.auto_respawn && cmd.should_be_running && !stopping_all_) {
      cmd.respawn_at_us = now + cmd.respawn_backoff_ms * 1000LL;
      note_(cmd.spec.id, "respawning in " + std::to_string(cmd.respawn_backoff_ms) + " ms");
    }
  }
}

bool ProcessTable::handleTimers(int64_t now) {
  std::vector<Command*> to_respawn;
  for (auto& [id, cmd] : commands_) {
    if (cmd->pid > 0 && cmd->first_kill_us != 0 && !cmd->sigkill_sent &&
        now >= cmd->first_kill_us + static_cast<int64_t>(cmd->spec.stop_time_allowed * 1e6)) {
      note_(cmd->spec.id,
            "still running " + std::to_string(cmd->spec.stop_time_allowed) + " s after the stop signal: SIGKILL");
      kill(-cmd->pid, SIGKILL);
      kill(cmd->pid, SIGKILL);
      cmd->sigkill_sent = true;
    }
    if (cmd->respawn_at_us != 0 && now >= cmd->respawn_at_us) to_respawn.push_back(cmd.get());
  }
  bool started = false;
  for (Command* cmd : to_respawn) {
    cmd->respawn_at_us = 0;
    if (cmd->spec.auto_respawn && cmd->should_be_running && cmd->pid == 0 && !stopping_all_) {
      start(*cmd, cmd->actual_runid, now);
      started = true;
    }
  }
  return started;
}

float ProcessTable::stopAll() {
  stopping_all_ = true;
  float longest = 1.f;
  for (auto& [id, cmd] : commands_) {
    if (cmd->pid > 0) {
      longest = std::max(longest, cmd->spec.stop_time_allowed);
      stop(*cmd, nowUs());
    }
  }
  return longest;
}

bool ProcessTable::anyRunning() const {
  return std::any_of(commands_.begin(), commands_.end(), [](const auto& kv) { return kv.second->pid > 0; });
}

void ProcessTable::killAll() {
  for (auto& [id, cmd] : commands_) {
    if (cmd->pid > 0) {
      kill(-cmd->pid, SIGKILL);
      kill(cmd->pid, SIGKILL);
      int status = 0;
      waitpid(cmd->pid, &status, 0);
      cmd->pid = 0;
    }
  }
}

int64_t ProcessTable::nextDeadline(int64_t limit) const {
  int64_t next = limit;
  for (auto& [id, cmd] : commands_) {
    if (cmd->respawn_at_us) next = std::min(next, cmd->respawn_at_us);
    if (cmd->pid > 0 && cmd->first_kill_us && !cmd->sigkill_sent)
      next = std::min(next, cmd->first_kill_us + static_cast<int64_t>(cmd->spec.stop_time_allowed * 1e6));
  }
  return next;
}

void ProcessTable::pollFds(std::vector<pollfd>& fds, std::vector<std::string>& ids) const {
  for (auto& [id, cmd] : commands_) {
    if (cmd->pty_fd >= 0 && cmd->pty_open) {
      fds.push_back({cmd->pty_fd, POLLIN, 0});
      ids.push_back(id);
    }
  }
}

void ProcessTable::sampleCpuAndMemory() {
  SystemTimes now_sys;
  if (!readSystemTimes(now_sys)) return;
  sys_cur_ = now_sys;
  if (have_sys_prev_) cpu_load_ = ips::procman::cpuLoad(sys_prev_, sys_cur_);
  for (auto& [id, cmd] : commands_) {
    if (cmd->pid <= 0) continue;
    ProcessTimes t;
    if (!readProcessTimes(cmd->pid, t)) continue;
    cmd->cur_times = t;
    cmd->cpu_usage = (cmd->have_prev_times && have_sys_prev_)
                         ? processCpuUsage(cmd->prev_times, cmd->cur_times, sys_prev_, sys_cur_)
                         : 0.f;
    cmd->prev_times = t;
    cmd->have_prev_times = true;
  }
  sys_prev_ = sys_cur_;
  have_sys_prev_ = true;
}

std::vector<ProcessStatus> ProcessTable::status() const {
  std::vector<ProcessStatus> out;
  for (auto& [id, cmd] : commands_) {
    ProcessStatus s;
    s.spec = cmd->spec;
    s.pid = cmd->pid;
    s.actual_runid = cmd->actual_runid;
    s.exit_status = cmd->exit_status;
    s.cpu_usage = cmd->pid > 0 ? cmd->cpu_usage : 0.f;
    s.mem_vsize_bytes = cmd->pid > 0 ? cmd->cur_times.vsize_bytes : 0;
    s.mem_rss_bytes = cmd->pid > 0 ? cmd->cur_times.rss_bytes : 0;
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace ips::procman
