// procman-deputy: starts, watches and stops the commands a procman sheriff orders over LCM on this machine.
// The options are the upstream procman deputy's, so either can be started by the same scripts.
#include <fcntl.h>
#include <libgen.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>

#include "ips/args.hpp"
#include "procman/deputy.hpp"

int main(int argc, char** argv) {
  ips::procman::DeputyOptions options;
  std::string log_path;
  try {
    ips::Args args(argc, argv,
                   "starts, watches and stops the commands a procman sheriff orders over LCM\n(channels PM_ORDERS, "
                   "PM_INFO, PM_OUTPUT, PM_DISCOVER; message package procman_lcm)");
    args.flag("--verbose", "log every action to stderr").alias("-v", "--verbose");
    args.option("--id", "NAME", "deputy id [default: the host name]").alias("-i", "--id");
    args.alias("-n", "--id").alias("--name", "--id");
    args.option("--lcm-url", "URL", "LCM URL [default: $LCM_DEFAULT_URL or LCM's default]").alias("-u", "--lcm-url");
    args.alias("--lcmurl", "--lcm-url");
    args.option("--log", "PATH", "append stdout and stderr to PATH").alias("-l", "--log");
    args.epilog(
        "The directory holding procman-deputy is put first on PATH, so commands built next to it are found.\n"
        "The options are the upstream procman deputy's, so either can be started by the same scripts.\n"
        "\n"
        "Exit status: 0 clean exit after SIGINT or SIGTERM (all commands stopped); 1 error (bad option, LCM,\n"
        "log file); 2 another deputy with the same id is running.");
    if (!args.parse()) return 0;
    options.verbose = args.getFlag("--verbose");
    if (args.has("--id")) options.deputy_id = args.get("--id");
    if (args.has("--lcm-url")) options.lcm_url = args.get("--lcm-url");
    log_path = args.get("--log");
  } catch (const ips::ArgError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return ips::procman::kExitError;
  }

  {
    std::string self = argv[0];
    if (self.find('/') != std::string::npos) {
      std::string dir = dirname(self.data());
      const char* path = std::getenv("PATH");
      setenv("PATH", (dir + ":" + (path ? path : "/usr/bin:/bin")).c_str(), 1);
    }
  }
  if (!log_path.empty()) {
    const int fd = open(log_path.c_str(), O_WRONLY | O_APPEND | O_CREAT, 0644);
    if (fd < 0) {
      std::fprintf(stderr, "procman-deputy: cannot open log file %s: %s\n", log_path.c_str(), std::strerror(errno));
      return ips::procman::kExitError;
    }
    dup2(fd, STDOUT_FILENO);
    dup2(fd, STDERR_FILENO);
    close(fd);
  }
  setvbuf(stdout, nullptr, _IOLBF, 0);
  setvbuf(stderr, nullptr, _IOLBF, 0);
  try {
    ips::procman::Deputy deputy(options);
    return deputy.run();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "procman-deputy: %s\n", e.what());
    return ips::procman::kExitError;
  }
}
