#pragma once
// What every process main shares: the common options and a guarded entry point.
#include <functional>
#include <string>

#include "ips/args.hpp"
#include "ips/config.hpp"

namespace ips::fw {

// Declares --lcm-url, --bulk-lcm-url, --log-level and --nice on `args`: a program on the buses without a
// configuration of its own (the players, bus_monitor).
void addBusOptions(Args& args);
// The bus options and --config, --check-config, --print-config (config default given per process).
void addCommonOptions(Args& args, const std::string& default_config);
// Applies --log-level, --bulk-lcm-url and --nice.
void applyCommonOptions(const Args& args);
// The process's scheduling priority, nice -20 (first) to 19 (last): its own nice value and its session's, which is
// what the kernel weighs where it groups scheduling by session (autogroup, the default of most distributions) and
// every command has a session of its own (procman's deputy). A value below 0 needs the right to raise priority
// (root, CAP_SYS_NICE); without it the process warns and runs at the nice value it has.
void applyNice(int nice);

// Called by a main once it has read all its settings from `cfg`: refuses a key nothing read (ConfigError naming the
// file and the keys: a misspelled key would otherwise leave its default in place without a word). With
// --check-config it says the file is good and returns true, and the main exits 0 before it opens a device or the bus;
// with --print-config it prints the effective settings (Config::effectiveYaml) and returns true.
bool configChecked(const Args& args, const Config& cfg);

// Runs body(); turns exceptions into a message on stderr and exit code 1, so a bad config or device gives a
// clear line, not an abort.
int guardedMain(const std::string& process, const std::function<int()>& body);

}  // namespace ips::fw
