// The procman deputy as a process: each test starts real procman-deputy processes and talks to them over LCM
// (UDP multicast; ctest runs each test in its own network namespace), acting as a sheriff with the raw
// procman protocol, and checks what the deputy reports on PM_INFO and PM_OUTPUT.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "procman_lcm/deputy_info_t.hpp"
#include "procman_lcm/discovery_t.hpp"
#include "procman_lcm/orders_t.hpp"
#include "procman_lcm/output_t.hpp"

namespace {

int64_t nowUs() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::string testUrl() {
  // A port of its own per test, so that tests never hear each other even without a network namespace.
  const std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
  return "udpm://239.255.76.67:" + std::to_string(7800 + std::hash<std::string>{}(name) % 150) + "?ttl=0";
}

class DeputyProcess {
 public:
  DeputyProcess(const std::string& id, const std::string& url) {
    pid_ = fork();
    if (pid_ == 0) {
      execl(PROCMAN_DEPUTY, PROCMAN_DEPUTY, "-i", id.c_str(), "-u", url.c_str(), "-v", static_cast<char*>(nullptr));
      _exit(127);
    }
  }
  ~DeputyProcess() {
    if (pid_ > 0 && !exited_) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  pid_t pid() const { return pid_; }
  // Exit code if the process ended within timeout_s, else nullopt.
  std::optional<int> waitExit(double timeout_s) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (std::chrono::steady_clock::now() < end) {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        exited_ = true;
        return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return std::nullopt;
  }

 private:
  pid_t pid_ = -1;
  bool exited_ = false;
};

procman_lcm::cmd_desired_t desired(const std::string& id, const std::string& exec, int32_t runid,
                                   bool force_quit = false, bool auto_respawn = false, int stop_signal = SIGINT,
                                   float stop_time_allowed = 7.f) {
  procman_lcm::cmd_desired_t d;
  d.cmd.command_id = id;
  d.cmd.exec_str = exec;
  d.cmd.group = "test";
  d.cmd.auto_respawn = auto_respawn;
  d.cmd.stop_signal = static_cast<int8_t>(stop_signal);
  d.cmd.stop_time_allowed = stop_time_allowed;
  d.desired_runid = runid;
  d.force_quit = force_quit;
  return d;
}

class ProcmanDeputy : public ::testing::Test {
 protected:
  void SetUp() override {
    url_ = testUrl();
    lcm_ = std::make_unique<lcm::LCM>(url_);
    ASSERT_TRUE(lcm_->good());
    lcm_->subscribe("PM_INFO", &ProcmanDeputy::onInfo, this);
    lcm_->subscribe("PM_OUTPUT", &ProcmanDeputy::onOutput, this);
    lcm_->subscribe("PM_DISCOVER", &ProcmanDeputy::onDiscover, this);
  }

  void onInfo(const lcm::ReceiveBuffer*, const std::string&, const procman_lcm::deputy_info_t* m) {
    latest_info_[m->deputy_id] = *m;
    ++info_count_[m->deputy_id];
  }
  void onOutput(const lcm::ReceiveBuffer*, const std::string&, const procman_lcm::output_t* m) {
    ASSERT_EQ(m->num_commands, static_cast<int16_t>(m->command_ids.size()));
    for (size_t i = 0; i < m->command_ids.size(); ++i) output_[m->deputy_id + "/" + m->command_ids[i]] += m->text[i];
  }
  void onDiscover(const lcm::ReceiveBuffer*, const std::string&, const procman_lcm::discovery_t* m) {
    discoveries_.push_back(*m);
  }

  // Handles LCM until pred() or timeout; resends the current orders every 500 ms like a sheriff does.
  bool spinUntil(const std::function<bool()>& pred, double timeout_s) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    auto next_orders = std::chrono::steady_clock::now() + std::chrono::milliseconds(500);
    while (!pred()) {
      if (std::chrono::steady_clock::now() >= end) return pred();
      lcm_->handleTimeout(20);
      if (resend_ && std::chrono::steady_clock::now() >= next_orders) {
        publishOrders();
        next_orders += std::chrono::milliseconds(500);
      }
    }
    return true;
  }
  void spinFor(double s) {
    spinUntil([] { return false; }, s);
  }

  void order(const std::string& deputy, std::vector<procman_lcm::cmd_desired_t> cmds, int64_t age_us = 0,
             bool resend = true) {
    orders_.deputy_id = deputy;
    orders_.sheriff_id = "test-sheriff";
    orders_.cmds = std::move(cmds);
    orders_.ncmds = static_cast<int32_t>(orders_.cmds.size());
    order_age_us_ = age_us;
    resend_ = resend;
    publishOrders();
  }
  void publishOrders() {
    orders_.utime = nowUs() - order_age_us_;
    lcm_->publish("PM_ORDERS", &orders_);
  }

  // The deputy reports once it takes orders (after its discovery period).
  void waitReady(const std::string& deputy) {
    ASSERT_TRUE(spinUntil([&] { return info_count_[deputy] > 0; }, 10)) << "no PM_INFO from deputy " << deputy;
  }

  std::optional<procman_lcm::cmd_status_t> status(const std::string& deputy, const std::string& cmd) {
    auto it = latest_info_.find(deputy);
    if (it == latest_info_.end()) return std::nullopt;
    for (const auto& s : it->second.cmds)
      if (s.cmd.command_id == cmd) return s;
    return std::nullopt;
  }
  std::string output(const std::string& deputy, const std::string& cmd) { return output_[deputy + "/" + cmd]; }
  bool outputHas(const std::string& deputy, const std::string& cmd, const std::string& text) {
    return output(deputy, cmd).find(text) != std::string::npos;
  }
  bool isRunning(const std::string& deputy, const std::string& cmd, int32_t runid) {
    auto s = status(deputy, cmd);
    return s && s->pid > 0 && s->actual_runid == runid;
  }
  bool hasEnded(const std::string& deputy, const std::string& cmd, int32_t runid) {
    auto s = status(deputy, cmd);
    return s && s->pid == 0 && s->actual_runid == runid;
  }

  std::string url_;
  std::unique_ptr<lcm::LCM> lcm_;
  std::map<std::string, procman_lcm::deputy_info_t> latest_info_;
  std::map<std::string, int> info_count_;
  std::map<std::string, std::string> output_;
  std::vector<procman_lcm::discovery_t> discoveries_;
  procman_lcm::orders_t orders_;
  int64_t order_age_us_ = 0;
  bool resend_ = false;
};

TEST_F(ProcmanDeputy, StartsCommandCapturesOutputAndReportsRawWaitStatus) {
  DeputyProcess deputy("d1", url_);
  waitReady("d1");
  order("d1", {desired("greet", "sh -c 'echo hello from $0; exit 3' greeter", 1),
               desired("signalled", "sh -c 'echo bye; kill -USR1 $$'", 1)});
  ASSERT_TRUE(spinUntil([&] { return hasEnded("d1", "greet", 1) && hasEnded("d1", "signalled", 1); }, 10));
  EXPECT_TRUE(spinUntil([&] { return outputHas("d1", "greet", "hello from greeter\n"); }, 5)) << output("d1", "greet");
  EXPECT_TRUE(spinUntil([&] { return outputHas("d1", "signalled", "bye\n"); }, 5)) << output("d1", "signalled");
  // exit_code is the raw wait status, as the upstream deputy reports it.
  const auto greet = status("d1", "greet");
  EXPECT_EQ(greet->exit_code, 3 << 8);
  EXPECT_TRUE(WIFEXITED(greet->exit_code));
  EXPECT_EQ(WEXITSTATUS(greet->exit_code), 3);
  const auto sig = status("d1", "signalled");
  EXPECT_EQ(sig->exit_code, SIGUSR1);
  EXPECT_TRUE(WIFSIGNALED(sig->exit_code));
  EXPECT_EQ(greet->cmd.exec_str, "sh -c 'echo hello from $0; exit 3' greeter");
  EXPECT_EQ(greet->cmd.group, "test");
  // A command that exited on its own is not started again by the same orders.
  spinFor(1.5);
  EXPECT_EQ(output("d1", "greet"), std::string("hello from greeter\n"));
}

TEST_F(ProcmanDeputy, RunsCommandUnderPseudoTerminal) {
  DeputyProcess deputy("d1", url_);
  waitReady("d1");
  order("d1", {desired("tty", "sh -c 'test -t 0 && test -t 1 && test -t 2 && echo all-on-a-tty; tty'", 1)});
  ASSERT_TRUE(spinUntil([&] { return hasEnded("d1", "tty", 1) && outputHas("d1", "tty", "/dev/pts/"); }, 10))
      << output("d1", "tty");
  EXPECT_TRUE(outputHas("d1", "tty", "all-on-a-tty\n"));
  EXPECT_EQ(status("d1", "tty")->exit_code, 0);
}

TEST_F(ProcmanDeputy, StopSignalThenKillAfterAllowedTime) {
  DeputyProcess deputy("d1", url_);
  waitReady("d1");
  const std::string stubborn = "sh -c 'trap \"echo caught TERM\" TERM; echo ready; while true; do sleep 0.1; done'";
  order("d1", {desired("stubborn", stubborn, 1, false, false, SIGTERM, 1.0f)});
  ASSERT_TRUE(spinUntil([&] { return isRunning("d1", "stubborn", 1) && outputHas("d1", "stubborn", "ready"); }, 10));
  const pid_t pid = status("d1", "stubborn")->pid;
  order("d1", {desired("stubborn", stubborn, 1, true, false, SIGTERM, 1.0f)});
  ASSERT_TRUE(spinUntil([&] { return hasEnded("d1", "stubborn", 1); }, 10));
  EXPECT_TRUE(outputHas("d1", "stubborn", "caught TERM")) << "the stop signal came first";
  const int exit_code = status("d1", "stubborn")->exit_code;
  ASSERT_TRUE(WIFSIGNALED(exit_code));
  EXPECT_EQ(WTERMSIG(exit_code), SIGKILL) << "then SIGKILL after stop_time_allowed";
  EXPECT_TRUE(outputHas("d1", "stubborn", "SIGKILL"));
  EXPECT_NE(kill(pid, 0), 0);
}

TEST_F(ProcmanDeputy, StopSignalEndsCooperativeCommand) {
  DeputyProcess deputy("d1", url_);
  waitReady("d1");
  order("d1", {desired("sleeper", "sleep 30", 1, false, false, SIGINT, 5.f)});
  ASSERT_TRUE(spinUntil([&] { return isRunning("d1", "sleeper", 1); }, 10));
  order("d1", {desired("sleeper", "sleep 30", 1, true, false, SIGINT, 5.f)});
  ASSERT_TRUE(spinUntil([&] { return hasEnded("d1", "sleeper", 1); }, 10));
  const int exit_code = status("d1", "sleeper")->exit_code;
  ASSERT_TRUE(WIFSIGNALED(exit_code));
  EXPECT_EQ(WTERMSIG(exit_code), SIGINT);
  EXPECT_FALSE(outputHas("d1", "sleeper", "SIGKILL"));
}

TEST_F(ProcmanDeputy, RespawnsWithBackOff) {
  DeputyProcess deputy("d1", url_);
  waitReady("d1");
  const std::string crasher = "sh -c 'echo run; exit 1'";
  order("d1", {desired("crasher", crasher, 1, false, true)});
  // The deputy announces each respawn delay: it doubles from 10 ms while the command keeps dying within a
  // second of its start, up to 1000 ms (the upstream deputy's back-off).
  auto delays = [&] {
    std::vector<int> out;
    const std::string text = output("d1", "crasher"), key = "respawning in ";
    for (size_t p = text.find(key); p != std::string::npos; p = text.find(key, p + 1))
      out.push_back(std::atoi(text.c_str() + p + key.size()));
    return out;
  };
  ASSERT_TRUE(spinUntil([&] { return delays().size() >= 8; }, 15)) << output("d1", "crasher");
  const std::vector<int> all = delays();
  const std::vector<int> first(all.begin(), all.begin() + 8);
  EXPECT_EQ(first, (std::vector<int>{10, 20, 40, 80, 160, 320, 640, 1000}));
  auto runs = [&] {
    const std::string text = output("d1", "crasher");
    size_t n = 0;
    for (size_t p = text.find("run\n"); p != std::string::npos; p = text.find("run\n", p + 1)) ++n;
    return n;
  };
  EXPECT_GE(runs(), 8u);
  EXPECT_EQ(status("d1", "crasher")->actual_runid, 1) << "a respawn keeps the run id";
  // Stopped: no more respawns.
  order("d1", {desired("crasher", crasher, 1, true, true)});
  spinFor(0.5);
  const size_t after_stop = runs();
  spinFor(2.0);
  EXPECT_EQ(runs(), after_stop);
}

TEST_F(ProcmanDeputy, IgnoresOrdersForAnotherDeputy) {
  DeputyProcess deputy("d-a", url_);
  waitReady("d-a");
  order("d-b", {desired("x", "sh -c 'echo should not run'", 1)});
  const int seen = info_count_["d-a"];
  ASSERT_TRUE(spinUntil([&] { return info_count_["d-a"] >= seen + 2; }, 5));
  EXPECT_EQ(latest_info_["d-a"].ncmds, 0);
  EXPECT_FALSE(outputHas("d-a", "x", "should not run"));
  // The same orders addressed to it are carried out.
  order("d-a", {desired("x", "sh -c 'echo should not run'", 1)});
  EXPECT_TRUE(spinUntil([&] { return outputHas("d-a", "x", "should not run"); }, 10));
}

TEST_F(ProcmanDeputy, IgnoresStaleOrders) {
  DeputyProcess deputy("d1", url_);
  waitReady("d1");
  order("d1", {desired("late", "sh -c 'echo ran'", 1)}, 61'000'000);  // 61 s old
  ASSERT_TRUE(spinUntil([&] { return outputHas("d1", "", "stale orders"); }, 5)) << output("d1", "");
  const int seen = info_count_["d1"];
  ASSERT_TRUE(spinUntil([&] { return info_count_["d1"] >= seen + 2; }, 5));
  EXPECT_EQ(latest_info_["d1"].ncmds, 0);
  EXPECT_FALSE(outputHas("d1", "late", "ran"));
  // 50 s old is within the 60 s limit.
  order("d1", {desired("late", "sh -c 'echo ran'", 1)}, 50'000'000);
  EXPECT_TRUE(spinUntil([&] { return outputHas("d1", "late", "ran\n"); }, 10));
}

TEST_F(ProcmanDeputy, IgnoresOrdersDuringDiscovery) {
  DeputyProcess deputy("d1", url_);
  // Orders sent as soon as the new deputy announces itself arrive during its discovery period.
  ASSERT_TRUE(spinUntil(
      [&] {
        for (const auto& d : discoveries_)
          if (d.transmitter_id == "d1") return true;
        return false;
      },
      10));
  order("d1", {desired("early", "sh -c 'echo early run'", 1)}, 0, /*resend=*/false);
  waitReady("d1");
  const int seen = info_count_["d1"];
  ASSERT_TRUE(spinUntil([&] { return info_count_["d1"] >= seen + 1; }, 5));
  EXPECT_EQ(latest_info_["d1"].ncmds, 0);
  EXPECT_FALSE(outputHas("d1", "early", "early run"));
  order("d1", {desired("early", "sh -c 'echo early run'", 1)});
  EXPECT_TRUE(spinUntil([&] { return outputHas("d1", "early", "early run"); }, 10));
}

TEST_F(ProcmanDeputy, StopsAndForgetsCommandMissingFromOrders) {
  DeputyProcess deputy("d1", url_);
  waitReady("d1");
  order("d1", {desired("a", "sleep 30", 1), desired("b", "sleep 30", 1)});
  ASSERT_TRUE(spinUntil([&] { return isRunning("d1", "a", 1) && isRunning("d1", "b", 1); }, 10));
  const pid_t pid_a = status("d1", "a")->pid, pid_b = status("d1", "b")->pid;
  order("d1", {desired("a", "sleep 30", 1)});
  ASSERT_TRUE(spinUntil([&] { return !status("d1", "b").has_value(); }, 10));
  EXPECT_EQ(latest_info_["d1"].ncmds, 1);
  EXPECT_EQ(status("d1", "a")->pid, pid_a) << "the listed command keeps running";
  EXPECT_NE(kill(pid_b, 0), 0) << "the missing one was stopped";
}

TEST_F(ProcmanDeputy, RestartsWhenDesiredRunIdChanges) {
  DeputyProcess deputy("d1", url_);
  waitReady("d1");
  order("d1", {desired("a", "sleep 30", 1)});
  ASSERT_TRUE(spinUntil([&] { return isRunning("d1", "a", 1); }, 10));
  const pid_t first = status("d1", "a")->pid;
  order("d1", {desired("a", "sleep 30", 2)});
  ASSERT_TRUE(spinUntil([&] { return isRunning("d1", "a", 2); }, 10));
  EXPECT_NE(status("d1", "a")->pid, first);
  EXPECT_NE(kill(first, 0), 0);
  // Same run id again: nothing happens.
  const pid_t second = status("d1", "a")->pid;
  spinFor(1.5);
  EXPECT_EQ(status("d1", "a")->pid, second);
}

TEST_F(ProcmanDeputy, RefusesSecondDeputyWithSameId) {
  DeputyProcess first("d1", url_);
  waitReady("d1");
  DeputyProcess other("d2", url_);
  DeputyProcess second("d1", url_);
  const auto code = second.waitExit(10);
  ASSERT_TRUE(code.has_value()) << "the second deputy with id d1 kept running";
  EXPECT_EQ(*code, 2);
  // The first one and one with another id keep running and reporting.
  waitReady("d2");
  EXPECT_FALSE(first.waitExit(0.1).has_value());
  EXPECT_FALSE(other.waitExit(0.1).has_value());
  const int seen = info_count_["d1"];
  EXPECT_TRUE(spinUntil([&] { return info_count_["d1"] > seen; }, 5));
}

TEST_F(ProcmanDeputy, ReportsCpuAndMemoryFromProc) {
  DeputyProcess deputy("d1", url_);
  waitReady("d1");
  order("d1", {desired("busy", "/usr/bin/python3 -c 'b = b\"x\" * (100 << 20); any(iter(int, 1))'", 1),
               desired("idle", "sleep 30", 1)});
  ASSERT_TRUE(spinUntil(
      [&] {
        auto s = status("d1", "busy");
        return s && s->pid > 0 && s->mem_rss_bytes >= (100LL << 20) && s->cpu_usage >= 0.05f;
      },
      15))
      << "rss " << (status("d1", "busy") ? status("d1", "busy")->mem_rss_bytes : -1) << " cpu "
      << (status("d1", "busy") ? status("d1", "busy")->cpu_usage : -1);
  const auto busy = *status("d1", "busy");
  const auto idle = *status("d1", "idle");
  EXPECT_GE(busy.mem_vsize_bytes, busy.mem_rss_bytes);
  EXPECT_LE(busy.cpu_usage, 1.0f);
  EXPECT_GT(idle.mem_rss_bytes, 0);
  EXPECT_LT(idle.mem_rss_bytes, 50LL << 20);
  EXPECT_LT(idle.cpu_usage, busy.cpu_usage);
  const auto& info = latest_info_["d1"];
  EXPECT_GT(info.phys_mem_total_bytes, busy.mem_rss_bytes);
  EXPECT_GT(info.phys_mem_free_bytes, 0);
  EXPECT_LE(info.phys_mem_free_bytes, info.phys_mem_total_bytes);
  EXPECT_GE(info.cpu_load, 0.f);
  EXPECT_LE(info.cpu_load, 1.f);
}

TEST_F(ProcmanDeputy, SurvivesMalformedOrders) {
  DeputyProcess deputy("d1", url_);
  waitReady("d1");
  order("d1",
        {desired("", "sh -c 'echo empty id'", 1), desired("unparsable", "A=1 B=2", 1),
         desired("missing", "/nonexistent/program --flag", 1),
         desired("nan", "sleep 30", 1, false, false, 99, std::nanf("")), desired("fine", "sh -c 'echo fine'", 1)});
  ASSERT_TRUE(spinUntil([&] { return hasEnded("d1", "fine", 1) && outputHas("d1", "fine", "fine\n"); }, 10));
  EXPECT_FALSE(status("d1", "").has_value());
  EXPECT_TRUE(spinUntil([&] { return outputHas("d1", "", "empty id"); }, 5));
  // Commands that cannot start end like a shell's "command not found": exit status 127, with a note.
  ASSERT_TRUE(spinUntil([&] { return hasEnded("d1", "unparsable", 1) && hasEnded("d1", "missing", 1); }, 10));
  EXPECT_EQ(status("d1", "unparsable")->exit_code, 127 << 8);
  EXPECT_EQ(status("d1", "missing")->exit_code, 127 << 8);
  EXPECT_TRUE(spinUntil([&] { return outputHas("d1", "unparsable", "cannot start"); }, 5));
  EXPECT_TRUE(spinUntil([&] { return outputHas("d1", "missing", "cannot run"); }, 5));
  // A signal number that does not exist and a NaN stop time: stopping still ends in SIGKILL, at once.
  ASSERT_TRUE(spinUntil([&] { return isRunning("d1", "nan", 1); }, 10));
  EXPECT_EQ(status("d1", "nan")->cmd.stop_time_allowed, 0.f);
  order("d1", {desired("nan", "sleep 30", 1, true, false, 99, std::nanf(""))});
  ASSERT_TRUE(spinUntil([&] { return hasEnded("d1", "nan", 1); }, 10));
  EXPECT_EQ(WTERMSIG(status("d1", "nan")->exit_code), SIGKILL);
  EXPECT_FALSE(deputy.waitExit(0.1).has_value()) << "the deputy is still running";

  // Orders with the right fingerprint whose lengths make the generated decoder throw: a string length of 0
  // and a negative command count. The deputy drops them, says so, and keeps taking orders.
  std::vector<uint8_t> head;
  auto put = [&](uint64_t v, int bytes) {
    for (int b = bytes - 1; b >= 0; --b) head.push_back(static_cast<uint8_t>(v >> (8 * b)));
  };
  put(static_cast<uint64_t>(procman_lcm::orders_t::getHash()), 8);
  put(static_cast<uint64_t>(nowUs()), 8);
  std::vector<uint8_t> zero_length_string = head;
  for (int i = 0; i < 4; ++i) zero_length_string.push_back(0);
  auto string_field = [&](const std::string& text) {
    put(text.size() + 1, 4);
    head.insert(head.end(), text.begin(), text.end());
    head.push_back(0);
  };
  string_field("d1");
  string_field("test-sheriff");
  put(0xffffffffu, 4);  // ncmds = -1
  for (int i = 0; i < 3; ++i) {
    lcm_->publish("PM_ORDERS", zero_length_string.data(), static_cast<unsigned>(zero_length_string.size()));
    lcm_->publish("PM_ORDERS", head.data(), static_cast<unsigned>(head.size()));
  }
  EXPECT_TRUE(spinUntil([&] { return outputHas("d1", "", "dropped a message on PM_ORDERS"); }, 5));
  order("d1", {desired("after", "sh -c 'echo still taking orders'", 1)});
  EXPECT_TRUE(spinUntil([&] { return outputHas("d1", "after", "still taking orders"); }, 10));
  EXPECT_FALSE(deputy.waitExit(0.1).has_value()) << "the deputy is still running";
}

TEST_F(ProcmanDeputy, StopsCommandsOnSigterm) {
  auto deputy = std::make_unique<DeputyProcess>("d1", url_);
  waitReady("d1");
  order("d1", {desired("a", "sleep 30", 1, false, true)});
  ASSERT_TRUE(spinUntil([&] { return isRunning("d1", "a", 1); }, 10));
  const pid_t child = status("d1", "a")->pid;
  kill(deputy->pid(), SIGTERM);
  const auto code = deputy->waitExit(10);
  ASSERT_TRUE(code.has_value());
  EXPECT_EQ(*code, 0);
  EXPECT_NE(kill(child, 0), 0) << "the command does not outlive its deputy";
}

TEST_F(ProcmanDeputy, CommandsDieWithAKilledDeputy) {
  // SIGKILL gives the deputy no chance to stop its commands. lcm-logger catches SIGHUP (to start a new file) and
  // the second command ignores it, so neither may rely on the hang-up of its pseudo-terminal.
  auto deputy = std::make_unique<DeputyProcess>("d1", url_);
  waitReady("d1");
  const std::string log = testing::TempDir() + "/deputy_killed_" + std::to_string(getpid()) + ".lcmlog";
  order("d1", {desired("logger", "lcm-logger --lcm-url=" + url_ + " -f " + log, 1, false, true),
               desired("deaf",
                       "python3 -c 'import signal, time; signal.signal(signal.SIGHUP, signal.SIG_IGN); time.sleep(30)'",
                       1, false, true)});
  ASSERT_TRUE(spinUntil([&] { return isRunning("d1", "deaf", 1); }, 10));
  const pid_t deaf = status("d1", "deaf")->pid;
  ASSERT_TRUE(spinUntil([&] { return isRunning("d1", "logger", 1); }, 10));
  const pid_t child = status("d1", "logger")->pid;
  kill(deputy->pid(), SIGKILL);
  ASSERT_TRUE(deputy->waitExit(10).has_value());
  // Dead: gone, or a zombie waiting for whoever it was reparented to.
  auto dead = [](pid_t p) {
    std::ifstream stat("/proc/" + std::to_string(p) + "/stat");
    std::string pid, comm, state;
    return !(stat >> pid >> comm >> state) || state == "Z";
  };
  EXPECT_TRUE(spinUntil([&] { return dead(child) && dead(deaf); }, 10)) << "a command outlives its killed deputy";
  std::remove(log.c_str());
}

// The orders recorded from a real exchange with upstream procman (tests/procman/upstream_exchange.lcmlog: our
// sheriff ordering the upstream deputy "up", the upstream sheriff ordering our deputy "ours"), played again,
// with fresh stamps and at their recorded pace (long pauses shortened), to our deputies with the same ids:
// each must end as the recorded deputy did (every command's run id, stopped, and how the non-respawning ones
// ended), and the auto-respawn command must have been respawned.
TEST_F(ProcmanDeputy, AnswersRecordedUpstreamOrdersAsRecorded) {
  lcm::LogFile log(std::string(PROCMAN_TEST_DIR) + "/upstream_exchange.lcmlog", "r");
  ASSERT_TRUE(log.good());
  struct Timed {
    int64_t t_us;
    procman_lcm::orders_t orders;
  };
  std::vector<Timed> orders;
  std::map<std::string, procman_lcm::deputy_info_t> recorded_final;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    const std::string ch = ev->channel;
    if (ch == "PM_ORDERS") {
      Timed t{ev->timestamp, {}};
      ASSERT_EQ(t.orders.decode(ev->data, 0, ev->datalen), ev->datalen);
      orders.push_back(t);
    } else if (ch == "PM_INFO") {
      procman_lcm::deputy_info_t info;
      ASSERT_EQ(info.decode(ev->data, 0, ev->datalen), ev->datalen);
      recorded_final[info.deputy_id] = info;
    }
  }
  ASSERT_FALSE(orders.empty());
  DeputyProcess up("up", url_), ours("ours", url_);
  waitReady("up");
  waitReady("ours");
  const double kMaxPauseS = 1.5;  // the recording has seconds between sheriff invocations
  for (size_t i = 0; i < orders.size(); ++i) {
    if (i > 0) spinFor(std::min(kMaxPauseS, (orders[i].t_us - orders[i - 1].t_us) * 1e-6));
    orders[i].orders.utime = nowUs();
    lcm_->publish("PM_ORDERS", &orders[i].orders);
  }
  for (const char* deputy : {"up", "ours"}) {
    const auto& want = recorded_final[deputy];
    ASSERT_FALSE(want.cmds.empty()) << deputy;
    for (const auto& w : want.cmds) {
      const std::string id = w.cmd.command_id;
      EXPECT_TRUE(spinUntil(
          [&] {
            auto s = status(deputy, id);
            return s && s->actual_runid == w.actual_runid && s->pid == 0;
          },
          15))
          << deputy << "/" << id;
      if (!w.cmd.auto_respawn) {
        auto s = status(deputy, id);
        ASSERT_TRUE(s.has_value());
        EXPECT_EQ(s->exit_code, w.exit_code) << deputy << "/" << id;
      }
    }
    const std::string crasher = output(deputy, "crasher");
    EXPECT_NE(crasher.find("crashing"), crasher.rfind("crashing")) << deputy << ": respawned at least once";
  }
}

}  // namespace
