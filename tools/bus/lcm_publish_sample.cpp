// lcm_publish_sample: publishes one known message of a project type, repeatedly, and optionally bad ones.
// Used by the tests that check other programs (lcm-spy's jar, processes' bad-input counters) against values
// known here; handy for poking a running process by hand.
#include <chrono>
#include <cmath>
#include <ips/imu_sample_t.hpp>
#include <thread>

#include "ips/framework/channels.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/process.hpp"

int main(int argc, char** argv) {
  return ips::fw::guardedMain("lcm_publish_sample", [&]() {
    ips::Args args(argc, argv, "publish a known IMU sample (and bad inputs) for tests");
    args.option("--channel", "NAME", "channel", ips::channels::kImu)
        .option("--count", "N", "messages to publish", "50")
        .option("--period-ms", "MS", "pause between messages", "100")
        .option("--bad", "KIND", "publish bad inputs instead: garbage, nan, backwards");
    ips::fw::addBusOptions(args);
    if (!args.parse()) return 0;
    ips::fw::applyCommonOptions(args);
    ips::fw::Node node("lcm_publish_sample", args.get("--lcm-url"));
    const std::string bad = args.get("--bad");
    const long long count = args.getInt("--count");
    for (long long i = 0; i < count && !ips::fw::stopRequested(); ++i) {
      ips::imu_sample_t m;
      m.utime = 1'000'000 + 5'000 * i;
      m.seq = i;
      m.angular_rate[0] = 0.125;
      m.angular_rate[1] = -0.25;
      m.angular_rate[2] = 0.5;
      m.specific_force[0] = 0.0;
      m.specific_force[1] = 0.0;
      m.specific_force[2] = 9.80665;
      if (bad == "garbage") {
        const char junk[] = "this is not an LCM message";
        node.lcm().publish(args.get("--channel"), junk, sizeof(junk));
      } else {
        if (bad == "nan") m.angular_rate[1] = std::nan("");
        if (bad == "backwards") m.utime = 1'000'000 - 5'000 * (i + 1);  // each earlier than any sent before
        node.publish(args.get("--channel"), m);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(args.getInt("--period-ms")));
    }
    return 0;
  });
}
