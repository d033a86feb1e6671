// log_recorder: records the channels matching a regular expression into an LCM log (lcm-logger's format, read by
// lcm-logplayer, lcm-spy, log_player and ips_report), with room for every message a stall holds back.
// lcm-logger 1.3.1 keeps LCM's 30 messages per subscription and has no option to change it: beside the filters'
// states (2 x 200 Hz) and the ground truth (200 Hz) a logger kept from the CPU for 50 ms drops what came meanwhile.
// This one asks LCM for a queue of --queue messages (the bound on its memory: a small message is a few hundred
// bytes) and writes each event as it is handled; the kernel's socket buffer (tools/setup.sh) holds what arrives
// while the whole process is stopped.
//
//   log_recorder --out FILE.lcmlog [--channels REGEX] [--increment] [--queue N] [--lcm-url URL] [--nice N]
//
// --increment writes FILE.lcmlog.00, or .01, ... if that exists (as lcm-logger -i: a restarted recorder never
// overwrites). Each event's stamp is its receive time, as lcm-logger's. Last line: "recorded=N events to FILE".
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <lcm/lcm-cpp.hpp>

#include "ips/args.hpp"
#include "ips/framework/log_writer.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/process.hpp"

namespace {

std::string incrementedPath(const std::string& base) {
  for (int i = 0; i < 100; ++i) {
    char suffix[8];
    std::snprintf(suffix, sizeof(suffix), ".%02d", i);
    if (!std::filesystem::exists(base + suffix)) return base + suffix;
  }
  throw std::runtime_error(base + ": .00 to .99 exist already");
}

struct Recorder {
  ips::fw::LogWriter* log;
  void handle(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    const auto* data = static_cast<const uint8_t*>(rbuf->data);
    log->write(channel, rbuf->recv_utime, std::vector<uint8_t>(data, data + rbuf->data_size));
  }
};

}  // namespace

int main(int argc, char** argv) {
  return ips::fw::guardedMain("log_recorder", [&]() {
    ips::Args args(argc, argv, "records LCM channels into a log without dropping what a stall holds back");
    args.required("--out", "FILE.lcmlog", "the log to write")
        .option("--channels", "REGEX", "channels to record (LCM's regular expression, anchored)", ".*")
        .flag("--increment", "write FILE.00, .01, ...: the first that does not exist")
        .option("--queue", "N", "messages LCM may hold for the recorder (>= 30)", "100000");
    ips::fw::addBusOptions(args);
    if (!args.parse()) return 0;
    const long long queue = args.getInt("--queue");
    if (queue < 30 || queue > 10'000'000) throw ips::ArgError("log_recorder: --queue must be in [30, 10000000]");
    ips::fw::applyCommonOptions(args);
    ips::fw::installSignalHandlers();
    const std::string path = args.getFlag("--increment") ? incrementedPath(args.get("--out")) : args.get("--out");
    lcm::LCM lcm(args.get("--lcm-url"));
    if (!lcm.good()) throw std::runtime_error("cannot initialise LCM with the URL '" + args.get("--lcm-url") + "'");
    ips::fw::LogWriter log(path);
    Recorder recorder{&log};
    lcm::Subscription* sub = lcm.subscribe(args.get("--channels"), &Recorder::handle, &recorder);
    if (!sub) throw std::runtime_error("log_recorder: cannot subscribe to '" + args.get("--channels") + "'");
    sub->setQueueCapacity(static_cast<int>(queue));
    using clock = std::chrono::steady_clock;
    auto last_flush = clock::now();
    while (!ips::fw::stopRequested()) {
      // A signal (the stop request, or a stopped process resumed) interrupts LCM's wait: not a failure.
      if (lcm.handleTimeout(100) < 0 && errno != EINTR && !ips::fw::stopRequested())
        throw std::runtime_error(std::string("log_recorder: LCM failed while receiving: ") + std::strerror(errno));
      if (clock::now() - last_flush > std::chrono::milliseconds(100)) log.flush(), last_flush = clock::now();
    }
    // What LCM still holds when asked to stop.
    while (lcm.handleTimeout(0) > 0) {
    }
    log.flush();
    std::printf("recorded=%lld events to %s\n", static_cast<long long>(log.events()), path.c_str());
    return 0;
  });
}
