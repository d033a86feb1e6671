#include "ips/framework/process.hpp"

#include <cstdio>
#include <exception>

#include "ips/log.hpp"

namespace ips::fw {

void addCommonOptions(Args& args, const std::string& default_config) {
  args.option("--lcm-url", "URL", "LCM URL (default: $LCM_DEFAULT_URL, else LCM's default udpm://239.255.76.67:7667)")
      .option("--config", "FILE", "YAML configuration of this process", default_config)
      .option("--log-level", "LEVEL", "debug, info, warn or error", "info");
}

void applyCommonOptions(const Args& args) { setLogLevel(parseLogLevel(args.get("--log-level"))); }

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
