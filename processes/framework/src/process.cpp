#include "ips/framework/process.hpp"

#include <sys/resource.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>

#include "ips/log.hpp"

namespace ips::fw {

void addBusOptions(Args& args) {
  args.option("--lcm-url", "URL", "LCM URL (default: $LCM_DEFAULT_URL, else LCM's default udpm://239.255.76.67:7667)")
      .option("--bulk-lcm-url", "URL",
              "LCM URL of the bulk channels, images and dense maps (default: $IPS_BULK_LCM_URL, else the LCM URL)")
      .option("--log-level", "LEVEL", "debug, info, warn or error", "info")
      .option("--nice", "N",
              "scheduling priority, -20 (first) to 19 (last): the process's nice value and its session's (see "
              "applyNice)");
}

void addCommonOptions(Args& args, const std::string& default_config) {
  addBusOptions(args);
  args.option("--config", "FILE", "YAML configuration of this process", default_config)
      .flag("--check-config", "read the configuration, refuse keys this process does not know, and exit")
      .flag("--print-config",
            "print the settings this process runs with (every key it reads: the file's value or its default) as "
            "YAML that --config takes, and exit");
}

void applyNice(int nice) {
  if (nice < -20 || nice > 19) throw ArgError("--nice must be in [-20, 19]");
  if (setpriority(PRIO_PROCESS, 0, nice) != 0)
    IPS_WARN("cannot set the nice value " << nice << " (" << std::strerror(errno) << "): running at "
                                          << getpriority(PRIO_PROCESS, 0));
  // The kernel weighs sessions against each other before nice values count within one (autogroup), and procman's
  // deputy starts every command in a session of its own: there the session's nice value is the one that counts.
  if (FILE* f = std::fopen("/proc/self/autogroup", "w")) {
    if (std::fprintf(f, "%d", nice) < 0 || std::fclose(f) != 0)
      IPS_WARN("cannot set the session's nice value " << nice << " (" << std::strerror(errno) << ")");
  }
}

void applyCommonOptions(const Args& args) {
  setLogLevel(parseLogLevel(args.get("--log-level")));
  if (args.has("--nice")) applyNice(static_cast<int>(args.getInt("--nice")));
  // The Nodes of this process read it from the environment, like LCM_DEFAULT_URL.
  if (args.has("--bulk-lcm-url")) setenv("IPS_BULK_LCM_URL", args.get("--bulk-lcm-url").c_str(), 1);
}

bool configChecked(const Args& args, const Config& cfg) {
  cfg.refuseUnreadKeys();
  if (args.getFlag("--print-config")) {
    std::fputs(cfg.effectiveYaml().c_str(), stdout);
    return true;
  }
  if (!args.getFlag("--check-config")) return false;
  std::printf("%s: every key is a setting of this process\n", cfg.path().c_str());
  return true;
}

int guardedMain(const std::string& process, const std::function<int()>& body) {
  setLogName(process);
  try {
    return body();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: error: %s\n", process.c_str(), e.what());
    return 1;
  }
}

}  // namespace ips::fw
