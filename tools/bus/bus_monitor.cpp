// bus_monitor: a headless lcm-spy for the system's channels. Counts messages per channel, checks each with the
// same validation the processes use (sizes, NaN, time order, sequence gaps), and prints the health messages of
// running processes as a table. Ends after --duration seconds or --count messages on the first channel.
#include <zlib.h>

#include <chrono>
#include <cstdio>
#include <ips/ground_truth_t.hpp>
#include <ips/health_t.hpp>
#include <ips/point_cloud_t.hpp>
#include <map>
#include <set>
#include <sstream>

#include "ips/framework/channels.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/process.hpp"
#include "ips/framework/validate.hpp"

namespace {

struct ChannelStats {
  int64_t received = 0, bad = 0, gaps = 0, backwards = 0;
  int64_t first_utime = 0, last_utime = 0;
  uint64_t checksum = 0;
  ips::fw::StreamOrder order;
};

class Monitor {
 public:
  explicit Monitor(ips::fw::Node& node) : node_(node) {}

  void watch(const std::string& channel) {
    order_.push_back(channel);
    using namespace ips::channels;
    if (channel == kStereo)
      sub<ips::stereo_pair_t>(channel);
    else if (channel == kImu)
      sub<ips::imu_sample_t>(channel);
    else if (channel == kTilt)
      sub<ips::tilt_sample_t>(channel);
    else if (channel == kTrackerDelta || channel == kCloudDelta)
      sub<ips::tracker_delta_t>(channel);
    else if (channel == kFilterState || channel == kFilterPrior)
      sub<ips::filter_state_t>(channel);
    else if (channel == kDisparity || channel == kGtDisparity)
      sub<ips::disparity_map_t>(channel);
    else if (channel == kGtPose)
      sub<ips::ground_truth_t>(channel);
    else if (channel == kPoints || channel == kMonoPoints)
      sub<ips::point_cloud_t>(channel);
    else if (channel == kIntegrity)
      sub<ips::integrity_t>(channel);
    else if (channel == kKeyframe)
      sub<ips::keyframe_t>(channel);
    else if (channel == kStereoTime)
      sub<ips::stereo_time_t>(channel);
    else
      throw ips::ArgError("bus_monitor: no known type for channel '" + channel + "'");
  }

  void watchHealth() {
    node_.subscribeWithChannel<ips::health_t>(
        std::string(ips::channels::kHealthPrefix) + ".*",
        [this](const ips::health_t& h, const std::string& channel) {
          ips::fw::Verdict v = ips::fw::validate(h, channel);
          if (!v.ok()) return node_.health().bad(v.reason, v.detail);
          health_[h.process] = h;
          publishers_[h.process].insert(h.host + ":" + std::to_string(h.pid));
        },
        /*drop_repeats=*/false);  // an idle process reports alike twice
  }

  int64_t received(const std::string& channel) { return stats_[channel].received; }

  void print() const {
    for (const auto& ch : order_) {
      const ChannelStats& s = stats_.at(ch);
      const double span = (s.last_utime - s.first_utime) * 1e-6;
      const double rate = s.received > 1 && span > 0 ? (s.received - 1) / span : 0.0;
      std::printf("channel=%s received=%lld bad=%lld gaps=%lld backwards=%lld stamp_rate_hz=%.2f checksum=%llu\n",
                  ch.c_str(), static_cast<long long>(s.received), static_cast<long long>(s.bad),
                  static_cast<long long>(s.gaps), static_cast<long long>(s.backwards), rate,
                  static_cast<unsigned long long>(s.checksum));
    }
    if (!health_.empty()) {
      std::printf("%-14s %-12s %9s %9s %10s %6s %10s %10s %8s %8s\n", "process", "host", "in_hz", "out_hz",
                  "latency_ms", "queue", "received", "published", "dropped", "bad");
      for (const auto& kv : health_) {
        const ips::health_t& h = kv.second;
        std::printf("%-14s %-12s %9.2f %9.2f %10.2f %6d %10lld %10lld %8lld %8lld\n", h.process.c_str(), h.host.c_str(),
                    h.input_rate_hz, h.output_rate_hz, h.latency_ms, h.queue_length, static_cast<long long>(h.received),
                    static_cast<long long>(h.published), static_cast<long long>(h.dropped),
                    static_cast<long long>(h.bad));
        const auto& pubs = publishers_.at(kv.first);
        if (pubs.size() > 1) {
          std::string list;
          for (const auto& p : pubs) list += (list.empty() ? "" : ",") + p;
          std::printf("    %s: WARNING: %zu processes publish this health channel (host:pid %s)\n", h.process.c_str(),
                      pubs.size(), list.c_str());
        }
        for (int i = 0; i < h.num_counters; ++i)
          std::printf("    %s.%s=%lld\n", h.process.c_str(), h.counter_names[i].c_str(),
                      static_cast<long long>(h.counter_values[i]));
      }
    }
  }

 private:
  template <class Msg>
  void sub(const std::string& channel) {
    stats_[channel];
    node_.subscribe<Msg>(channel, [this, channel](const Msg& m) { onMessage(channel, m); });
  }

  template <class Msg>
  static int64_t seqOf(const Msg& m) {
    if constexpr (std::is_same_v<Msg, ips::stereo_pair_t> || std::is_same_v<Msg, ips::imu_sample_t> ||
                  std::is_same_v<Msg, ips::tilt_sample_t> || std::is_same_v<Msg, ips::tracker_delta_t> ||
                  std::is_same_v<Msg, ips::disparity_map_t> || std::is_same_v<Msg, ips::integrity_t> ||
                  std::is_same_v<Msg, ips::keyframe_t> || std::is_same_v<Msg, ips::stereo_time_t>)
      return m.seq;
    return 0;
  }

  template <class Msg>
  void onMessage(const std::string& channel, const Msg& m) {
    ChannelStats& s = stats_[channel];
    ++s.received;
    if constexpr (std::is_same_v<Msg, ips::ground_truth_t> || std::is_same_v<Msg, ips::point_cloud_t>) {
      // no validation rule for these beyond decoding
    } else {
      ips::fw::Verdict v = ips::fw::validate(m);
      if (!v.ok()) {
        ++s.bad;
        node_.health().bad(v.reason, channel + ": " + v.detail);
        return;
      }
    }
    const int64_t seq = seqOf(m);
    auto r = s.order.check(m.utime, seq != 0 ? seq : s.received, node_.arrivalUs());
    if (!r.accept) ++s.backwards;
    s.gaps += r.gap;
    if (s.first_utime == 0) s.first_utime = m.utime;
    s.last_utime = m.utime;
    if constexpr (std::is_same_v<Msg, ips::stereo_pair_t>) {
      uLong a = adler32(0L, Z_NULL, 0);
      a = adler32(a, m.left.data(), static_cast<uInt>(m.left.size()));
      a = adler32(a, m.right.data(), static_cast<uInt>(m.right.size()));
      s.checksum += a;
    }
  }

  ips::fw::Node& node_;
  std::vector<std::string> order_;
  std::map<std::string, ChannelStats> stats_;
  std::map<std::string, ips::health_t> health_;
  std::map<std::string, std::set<std::string>> publishers_;  // per process name: every host:pid seen
};

}  // namespace

int main(int argc, char** argv) {
  return ips::fw::guardedMain("bus_monitor", [&]() {
    ips::Args args(argc, argv, "count, check and summarise the system's LCM channels and process health");
    args.option("--channels", "A,B,...", "channels to watch", "STEREO,IMU,TILT,TRACKER_DELTA,FILTER_STATE,DISPARITY")
        .option("--duration", "S", "stop after this many seconds (0: until Ctrl-C)", "0")
        .option("--count", "N", "stop after N messages on the first channel (0: no limit)", "0")
        .flag("--no-health", "do not show HEALTH_* messages");
    ips::fw::addBusOptions(args);
    if (!args.parse()) return 0;
    ips::fw::applyCommonOptions(args);

    ips::fw::Node node("bus_monitor", args.get("--lcm-url"));
    Monitor monitor(node);
    std::stringstream ss(args.get("--channels"));
    std::string ch, first;
    while (std::getline(ss, ch, ',')) {
      if (ch.empty()) continue;
      if (first.empty()) first = ch;
      monitor.watch(ch);
    }
    if (!args.getFlag("--no-health")) monitor.watchHealth();
    const double duration = args.getDouble("--duration");
    const long long count = args.getInt("--count");
    const auto start = std::chrono::steady_clock::now();
    std::printf("ready\n");
    std::fflush(stdout);
    while (!ips::fw::stopRequested()) {
      node.handleOnce(50);
      if (count > 0 && !first.empty() && monitor.received(first) >= count) break;
      if (duration > 0 && std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() >= duration)
        break;
    }
    monitor.print();
    std::printf("bus_monitor decode_error=%lld duplicate=%lld bad=%lld\n",
                static_cast<long long>(node.health().counter("decode_error")),
                static_cast<long long>(node.health().counter("duplicate")),
                static_cast<long long>(node.health().badCount()));
    return 0;
  });
}
