#pragma once
// What every process main shares: the common options and a guarded entry point.
#include <functional>
#include <string>

#include "ips/args.hpp"

namespace ips::fw {

// Declares --lcm-url, --config and --log-level on `args` (config default given per process).
void addCommonOptions(Args& args, const std::string& default_config);
// Applies --log-level.
void applyCommonOptions(const Args& args);

// Runs body(); turns exceptions into a message on stderr and exit code 1, so a bad config or device gives a
// clear line, not an abort.
int guardedMain(const std::string& process, const std::function<int()>& body);

}  // namespace ips::fw
