#pragma once
// The loop of a serial-line driver process (imu, tilt): poll the reader, turn each sample into its message, check
// and publish it; the reader's unusable input goes into the health message's "bad" total by reason, and the
// reader's counters (plus the driver's own, from `extra_health`) into a health message once a second.
#include <chrono>
#include <functional>
#include <map>
#include <string>

#include "ips/framework/node.hpp"
#include "ips/framework/process.hpp"
#include "ips/framework/validate.hpp"

namespace ips::drivers {

template <class Reader, class ToMessage>
int runSerialDriver(fw::Node& node, Reader& reader, const std::string& device, const std::string& channel,
                    ToMessage to_message, const std::function<void(fw::Health&)>& extra_health = {}) {
  auto last_health = std::chrono::steady_clock::now();
  std::map<std::string, int64_t> reported;
  auto report_bad = [&] {
    const auto counters = reader.counters();
    for (const char* reason : {"checksum_errors", "bad_frames", "partial_frames"}) {
      const int64_t now_count = counters.at(reason);
      for (int64_t i = reported[reason]; i < now_count; ++i)
        node.health().bad(reason, std::string(reason) + " on " + device);
      reported[reason] = now_count;
    }
  };
  auto set_counters = [&] {
    for (const auto& [name, value] : reader.counters()) node.health().set(name, value);
    if (extra_health) extra_health(node.health());
  };
  while (!fw::stopRequested()) {
    for (const auto& sample : reader.poll(50)) {
      const auto msg = to_message(sample);
      node.health().received(msg.utime);
      const auto verdict = fw::validate(msg);
      if (!verdict.ok()) {
        node.health().bad(verdict.reason, verdict.detail);
        continue;
      }
      node.health().accepted();
      node.publish(channel, msg);
    }
    report_bad();
    const auto now = std::chrono::steady_clock::now();
    const double since = std::chrono::duration<double>(now - last_health).count();
    if (since >= 1.0) {
      set_counters();
      node.publishHealth(since);
      last_health = now;
    }
  }
  set_counters();
  node.publishHealth(1.0);
  return 0;
}

}  // namespace ips::drivers
