#pragma once
// Small valid messages of the project's types with every variable-length field in use, for tests that encode,
// mutate or replay them, and for the fuzz targets' seeds. Stamps are 1000 us unless given.
#include <climits>
#include <cstddef>
#include <cstdint>
#include <ips/disparity_map_t.hpp>
#include <ips/filter_state_t.hpp>
#include <ips/health_t.hpp>
#include <ips/point_cloud_t.hpp>
#include <string>
#include <utility>
#include <vector>

#include "ips/framework/log_writer.hpp"

namespace ips::test_support {

using ips::fw::encodeMessage;

// Writes v big-endian (LCM's byte order) into the 4 bytes at `at`.
inline void putBigEndian32(std::vector<uint8_t>& buf, size_t at, int32_t v) {
  const auto u = static_cast<uint32_t>(v);
  for (int i = 0; i < 4; ++i) buf[at + i] = static_cast<uint8_t>(u >> (24 - 8 * i));
}

// Calls visit(bytes, at, value) for every variant of a valid encoding with one 4-byte window after the type's
// fingerprint replaced by a hostile length: INT32_MIN, -1, 0, one more than the datagram, four times the
// datagram and INT32_MAX. Wherever a string length or an array count sits, one of these is what a faulty or
// malicious sender puts there.
template <class Visit>
void forEachHostileLength(const std::vector<uint8_t>& good, Visit visit) {
  const auto size = static_cast<int32_t>(good.size());
  const int32_t hostile[] = {INT32_MIN, -1, 0, size + 1, size * 4, INT32_MAX};
  for (size_t at = 8; at + 4 <= good.size(); ++at)  // the first 8 bytes are the type's fingerprint
    for (int32_t v : hostile) {
      std::vector<uint8_t> bad = good;
      putBigEndian32(bad, at, v);
      visit(bad, at, v);
    }
}

inline ips::disparity_map_t sampleDisparityMap(int64_t utime = 1000) {
  ips::disparity_map_t m{};
  m.utime = utime;
  m.width = 3;
  m.height = 2;
  m.subpixel_scale = 16;
  m.data.assign(2, std::vector<int16_t>(3, 32));
  m.confidence_size = 6;
  m.confidence.assign(6, 200);
  return m;
}

inline ips::filter_state_t sampleFilterState(int64_t utime = 1000) {
  ips::filter_state_t m{};
  m.utime = utime;
  m.orientation[0] = 1;
  m.up[2] = 1;
  m.cov_dim = 3;
  m.covariance.assign(3, std::vector<double>(3, 0.0));
  m.num_sensors = 1;
  m.sensor_names = {"tracker"};
  m.accepted = {1};
  m.rejected = {0};
  m.too_late = {0};
  return m;
}

inline ips::health_t sampleHealth(int64_t utime = 1000) {
  ips::health_t m{};
  m.utime = utime;
  m.process = "tracker";
  m.host = "head";
  m.num_counters = 2;
  m.counter_names = {"bad", "nan"};
  m.counter_values = {3, 1};
  return m;
}

// A process's health at `utime` (100 inputs received) with these counters, as a run's recording holds it.
inline ips::health_t healthWithCounters(int64_t utime, const std::string& process,
                                        const std::vector<std::pair<std::string, int64_t>>& counters) {
  ips::health_t h{};
  h.utime = utime;
  h.process = process;
  h.host = "test";
  h.received = 100;
  for (const auto& [name, value] : counters) {
    h.counter_names.push_back(name);
    h.counter_values.push_back(value);
  }
  h.num_counters = static_cast<int32_t>(counters.size());
  return h;
}

inline ips::point_cloud_t samplePointCloud(int64_t utime = 1000) {
  ips::point_cloud_t m{};
  m.utime = utime;
  m.frame = "world";
  m.num_points = 2;
  m.points = {{1, 2, 3}, {4, 5, 6}};
  m.intensity = {10, 20};
  return m;
}

}  // namespace ips::test_support
