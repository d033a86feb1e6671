#pragma once
// Small valid messages of the project's types with every variable-length field in use, for tests that encode,
// mutate or replay them, and for the fuzz targets' seeds. Stamps are 1000 us unless given.
#include <cstdint>
#include <ips/disparity_map_t.hpp>
#include <ips/filter_state_t.hpp>
#include <ips/health_t.hpp>
#include <ips/point_cloud_t.hpp>
#include <vector>

#include "ips/framework/log_writer.hpp"

namespace ips::test_support {

using ips::fw::encodeMessage;

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
