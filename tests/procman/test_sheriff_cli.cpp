// procman-sheriff's command line without LCM: what argv asks for, the errors and their exit status, the --check
// listing, and how a followed command's output is printed.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "procman/sheriff_cli.hpp"

namespace {

using ips::procman::parseSheriffCli;
using ips::procman::SheriffCliParse;

SheriffCliParse parse(std::vector<std::string> args) {
  args.insert(args.begin(), "procman-sheriff");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  return parseSheriffCli(static_cast<int>(args.size()), argv.data());
}

// The parse's exit status and what it printed on stderr.
std::pair<int, std::string> parseError(const std::vector<std::string>& args) {
  testing::internal::CaptureStderr();
  const SheriffCliParse p = parse(args);
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_FALSE(p.cli.has_value());
  return {p.exit_status, err};
}

TEST(SheriffCli, ActionsAndOptionsFromTheCommandLine) {
  const SheriffCliParse p = parse(
      {"--config",   "a.pmd",  "--stop",           "x",         "--start",  "g/sub",    "--start",
       "y",          "--wait", "running",          "--timeout", "2.5",      "-u",       "udpm://239.255.76.67:7700",
       "--id",       "me",     "--default-deputy", "d",         "--status", "--follow", "y",
       "--duration", "4",      "--stop-on-exit"});
  ASSERT_TRUE(p.cli.has_value());
  const ips::procman::SheriffCli& c = *p.cli;
  EXPECT_EQ(c.config_path, "a.pmd");
  EXPECT_EQ(c.stops, std::vector<std::string>{"x"});
  EXPECT_EQ(c.starts, (std::vector<std::string>{"g/sub", "y"}));
  EXPECT_TRUE(c.restarts.empty());
  EXPECT_EQ(c.wait_mode, ips::procman::SheriffCli::Wait::kRunning);
  EXPECT_EQ(c.timeout_s, 2.5);
  EXPECT_EQ(c.duration_s, 4.0);
  EXPECT_EQ(c.status_period_s, 0.0);
  EXPECT_EQ(c.options.lcm_url, "udpm://239.255.76.67:7700");
  EXPECT_EQ(c.options.sheriff_id, "me");
  EXPECT_EQ(c.options.default_deputy, "d");
  EXPECT_TRUE(c.status);
  EXPECT_EQ(c.follows, std::vector<std::string>{"y"});
  EXPECT_TRUE(c.stop_on_exit);
  EXPECT_FALSE(c.keep);
  EXPECT_TRUE(c.ordersNeeded());
}

TEST(SheriffCli, OnlyActionsThatSendOrdersNeedAConfiguration) {
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"--status"}, {"--follow", "x"}, {"--status", "-u", "udpm://239.255.76.67:7700"}}) {
    const SheriffCliParse p = parse(args);
    ASSERT_TRUE(p.cli.has_value()) << args[0];
    EXPECT_FALSE(p.cli->ordersNeeded()) << args[0];
  }
  for (const char* action : {"--start-all", "--stop-all", "--restart-all", "--keep-running"}) {
    const auto [status, err] = parseError({action});
    EXPECT_EQ(status, ips::procman::kSheriffExitError) << action;
    EXPECT_EQ(err, "procman-sheriff: this action needs --config FILE\n") << action;
    const SheriffCliParse p = parse({"--config", "a.pmd", action});
    ASSERT_TRUE(p.cli.has_value()) << action;
    EXPECT_TRUE(p.cli->ordersNeeded()) << action;
  }
  EXPECT_EQ(parseError({"--check"}).second, "procman-sheriff: this action needs --config FILE\n");
  EXPECT_EQ(parseError({"--script", "s"}).second, "procman-sheriff: this action needs --config FILE\n");
}

TEST(SheriffCli, ErrorsExitWithOneAndSayWhy) {
  EXPECT_EQ(parseError({"--status", "--wait", "soon"}).second,
            "procman-sheriff: --wait must be started, running or none\n");
  EXPECT_EQ(parseError({"--status", "--timeout", "-1"}).second,
            "procman-sheriff: --timeout must not be negative, got -1\n");
  EXPECT_EQ(parseError({"--status", "--duration", "3s"}).second,
            "procman-sheriff: option '--duration' needs a number, got '3s'\n");
  EXPECT_EQ(parseError({"--status", "--status-period", "1e"}).second,
            "procman-sheriff: option '--status-period' needs a number, got '1e'\n");
  EXPECT_EQ(parseError({"--status", "extra"}).second, "procman-sheriff: unexpected argument 'extra' (see --help)\n");
  EXPECT_EQ(parseError({"--status", "--colour"}),
            std::make_pair(1, std::string("procman-sheriff: unknown option '--colour' (see --help)\n")));
  EXPECT_EQ(parseError({"--status", "--follow"}).second, "procman-sheriff: option '--follow' needs a value (CMD)\n");
  // Without any action: the usage.
  EXPECT_NE(parseError({"--config", "a.pmd"}).second.find("Usage: procman-sheriff [--config FILE]"), std::string::npos);
}

TEST(SheriffCli, HelpPrintsTheUsageAndExitsWithZero) {
  testing::internal::CaptureStdout();
  const SheriffCliParse p = parse({"--status", "--help"});
  const std::string out = testing::internal::GetCapturedStdout();
  EXPECT_FALSE(p.cli.has_value());
  EXPECT_EQ(p.exit_status, 0);
  EXPECT_EQ(out.rfind("procman-sheriff: headless procman sheriff", 0), 0u);
  EXPECT_NE(out.find("\nActions:\n  --start-all"), std::string::npos) << out;
  EXPECT_NE(out.find("  -u, --lcm-url URL"), std::string::npos) << out;
}

TEST(SheriffCli, FollowedOutputIsPrefixedLineByLineWhenSeveralCommandsAreFollowed) {
  using ips::procman::followedOutput;
  EXPECT_EQ(followedOutput("a", "one\ntwo", false), "one\ntwo");
  EXPECT_EQ(followedOutput("a", "one\ntwo\n", true), "[a] one\n[a] two\n");
  EXPECT_EQ(followedOutput("a", "part", true), "[a] part");  // the rest of the line comes in the next message
  EXPECT_EQ(followedOutput("a", "", true), "");
  // A line is printed as a C string: it ends at a NUL byte, the next line is printed whole.
  EXPECT_EQ(followedOutput("a", std::string("x\0y\nz\n", 6), true), "[a] x[a] z\n");
  EXPECT_EQ(followedOutput("a", std::string("x\0y\n", 4), false), std::string("x\0y\n", 4));
}

TEST(SheriffCli, CheckListsTheConfiguration) {
  const std::string path = testing::TempDir() + "sheriff_cli.pmd";
  std::ofstream(path)
      << "group \"g\" {\n"
         "  cmd \"a\" { exec = \"sleep 1\"; deputy = \"d\"; stop_signal = 15; stop_time_allowed = 2; }\n"
         "}\n"
         "cmd \"b\" { exec = \"true\"; auto_respawn = \"true\"; }\n"
         "script \"s\" {\n  start cmd \"a\";\n  wait ms 200;\n}\n";
  const ips::procman::SheriffConfig config = ips::procman::loadSheriffConfig(path);
  FILE* out = std::tmpfile();
  ASSERT_NE(out, nullptr);
  ips::procman::printSheriffConfig("x.pmd", config, out);
  std::rewind(out);
  std::string text;
  for (int ch; (ch = std::fgetc(out)) != EOF;) text += static_cast<char>(ch);
  std::fclose(out);
  const std::string head = "x.pmd: 2 commands, 1 groups, 1 scripts\n";
  EXPECT_EQ(text.substr(0, head.size()), head);
  EXPECT_NE(text.find("cmd a deputy=d group=g auto_respawn=0 stop_signal=15 stop_time_allowed=2 exec=sleep 1\n"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("cmd b deputy=(default) group=- auto_respawn=1 "), std::string::npos) << text;
  EXPECT_NE(text.find("script s:\n  "), std::string::npos) << text;
}

}  // namespace
