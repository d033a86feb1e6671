// Unit tests of the procman library: exec strings, the configuration format, /proc readers, the sheriff's
// status logic, and wire compatibility of our procman_lcm types with upstream procman's (ashuang/procman 3fc4a80),
// judged on a recorded exchange with the upstream deputy and sheriff and on upstream's type fingerprints.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <optional>
#include <vector>

#include "procman/exec_string.hpp"
#include "procman/proc_info.hpp"
#include "procman/sheriff.hpp"
#include "procman/sheriff_config.hpp"
#include "procman_lcm/cmd_desired_t.hpp"
#include "procman_lcm/cmd_status_t.hpp"
#include "procman_lcm/cmd_t.hpp"
#include "procman_lcm/deputy_info_t.hpp"
#include "procman_lcm/discovery_t.hpp"
#include "procman_lcm/orders_t.hpp"
#include "procman_lcm/output_t.hpp"

namespace pm = ips::procman;

namespace {

std::optional<std::string> lookupIn(const std::map<std::string, std::string>& env, const std::string& name) {
  auto it = env.find(name);
  if (it == env.end()) return std::nullopt;
  return it->second;
}

pm::ExecSpec parse(const std::string& s, const std::map<std::string, std::string>& env = {}) {
  return pm::parseExecString(s, [&](const std::string& n) { return lookupIn(env, n); });
}

using Words = std::vector<std::string>;

}  // namespace

// Expected words below follow the upstream deputy's code (ashuang/procman 3fc4a80, SeparateArgs and
// ExpandVariables in src/procman/exec_string_utils.cpp). Its behaviour on $HOME inside single quotes,
// ${NAME:-default}, an unset variable and a last one-character word was also observed with the real upstream
// deputy (WireCompatibility.RecordedExchangeWithUpstreamDecodesBothWays).
TEST(ExecString, SplitsWordsLikeTheUpstreamDeputy) {
  // The upstream procman test configuration's argument test (test/test.cfg).
  const auto spec = parse(R"(bash -c 'echo arg0: [$0] arg1: "$1" arg2: [$2]' abc "def ghi" 'jkl mno pqr')");
  EXPECT_EQ(spec.argv,
            (Words{"bash", "-c", R"(echo arg0: [$0] arg1: "$1" arg2: [$2])", "abc", "def ghi", "jkl mno pqr"}));
  EXPECT_TRUE(spec.env.empty());
  EXPECT_EQ(parse(R"(a\ b "c\"d" e\\f)").argv, (Words{"a b", "c\"d", "e\\"}));  // "e\\f": backslash rule of expansion
  EXPECT_EQ(parse("  x   y\t zz  ").argv, (Words{"x", "y", "zz"}));
  EXPECT_EQ(parse("x '' \"\" yy").argv, (Words{"x", "", "", "yy"}));
  // A backslash works inside single quotes too; the other quote character is literal inside a quote.
  EXPECT_EQ(parse(R"(x 'it\'s' "say 'hi'" 'a"b')").argv, (Words{"x", "it's", "say 'hi'", "a\"b"}));
  // An unclosed quote runs to the end; a trailing backslash stays.
  EXPECT_EQ(parse("echo 'open end").argv, (Words{"echo", "open end"}));
  EXPECT_EQ(parse("echo ab\\").argv, (Words{"echo", "ab\\"}));
}

TEST(ExecString, LeadingWordsWithEqualsBecomeEnvironment) {
  const auto spec = parse(R"(ABC=def GHI="jkl mno" P=$HOME bash -c 'echo $ABC' X=1)", {{"HOME", "/h"}});
  ASSERT_EQ(spec.env.size(), 3u);
  EXPECT_EQ(spec.env[0], (std::pair<std::string, std::string>{"ABC", "def"}));
  EXPECT_EQ(spec.env[1], (std::pair<std::string, std::string>{"GHI", "jkl mno"}));
  EXPECT_EQ(spec.env[2], (std::pair<std::string, std::string>{"P", "$HOME"}));  // values are not expanded
  EXPECT_EQ(spec.argv, (Words{"bash", "-c", "echo $ABC", "X=1"}));
  EXPECT_EQ(parse("A=b=c prog").env[0], (std::pair<std::string, std::string>{"A", "b=c"}));
}

TEST(ExecString, ExpandsVariablesAfterQuoteRemoval) {
  const std::map<std::string, std::string> env = {{"ROOT", "/opt/ips"}, {"SPACE", "a b"}, {"EMPTY", ""}};
  // Single quotes do not protect: expansion runs on each word after quote removal. Values are not split.
  EXPECT_EQ(parse("$ROOT/bin/tracker --config ${ROOT}/config/x.yaml '$ROOT' $SPACE \"<$EMPTY>\" end", env).argv,
            (Words{"/opt/ips/bin/tracker", "--config", "/opt/ips/config/x.yaml", "/opt/ips", "a b", "<>", "end"}));
  // Unset variables, bare $, names starting with a digit, and ${...} that is not ${NAME} stay literally.
  EXPECT_EQ(parse("p $UNSET ${UNSET} $ $5 a$ ${} ${ROOT", env).argv,
            (Words{"p", "$UNSET", "${UNSET}", "$", "$5", "a$", "${}", "${ROOT"}));
  EXPECT_EQ(parse("play ${LOG:-out/run.lcmlog} ${ROOT:-/x} $ROOT_DIR $ROOT-x", env).argv,
            (Words{"play", "${LOG:-out/run.lcmlog}", "${ROOT:-/x}", "$ROOT_DIR", "/opt/ips-x"}));
  // An escaped $ is still expanded (the backslash is gone after splitting); a backslash left in a word keeps
  // itself and drops the next character.
  EXPECT_EQ(parse("p \\$ROOT a\\\\bc", env).argv, (Words{"p", "/opt/ips", "a\\c"}));
}

TEST(ExecString, RejectsStringsWithoutProgram) {
  EXPECT_THROW(parse(""), pm::ExecStringError);
  EXPECT_THROW(parse("   "), pm::ExecStringError);
  EXPECT_THROW(parse("A=1 B=2"), pm::ExecStringError);
  EXPECT_THROW(parse("=1 prog"), pm::ExecStringError);
}

TEST(SheriffConfig, ParsesGroupsCommandsAndScripts) {
  const char* text = R"(
# a comment
group "sensors" {
    cmd "camera" {
        exec = "camera --rate 8";   # trailing comment
        deputy = "head";
        auto_respawn = "true";
        stop_signal = 15;
        stop_time_allowed = 3;
    }
    group "inertial" {
        cmd "imu" { exec = "imu"; host = "head"; auto_respawn = false; stop_time_allowed = 0.5; }
    }
}
cmd "viewer" { exec = "viewer \"with quotes\""; }
script "up" {
    start group "sensors" wait "running";
    wait ms 250;
    start cmd "viewer";
    wait cmd "viewer" status "running";
    restart everything;
    stop group "sensors/inertial" wait "stopped";
    run_script "down";
}
script "down" { stop everything wait "stopped"; }
)";
  const pm::SheriffConfig cfg = pm::parseSheriffConfig(text, "test.pmd");
  ASSERT_EQ(cfg.commands.size(), 3u);
  const auto& camera = cfg.commands[0];
  EXPECT_EQ(camera.id, "camera");
  EXPECT_EQ(camera.exec, "camera --rate 8");
  EXPECT_EQ(camera.deputy, "head");
  EXPECT_EQ(camera.group, "sensors");
  EXPECT_TRUE(camera.auto_respawn);
  EXPECT_EQ(camera.stop_signal, 15);
  EXPECT_DOUBLE_EQ(camera.stop_time_allowed, 3.0);
  const auto& imu = cfg.commands[1];
  EXPECT_EQ(imu.group, "sensors/inertial");
  EXPECT_EQ(imu.deputy, "head");
  EXPECT_FALSE(imu.auto_respawn);
  EXPECT_EQ(imu.stop_signal, 2);
  EXPECT_DOUBLE_EQ(imu.stop_time_allowed, 0.5);
  const auto& viewer = cfg.commands[2];
  EXPECT_EQ(viewer.exec, "viewer \"with quotes\"");
  EXPECT_EQ(viewer.deputy, "");
  EXPECT_EQ(viewer.group, "");
  EXPECT_DOUBLE_EQ(viewer.stop_time_allowed, 7.0);
  EXPECT_EQ(cfg.groups, (std::vector<std::string>{"sensors", "sensors/inertial"}));

  const pm::Script* up = cfg.findScript("up");
  ASSERT_NE(up, nullptr);
  ASSERT_EQ(up->actions.size(), 7u);
  EXPECT_EQ(up->actions[0].describe(), "start group \"sensors\" wait \"running\"");
  EXPECT_EQ(up->actions[1].type, pm::ActionType::kWaitMs);
  EXPECT_EQ(up->actions[1].delay_ms, 250);
  EXPECT_EQ(up->actions[2].describe(), "start cmd \"viewer\"");
  EXPECT_EQ(up->actions[3].describe(), "wait cmd \"viewer\" status \"running\"");
  EXPECT_EQ(up->actions[4].describe(), "restart everything");
  EXPECT_EQ(up->actions[5].describe(), "stop group \"sensors/inertial\" wait \"stopped\"");
  EXPECT_EQ(up->actions[6].describe(), "run_script \"down\"");
  EXPECT_NE(cfg.findScript("down"), nullptr);
  EXPECT_EQ(cfg.findScript("nope"), nullptr);
}

TEST(SheriffConfig, ErrorsNameFileLineAndProblem) {
  auto error = [](const std::string& text) {
    try {
      pm::parseSheriffConfig(text, "bad.pmd");
    } catch (const pm::ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error("cmd \"a\" {\n exec = \"x\";\n colour = \"red\";\n}").find("bad.pmd:3:"), std::string::npos);
  EXPECT_NE(error("cmd \"a\" {\n exec = \"x\";\n colour = \"red\";\n}").find("colour"), std::string::npos);
  EXPECT_NE(error("cmd \"a\" { deputy = \"d\"; }").find("has no exec"), std::string::npos);
  EXPECT_NE(error("cmd \"a\" { exec = \"x\" }").find("expected ';'"), std::string::npos);
  EXPECT_NE(error("cmd \"a\" { exec = \"x\"; }\ncmd \"a\" { exec = \"y\"; }").find("used twice"), std::string::npos);
  EXPECT_NE(error("cmd \"a\" { exec = \"x\"; auto_respawn = \"maybe\"; }").find("auto_respawn"), std::string::npos);
  EXPECT_NE(error("cmd \"a\" { exec = \"x\"; stop_signal = 0; }").find("out of range"), std::string::npos);
  EXPECT_NE(error("cmd \"a\" { exec = \"unterminated; }").find("unterminated"), std::string::npos);
  EXPECT_NE(error("script \"s\" { start cmd \"ghost\"; }").find("no command 'ghost'"), std::string::npos);
  EXPECT_NE(error("script \"s\" { stop group \"ghost\"; }").find("no group 'ghost'"), std::string::npos);
  EXPECT_NE(error("script \"s\" { run_script \"ghost\"; }").find("no script 'ghost'"), std::string::npos);
  EXPECT_NE(error("script \"s\" { wait ms 5 }").find("expected ';'"), std::string::npos);
  EXPECT_NE(error("cmd \"a/b\" { exec = \"x\"; }").find("'/'"), std::string::npos);
  EXPECT_NE(error("group \"g\" { cmd \"a\" { exec = \"x\"; }").find("expected '}'"), std::string::npos);
  EXPECT_NE(error("bogus").find("bad.pmd:1:1"), std::string::npos);
  // Same id on two deputies is allowed (ids are per deputy).
  EXPECT_EQ(error("cmd \"a\" { exec = \"x\"; deputy = \"d1\"; }\ncmd \"a\" { exec = \"x\"; deputy = \"d2\"; }"),
            "no error");
  EXPECT_THROW(pm::loadSheriffConfig("/nonexistent/x.pmd"), pm::ConfigError);
}

TEST(SheriffConfig, ProjectConfigurationsLoad) {
  const std::string dir = PROCMAN_SOURCE_DIR;
  auto deputyOf = [](const pm::SheriffConfig& cfg, const std::string& id) {
    for (const auto& c : cfg.commands)
      if (c.id == id) return c.deputy;
    return std::string("<missing>");
  };
  const auto local = pm::loadSheriffConfig(dir + "/system_local.pmd");
  for (const char* id : {"sim", "tracker", "filter", "e3d"}) EXPECT_NE(deputyOf(local, id), "<missing>") << id;
  EXPECT_NE(local.findScript("start_all"), nullptr);

  const auto vehicle = pm::loadSheriffConfig(dir + "/vehicle.pmd");
  for (const char* id : {"camera", "imu", "tilt", "tracker", "filter"})
    EXPECT_EQ(deputyOf(vehicle, id), "sensors") << id;
  EXPECT_EQ(deputyOf(vehicle, "e3d"), "processing");
  EXPECT_EQ(deputyOf(vehicle, "viewer"), "processing");
  EXPECT_NE(vehicle.findScript("start_all"), nullptr);

  const auto replay = pm::loadSheriffConfig(dir + "/replay.pmd");
  bool has_player = false;
  for (const auto& c : replay.commands) has_player = has_player || c.exec.find("log_player") != std::string::npos;
  EXPECT_TRUE(has_player);
  EXPECT_NE(replay.findScript("replay"), nullptr);
  EXPECT_NE(deputyOf(replay, "viewer"), "<missing>");
  EXPECT_NE(deputyOf(pm::loadSheriffConfig(dir + "/main_job.pmd"), "viewer"), "<missing>");
}

// What the upstream sheriff and deputy need of a configuration: a deputy named by every command (its sheriff
// refuses a command without one), and no ${NAME:-default} that a deputy would hand literally to a program
// (only to sh, which applies the default itself).
TEST(SheriffConfig, ProjectConfigurationsRunUnderUpstreamProcman) {
  for (const auto& entry : std::filesystem::directory_iterator(PROCMAN_SOURCE_DIR)) {
    if (entry.path().extension() != ".pmd") continue;
    const auto cfg = pm::loadSheriffConfig(entry.path().string());
    ASSERT_FALSE(cfg.commands.empty()) << entry.path();
    for (const auto& c : cfg.commands) {
      EXPECT_FALSE(c.deputy.empty()) << entry.path() << ": " << c.id << " names no deputy";
      // Every variable set: what is left of "${" is then a reference no deputy expands.
      const auto spec = pm::parseExecString(c.exec, [](const std::string&) { return std::optional<std::string>("v"); });
      if (spec.argv[0] == "sh") continue;
      for (const auto& word : spec.argv)
        EXPECT_EQ(word.find("${"), std::string::npos) << entry.path() << ": " << c.id << " passes " << word;
    }
  }
}

TEST(SheriffConfig, GroupContainment) {
  EXPECT_TRUE(pm::groupContains("a", "a"));
  EXPECT_TRUE(pm::groupContains("a", "a/b"));
  EXPECT_FALSE(pm::groupContains("a", "ab"));
  EXPECT_FALSE(pm::groupContains("a/b", "a"));
  EXPECT_TRUE(pm::groupContains("", "anything"));
}

TEST(ProcInfo, ParsesProcFilesExactly) {
  const auto root = std::filesystem::temp_directory_path() / ("procman_fakeproc_" + std::to_string(getpid()));
  std::filesystem::create_directories(root / "4242");
  std::ofstream(root / "stat") << "cpu  100 20 30 850 5 0 0 0 0 0\ncpu0 50 10 15 425 0 0 0 0 0 0\n";
  std::ofstream(root / "meminfo") << "MemTotal:       1000 kB\nMemFree:         200 kB\nMemAvailable:    600 kB\n"
                                     "SwapTotal:       300 kB\nSwapFree:        100 kB\n";
  // A command name with spaces and a ')' must not shift the fields.
  std::ofstream(root / "4242" / "stat")
      << "4242 (odd) name) S 1 4242 4242 0 -1 4194560 100 0 0 0 77 33 0 0 20 0 1 0 12345 8192000 250 "
         "18446744073709551615 1 1 0 0 0 0 0 0 0 0 0 0 17 1 0 0 0 0 0\n";
  pm::SystemTimes sys;
  ASSERT_TRUE(pm::readSystemTimes(sys, root.string()));
  EXPECT_EQ(sys.user, 100u);
  EXPECT_EQ(sys.nice, 20u);
  EXPECT_EQ(sys.system, 30u);
  EXPECT_EQ(sys.idle, 850u);
  EXPECT_EQ(sys.mem_total_bytes, 1000 * 1024);
  EXPECT_EQ(sys.mem_free_bytes, 600 * 1024);
  EXPECT_EQ(sys.swap_total_bytes, 300 * 1024);
  EXPECT_EQ(sys.swap_free_bytes, 100 * 1024);
  pm::ProcessTimes p;
  ASSERT_TRUE(pm::readProcessTimes(4242, p, root.string()));
  EXPECT_EQ(p.user, 77u);
  EXPECT_EQ(p.system, 33u);
  EXPECT_EQ(p.vsize_bytes, 8192000);
  EXPECT_EQ(p.rss_bytes, 250 * sysconf(_SC_PAGESIZE));
  EXPECT_FALSE(pm::readProcessTimes(4243, p, root.string()));
  std::filesystem::remove_all(root);
}

TEST(ProcInfo, LoadAndUsageArithmetic) {
  pm::SystemTimes a, b;
  a.user = 100, a.nice = 0, a.system = 100, a.idle = 800;
  b.user = 150, b.nice = 10, b.system = 140, b.idle = 1000;  // 300 elapsed, 100 busy
  EXPECT_NEAR(pm::cpuLoad(a, b), 100.0 / 300.0, 1e-6);
  EXPECT_EQ(pm::cpuLoad(b, a), 0.f);  // counters going back: no load rather than garbage
  pm::ProcessTimes pa, pb;
  pa.user = 10, pa.system = 5;
  pb.user = 70, pb.system = 20;  // 75 of 300
  EXPECT_NEAR(pm::processCpuUsage(pa, pb, a, b), 0.25, 1e-6);
  EXPECT_EQ(pm::processCpuUsage(pa, pb, a, a), 0.f);
}

TEST(ProcInfo, ReadsThisProcess) {
  // Touch 64 MB so that it is resident, then burn 0.3 s of CPU time.
  std::vector<char> block(64 << 20);
  for (size_t i = 0; i < block.size(); i += 4096) block[i] = static_cast<char>(i);
  pm::ProcessTimes before, after;
  ASSERT_TRUE(pm::readProcessTimes(getpid(), before));
  const std::clock_t start = std::clock();
  volatile double sink = 0;
  while (std::clock() - start < CLOCKS_PER_SEC * 3 / 10) sink = sink + 1.0;
  ASSERT_TRUE(pm::readProcessTimes(getpid(), after));
  EXPECT_GE(after.rss_bytes, 64 << 20);
  EXPECT_GE(after.vsize_bytes, after.rss_bytes);
  const long hz = sysconf(_SC_CLK_TCK);
  EXPECT_GE(static_cast<double>((after.user + after.system) - (before.user + before.system)), 0.2 * hz);
  pm::SystemTimes sys;
  ASSERT_TRUE(pm::readSystemTimes(sys));
  EXPECT_GT(sys.mem_total_bytes, after.rss_bytes);
  EXPECT_GT(sys.user + sys.system + sys.idle, 0u);
  EXPECT_EQ(block[4096], static_cast<char>(4096));
}

TEST(SheriffStatus, FollowsDesiredAndReportedState) {
  pm::SheriffCommand c;
  c.config.stop_signal = SIGINT;
  EXPECT_EQ(pm::commandStatus(c), pm::CommandStatus::kUnknown);
  c.reported = true;
  c.desired_runid = 1, c.actual_runid = 0, c.force_quit = false, c.pid = 0;
  EXPECT_EQ(pm::commandStatus(c), pm::CommandStatus::kTryingToStart);
  c.actual_runid = 1, c.pid = 123;
  EXPECT_EQ(pm::commandStatus(c), pm::CommandStatus::kRunning);
  c.desired_runid = 2;
  EXPECT_EQ(pm::commandStatus(c), pm::CommandStatus::kRestarting);
  c.desired_runid = 1, c.force_quit = true;
  EXPECT_EQ(pm::commandStatus(c), pm::CommandStatus::kTryingToStop);
  c.pid = 0, c.exit_code = SIGINT;  // raw wait status of a process killed by SIGINT
  EXPECT_EQ(pm::commandStatus(c), pm::CommandStatus::kStoppedOk);
  c.force_quit = false, c.exit_code = 3 << 8;  // exited on its own with status 3
  EXPECT_EQ(pm::commandStatus(c), pm::CommandStatus::kStoppedError);
  c.exit_code = SIGSEGV;
  EXPECT_EQ(pm::commandStatus(c), pm::CommandStatus::kStoppedError);
  c.exit_code = 0;
  EXPECT_EQ(pm::commandStatus(c), pm::CommandStatus::kStoppedOk);
  EXPECT_EQ(pm::describeWaitStatus(0), "0");
  EXPECT_EQ(pm::describeWaitStatus(3 << 8), "exit(3)");
  EXPECT_EQ(pm::describeWaitStatus(SIGKILL), "SIGKILL");
}

// Upstream's type fingerprints (lcm-gen 1.3.1 over ashuang/procman 3fc4a80's lcmtypes/*.lcm, as its deputy and
// sheriff put them in front of every message): ours must be the same numbers, or neither side decodes the other.
TEST(WireCompatibility, FingerprintsAreUpstreams) {
  EXPECT_EQ(procman_lcm::cmd_t::getHash(), static_cast<int64_t>(0x2277f449a855d330ULL));
  EXPECT_EQ(procman_lcm::cmd_desired_t::getHash(), static_cast<int64_t>(0xb2a6c7a09ba54539ULL));
  EXPECT_EQ(procman_lcm::cmd_status_t::getHash(), static_cast<int64_t>(0xa8e0208786cf86e3ULL));
  EXPECT_EQ(procman_lcm::deputy_info_t::getHash(), static_cast<int64_t>(0x8876aeb040efd01fULL));
  EXPECT_EQ(procman_lcm::orders_t::getHash(), static_cast<int64_t>(0xd343f45b171ab855ULL));
  EXPECT_EQ(procman_lcm::output_t::getHash(), static_cast<int64_t>(0x8efa5caf5da01eb3ULL));
  EXPECT_EQ(procman_lcm::discovery_t::getHash(), static_cast<int64_t>(0xb1c83182bed74b95ULL));
}

// upstream_exchange.lcmlog: what our sheriff and the upstream deputy ("up"), then the upstream sheriff and our
// deputy ("ours") sent each other (procman 3fc4a80 built outside the project; tests/procman/README.md says how it
// was recorded): start, restart and stop of a command, an auto-respawn command, and output. Every message, whoever
// sent it, must carry our type's fingerprint and decode with our code and encode again to the same bytes; and each
// deputy's last report must carry out the last orders the other side's sheriff gave it (so upstream's deputy
// understood our sheriff's orders, and our deputy upstream's sheriff's).
namespace {

template <class Ours>
void expectSameBytes(const lcm::LogEvent* ev) {
  ASSERT_GE(ev->datalen, 8) << ev->channel << " #" << ev->eventnum;
  uint64_t fingerprint = 0;
  for (int i = 0; i < 8; ++i) fingerprint = fingerprint << 8 | static_cast<const uint8_t*>(ev->data)[i];
  EXPECT_EQ(static_cast<int64_t>(fingerprint), Ours::getHash()) << ev->channel << " #" << ev->eventnum;
  Ours ours;
  ASSERT_EQ(ours.decode(ev->data, 0, ev->datalen), ev->datalen) << ev->channel << " #" << ev->eventnum;
  std::vector<uint8_t> again(static_cast<size_t>(ours.getEncodedSize()));
  ASSERT_EQ(ours.encode(again.data(), 0, static_cast<int>(again.size())), ev->datalen);
  EXPECT_EQ(0, std::memcmp(again.data(), ev->data, again.size())) << ev->channel << " #" << ev->eventnum;
}

}  // namespace

TEST(WireCompatibility, RecordedExchangeWithUpstreamDecodesBothWays) {
  lcm::LogFile log(std::string(PROCMAN_TEST_DIR) + "/upstream_exchange.lcmlog", "r");
  ASSERT_TRUE(log.good());
  std::map<std::string, int> count;  // channel/sender
  std::map<std::string, procman_lcm::orders_t> last_orders;
  std::map<std::string, procman_lcm::deputy_info_t> last_info;
  std::map<std::string, std::string> output;  // deputy/command -> text
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    const std::string ch = ev->channel;
    if (ch == "PM_ORDERS") {
      expectSameBytes<procman_lcm::orders_t>(ev);
      procman_lcm::orders_t m;
      m.decode(ev->data, 0, ev->datalen);
      last_orders[m.deputy_id] = m;
      ++count[ch + "/" + m.deputy_id];
    } else if (ch == "PM_INFO") {
      expectSameBytes<procman_lcm::deputy_info_t>(ev);
      procman_lcm::deputy_info_t m;
      m.decode(ev->data, 0, ev->datalen);
      last_info[m.deputy_id] = m;
      ++count[ch + "/" + m.deputy_id];
    } else if (ch == "PM_OUTPUT") {
      expectSameBytes<procman_lcm::output_t>(ev);
      procman_lcm::output_t m;
      m.decode(ev->data, 0, ev->datalen);
      for (size_t i = 0; i < m.command_ids.size(); ++i) output[m.deputy_id + "/" + m.command_ids[i]] += m.text[i];
      ++count[ch + "/" + m.deputy_id];
    } else if (ch == "PM_DISCOVER") {
      expectSameBytes<procman_lcm::discovery_t>(ev);
    } else {
      ADD_FAILURE() << "unexpected channel " << ch;
    }
  }
  // Both directions are in the recording: orders to and reports from the upstream deputy and ours.
  for (const char* key :
       {"PM_ORDERS/up", "PM_ORDERS/ours", "PM_INFO/up", "PM_INFO/ours", "PM_OUTPUT/up", "PM_OUTPUT/ours"})
    EXPECT_GT(count[key], 0) << key;
  EXPECT_EQ(last_orders["up"].sheriff_id.rfind("procman-sheriff@", 0), 0u) << "orders to 'up' came from ours";

  // Each deputy did what the other side's sheriff ordered last: every command at the ordered run id, stopped
  // where force_quit is set; the restarted ticker ran twice and ended by its stop signal (SIGTERM).
  for (const char* deputy : {"up", "ours"}) {
    const auto& orders = last_orders[deputy];
    const auto& info = last_info[deputy];
    ASSERT_EQ(info.cmds.size(), orders.cmds.size()) << deputy;
    for (const auto& want : orders.cmds) {
      const auto it = std::find_if(info.cmds.begin(), info.cmds.end(), [&](const procman_lcm::cmd_status_t& s) {
        return s.cmd.command_id == want.cmd.command_id;
      });
      ASSERT_NE(it, info.cmds.end()) << deputy << "/" << want.cmd.command_id;
      EXPECT_EQ(it->actual_runid, want.desired_runid) << deputy << "/" << want.cmd.command_id;
      if (want.force_quit) {
        EXPECT_EQ(it->pid, 0) << deputy << "/" << want.cmd.command_id;
      }
      EXPECT_EQ(it->cmd.auto_respawn, want.cmd.auto_respawn);
      if (want.cmd.command_id == "ticker") {
        EXPECT_EQ(it->actual_runid, 2) << deputy;
        EXPECT_TRUE(want.force_quit) << deputy;
        EXPECT_TRUE(WIFSIGNALED(it->exit_code) && WTERMSIG(it->exit_code) == SIGTERM) << deputy;
      }
    }
    // Output: the auto-respawn command was respawned (printed more than once); exec strings expanded alike
    // ($HOME inside single quotes by the deputy, ${NOPE:-d} left to sh).
    const std::string crasher = output[std::string(deputy) + "/crasher"];
    size_t runs = 0;
    for (size_t p = crasher.find("crashing"); p != std::string::npos; p = crasher.find("crashing", p + 1)) ++runs;
    EXPECT_GE(runs, 2u) << deputy;
    EXPECT_NE(output[std::string(deputy) + "/expand"].find("default=[d] unset=[]"), std::string::npos) << deputy;
    EXPECT_EQ(output[std::string(deputy) + "/expand"].find("single=[$HOME]"), std::string::npos) << deputy;
  }
  // What differs: the upstream deputy's pseudo-terminal turns "\n" into "\r\n"; ours does not. And its
  // splitter drops a last one-character word ("echo a b c" prints "a b").
  EXPECT_NE(output["up/ticker"].find("tick 0\r\n"), std::string::npos);
  EXPECT_NE(output["ours/ticker"].find("tick 0\n"), std::string::npos);
  EXPECT_EQ(output["ours/ticker"].find('\r'), std::string::npos);
  EXPECT_NE(output["up/lastword"].find("a b\r\n"), std::string::npos);
  EXPECT_NE(output["ours/lastword"].find("a b c\n"), std::string::npos);
}
