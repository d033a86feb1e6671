// procman-deputy: starts, watches and stops the commands a procman sheriff orders over LCM on this machine.
// The options are the upstream procman deputy's, so either can be started by the same scripts.
#include <fcntl.h>
#include <getopt.h>
#include <libgen.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>

#include "procman/deputy.hpp"

namespace {

void usage(FILE* out) {
  std::fprintf(out,
               "usage: procman-deputy [options]\n"
               "\n"
               "Starts, watches and stops the commands a procman sheriff orders over LCM (channels PM_ORDERS,\n"
               "PM_INFO, PM_OUTPUT, PM_DISCOVER; message package procman_lcm).\n"
               "\n"
               "  -h, --help          show this text and exit\n"
               "  -v, --verbose       log every action to stderr\n"
               "  -i, --id NAME       deputy id (default: the host name); -n, --name NAME is the same\n"
               "  -u, --lcmurl URL    LCM URL (default: $LCM_DEFAULT_URL or LCM's default); --lcm-url URL is the same\n"
               "  -l, --log PATH      append stdout and stderr to PATH\n"
               "\n"
               "The directory holding procman-deputy is put first on PATH, so commands built next to it are found.\n"
               "\n"
               "EXIT STATUS\n"
               "  0   clean exit after SIGINT or SIGTERM (all commands stopped)\n"
               "  1   error (bad option, LCM, log file)\n"
               "  2   another deputy with the same id is running\n");
}

}  // namespace

int main(int argc, char** argv) {
  const option long_opts[] = {{"help", no_argument, nullptr, 'h'},         {"verbose", no_argument, nullptr, 'v'},
                              {"id", required_argument, nullptr, 'i'},     {"name", required_argument, nullptr, 'n'},
                              {"lcmurl", required_argument, nullptr, 'u'}, {"lcm-url", required_argument, nullptr, 'u'},
                              {"log", required_argument, nullptr, 'l'},    {nullptr, 0, nullptr, 0}};
  ips::procman::DeputyOptions options;
  std::string log_path;
  int c;
  while ((c = getopt_long(argc, argv, "hvi:n:u:l:", long_opts, nullptr)) >= 0) {
    switch (c) {
      case 'h':
        usage(stdout);
        return 0;
      case 'v':
        options.verbose = true;
        break;
      case 'i':
      case 'n':
        options.deputy_id = optarg;
        break;
      case 'u':
        options.lcm_url = optarg;
        break;
      case 'l':
        log_path = optarg;
        break;
      default:
        usage(stderr);
        return ips::procman::kExitError;
    }
  }
  if (optind < argc) {
    std::fprintf(stderr, "procman-deputy: unexpected argument '%s'\n", argv[optind]);
    usage(stderr);
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
