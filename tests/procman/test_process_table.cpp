// The deputy's process table on its own, without LCM: real child processes under pseudo-terminals.
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/wait.h>

#include <chrono>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "procman/process_table.hpp"

namespace {

using ips::procman::CommandSpec;
using ips::procman::ProcessStatus;
using ips::procman::ProcessTable;
using ips::procman::ProcessTableOptions;

int64_t nowUs() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

struct Harness {
  std::map<std::string, std::string> output, notes;
  ProcessTable table;
  explicit Harness(ProcessTableOptions o = {})
      : table(
            o, [this](const std::string& id, const std::string& t) { output[id] += t; },
            [this](const std::string& id, const std::string& t) { notes[id] += t + "\n"; }) {}

  // What the deputy's loop does, until `done` or `seconds` have passed; false on time-out. Generous limits:
  // the machine may be loaded.
  bool pump(double seconds, const std::function<bool()>& done) {
    const int64_t end = nowUs() + static_cast<int64_t>(seconds * 1e6);
    while (nowUs() < end) {
      std::vector<pollfd> fds;
      std::vector<std::string> ids;
      table.pollFds(fds, ids);
      poll(fds.data(), fds.size(), 20);
      for (size_t i = 0; i < fds.size(); ++i)
        if (fds[i].revents) table.readOutput(ids[i]);
      table.reap(nowUs());
      table.handleTimers(nowUs());
      if (done()) return true;
    }
    return false;
  }
  ProcessStatus status(const std::string& id) const {
    for (const auto& s : table.status())
      if (s.spec.id == id) return s;
    return {};
  }
};

CommandSpec spec(const std::string& id, const std::string& exec) {
  CommandSpec s;
  s.id = id;
  s.exec_str = exec;
  return s;
}

TEST(ProcessTable, StartsACommandReadsItsOutputAndKeepsItsExitStatus) {
  Harness h;
  EXPECT_TRUE(h.table.apply(spec("hello", "sh -c 'echo hello from the table; exit 3'"), 1, true));
  EXPECT_GT(h.status("hello").pid, 0);
  ASSERT_TRUE(h.pump(30, [&] { return h.status("hello").pid == 0; }));
  const ProcessStatus s = h.status("hello");
  EXPECT_TRUE(WIFEXITED(s.exit_status));
  EXPECT_EQ(WEXITSTATUS(s.exit_status), 3);
  EXPECT_EQ(s.actual_runid, 1);
  EXPECT_NE(h.output["hello"].find("hello from the table\n"), std::string::npos) << h.output["hello"];
  // The same run id again: nothing to do; a new one: started again.
  EXPECT_FALSE(h.table.apply(spec("hello", "sh -c 'echo hello from the table; exit 3'"), 1, true));
  EXPECT_EQ(h.status("hello").pid, 0);
  EXPECT_TRUE(h.table.apply(spec("hello", "sh -c 'exit 0'"), 2, true));
  EXPECT_GT(h.status("hello").pid, 0);
  ASSERT_TRUE(h.pump(30, [&] { return h.status("hello").pid == 0; }));
  EXPECT_EQ(WEXITSTATUS(h.status("hello").exit_status), 0);
}

TEST(ProcessTable, RespawnsWithAGrowingBackOff) {
  ProcessTableOptions o;
  o.respawn_min_ms = 10;
  o.respawn_max_ms = 1000;
  Harness h(o);
  CommandSpec s = spec("crasher", "false");
  s.auto_respawn = true;
  h.table.apply(s, 1, true);
  // 10 ms doubling per quick death: 20, 40, 80, 160, 320 ms before the sixth start.
  auto respawns = [&] {
    size_t n = 0;
    for (size_t p = h.notes["crasher"].find("respawning in"); p != std::string::npos;
         p = h.notes["crasher"].find("respawning in", p + 1))
      ++n;
    return n;
  };
  ASSERT_TRUE(h.pump(60, [&] { return respawns() >= 5; })) << h.notes["crasher"];
  const std::string& n = h.notes["crasher"];
  const size_t p20 = n.find("respawning in 20 ms"), p40 = n.find("respawning in 40 ms"),
               p80 = n.find("respawning in 80 ms");
  ASSERT_NE(p20, std::string::npos) << n;
  ASSERT_NE(p40, std::string::npos) << n;
  ASSERT_NE(p80, std::string::npos) << n;
  EXPECT_LT(p20, p40);
  EXPECT_LT(p40, p80);
  // Ordered to stop: no further respawn.
  h.table.apply(s, 1, false);
  ASSERT_TRUE(h.pump(30, [&] { return h.status("crasher").pid == 0; }));
  const size_t before = respawns();
  h.pump(0.5, [] { return false; });
  EXPECT_EQ(respawns(), before);
  EXPECT_EQ(h.status("crasher").pid, 0);
}

TEST(ProcessTable, StopSignalThenSigkillAfterTheAllowedTime) {
  Harness h;
  CommandSpec s = spec("stubborn", "sh -c 'trap \"\" INT; echo ready; while :; do sleep 0.05; done'");
  s.stop_signal = SIGINT;
  s.stop_time_allowed = 0.3f;
  h.table.apply(s, 1, true);
  ASSERT_TRUE(h.pump(30, [&] { return h.output["stubborn"].find("ready") != std::string::npos; }));
  h.table.apply(s, 1, false);
  ASSERT_TRUE(h.pump(30, [&] { return h.status("stubborn").pid == 0; }));
  const int st = h.status("stubborn").exit_status;
  ASSERT_TRUE(WIFSIGNALED(st));
  EXPECT_EQ(WTERMSIG(st), SIGKILL);
  EXPECT_NE(h.notes["stubborn"].find("SIGKILL"), std::string::npos);
}

TEST(ProcessTable, CommandsLeftOutOfTheDesiredStateAreStoppedAndForgotten) {
  Harness h;
  h.table.apply(spec("kept", "sleep 100"), 1, true);
  h.table.apply(spec("dropped", "sleep 100"), 1, true);
  EXPECT_TRUE(h.table.retainOnly({"kept"}));
  ASSERT_TRUE(h.pump(30, [&] { return h.table.status().size() == 1; }));
  EXPECT_EQ(h.table.status().front().spec.id, "kept");
  EXPECT_GT(h.status("kept").pid, 0);
  EXPECT_GE(h.table.stopAll(), 1.f);
  ASSERT_TRUE(h.pump(30, [&] { return !h.table.anyRunning(); }));
}

}  // namespace
