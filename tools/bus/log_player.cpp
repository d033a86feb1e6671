// log_player: plays an LCM log at its recorded pace (or a multiple of it) on both buses: the bulk channels (images,
// dense maps: channels::isBulkChannel) on the bulk URL, everything else on the control URL, from one clock, so that
// the two streams keep their recorded timing against each other. lcm-logplayer plays one URL; two of them with -e
// would each start their own clock. A log written before STEREO_TIME existed gets it from each STEREO (the filter
// takes image times from it), as the head publishes it.
//
//   log_player --log FILE.lcmlog [--speed 1.0] [--lcm-url URL] [--bulk-lcm-url URL] [--nice N]
//
// Last line: "played=N events (S stereo pairs) in T s, late=L" (late: events published more than 20 ms after their
// time: the machine could not keep the pace). Its health (HEALTH_LOG_PLAYER) says once a second what it played, and
// at the end whether it played the whole log (played_to_end), for the report's completeness check.
#include <chrono>
#include <cstdio>
#include <ips/stereo_pair_t.hpp>
#include <thread>

#include "ips/args.hpp"
#include "ips/framework/channels.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/log_reader.hpp"
#include "ips/framework/log_writer.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/process.hpp"

int main(int argc, char** argv) {
  return ips::fw::guardedMain("log_player", [&]() {
    ips::Args args(argc, argv, "plays an LCM log at its pace on the control and the bulk bus, from one clock");
    args.required("--log", "FILE.lcmlog", "the log")
        .option("--speed", "X", "pace: 1 real time, 0.25 a quarter of it (> 0)", "1.0");
    // --nice as the processes': the player stands for the drivers.
    ips::fw::addBusOptions(args);
    if (!args.parse()) return 0;
    const double speed = args.getDouble("--speed");
    if (!(speed >= 1e-3 && speed <= 1e3)) throw ips::ArgError("log_player: --speed must be in [0.001, 1000]");
    ips::fw::applyCommonOptions(args);
    ips::fw::installSignalHandlers();
    ips::fw::Node node("log_player", args.get("--lcm-url"));
    ips::fw::LogReader log(args.get("--log"));
    ips::fw::LogMessage e;
    using clock = std::chrono::steady_clock;
    const auto start = clock::now();
    int64_t first_us = 0, events = 0, pairs = 0, late = 0;
    auto last_health = clock::now();
    auto publishAccount = [&](bool to_end) {
      node.health().set("events_played", events);
      node.health().set("pairs_played", pairs);
      node.health().set("late_events", late);
      node.health().set("played_to_end", to_end ? 1 : 0);
      node.publishHealth(std::chrono::duration<double>(clock::now() - last_health).count());
      last_health = clock::now();
    };
    bool have_first = false, previous_was_time = false;
    while (!ips::fw::stopRequested() && log.next(&e)) {
      if (!have_first) first_us = e.timestamp, have_first = true;
      const auto due = start + std::chrono::microseconds(static_cast<int64_t>((e.timestamp - first_us) / speed));
      if (due > clock::now())
        std::this_thread::sleep_until(due);
      else if (clock::now() - due > std::chrono::milliseconds(20))
        ++late;
      if (e.channel == ips::channels::kStereo) {
        ++pairs;
        ips::stereo_pair_t m;
        // The stamp of an older log's pair (STEREO_TIME goes before each STEREO in the logs that have it).
        if (!previous_was_time && m.decode(e.data.data(), 0, static_cast<int>(e.data.size())) >= 0)
          node.publish(ips::channels::kStereoTime, ips::fw::stereoTimeOf(m));
      }
      previous_was_time = e.channel == ips::channels::kStereoTime;
      node.publishRaw(e.channel, e.data.data(), static_cast<unsigned>(e.data.size()));
      ++events;
      if (clock::now() - last_health >= std::chrono::seconds(1)) publishAccount(false);
    }
    // Its account, which the report reads: a recording without the player's last one, or with played_to_end 0,
    // covers part of the input.
    publishAccount(!ips::fw::stopRequested());
    std::printf("played=%lld events (%lld stereo pairs) in %.1f s, late=%lld\n", static_cast<long long>(events),
                static_cast<long long>(pairs), std::chrono::duration<double>(clock::now() - start).count(),
                static_cast<long long>(late));
    return 0;
  });
}
