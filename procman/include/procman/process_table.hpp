#pragma once
// The deputy's process table, without LCM: starts commands under pseudo-terminals in their own sessions, stops
// them (their stop signal, SIGKILL after the time allowed), reaps them, respawns those that ask for it with a
// back-off, reads what they write and samples their CPU and memory. The deputy (deputy.hpp) turns a sheriff's
// orders into calls here and publishes what `status()` returns; tests drive it directly.
#include <poll.h>
#include <sys/types.h>

#include <csignal>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "procman/proc_info.hpp"

namespace ips::procman {

struct CommandSpec {
  std::string id, exec_str, group;
  bool auto_respawn = false;
  int stop_signal = SIGINT;
  float stop_time_allowed = 7.f;  // [s] from the stop signal to SIGKILL
};

struct ProcessStatus {
  CommandSpec spec;
  pid_t pid = 0;  // 0: not running
  int32_t actual_runid = 0;
  int exit_status = 0;  // raw wait status of the last run
  float cpu_usage = 0.f;
  int64_t mem_vsize_bytes = 0, mem_rss_bytes = 0;
};

struct ProcessTableOptions {
  int respawn_min_ms = 10;    // auto-respawn back-off: starts here, doubles while the command keeps dying
  int respawn_max_ms = 1000;  // within this time of its start, and is capped here
  int respawn_backoff_factor = 2;
  bool verbose = false;  // every start, stop, end and removal on stderr
};

class ProcessTable {
 public:
  // `output`: what a command wrote (id, text); `note`: the table's own remarks about a command, for its output.
  using TextSink = std::function<void(const std::string& id, const std::string& text)>;
  ProcessTable(ProcessTableOptions options, TextSink output, TextSink note);
  ~ProcessTable();  // kills whatever still runs
  ProcessTable(const ProcessTable&) = delete;
  ProcessTable& operator=(const ProcessTable&) = delete;

  // The desired state of one command: its spec (changes apply from the next start), the run it should be in
  // (a new run id restarts it) and whether it should run at all. True when something changed.
  bool apply(const CommandSpec& spec, int32_t desired_runid, bool run);
  // Stops and forgets every command not named in `keep` (forgotten once it has ended). True when any was.
  bool retainOnly(const std::set<std::string>& keep);
  // After SIGCHLD: collects ended commands, schedules respawns. True when any ended.
  bool reap(int64_t now_us);
  // SIGKILL for commands past their stop time, due respawns. True when any command started.
  bool handleTimers(int64_t now_us);
  // Stops everything for good (no respawn); returns the longest stop time allowed [s] (at least 1).
  float stopAll();
  bool anyRunning() const;
  void killAll();  // SIGKILL and wait, for the end of the deputy
  // The earliest time something is due (a SIGKILL, a respawn), or `limit`.
  int64_t nextDeadline(int64_t limit) const;

  // The pseudo-terminals worth polling, and reading one that is readable.
  void pollFds(std::vector<pollfd>& fds, std::vector<std::string>& ids) const;
  void readOutput(const std::string& id);

  void sampleCpuAndMemory();
  const SystemTimes& system() const { return sys_cur_; }
  float cpuLoad() const { return cpu_load_; }
  std::vector<ProcessStatus> status() const;
  bool empty() const { return commands_.empty(); }

 private:
  struct Command;
  void start(Command& cmd, int32_t runid, int64_t now_us);
  void stop(Command& cmd, int64_t now_us);
  void remove(const std::string& id);
  void readOutput(Command& cmd);

  ProcessTableOptions opt_;
  TextSink output_, note_;
  std::map<std::string, std::unique_ptr<Command>> commands_;
  bool stopping_all_ = false;
  SystemTimes sys_prev_, sys_cur_;
  bool have_sys_prev_ = false;
  float cpu_load_ = 0.f;
};

}  // namespace ips::procman
