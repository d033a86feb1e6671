#pragma once
// Maps a device's own clock (camera tick time stamps, an IMU sample counter times its period) onto the common
// clock, from pairs (device time, host arrival time). Arrival = event + transport latency, and the latency is
// never below some minimum but often above it (scheduling, interrupt moderation, a bus busy with another
// frame). So the drift (rate ratio) is a least-squares slope over a sliding window, and the offset is the
// lower envelope: the arrival that came fastest. The mapped time is "arrival with the minimum latency"; that
// minimum is a constant per sensor and belongs to the calibrated sensor delay.
#include <cstddef>
#include <cstdint>
#include <deque>

namespace ips::drivers {

struct ClockMapperPoint {
  double device;   // [us] relative to the first pair's device time
  double arrival;  // [us] relative to the first pair's arrival time
};

struct ClockMapperConfig {
  size_t window = 300;              // pairs kept for the fit (e.g. 10 s of frames at 30 Hz)
  size_t min_pairs_for_drift = 20;  // below this the rate ratio is taken as exactly 1
  double max_drift_ppm = 500.0;     // crystal clocks are within ~100 ppm; more means a wrong input
  int64_t reset_jump_us = 500'000;  // prediction error beyond this: the device clock jumped (restart): reset
};

class ClockMapper {
 public:
  explicit ClockMapper(ClockMapperConfig config = {});

  // Adds a pair and returns the device time mapped onto the common clock [us].
  int64_t update(int64_t device_us, int64_t arrival_us);
  // Maps without adding a pair (requires at least one update since the last reset).
  int64_t map(int64_t device_us) const;

  void reset();
  bool empty() const { return pairs_.empty(); }
  double driftPpm() const { return (slope_ - 1.0) * 1e6; }
  size_t resets() const { return resets_; }  // jumps detected (not counting the first pair)

 private:
  void refit();
  ClockMapperConfig config_;
  int64_t device_ref_ = 0, arrival_ref_ = 0;
  std::deque<ClockMapperPoint> pairs_;
  double slope_ = 1.0;
  double offset_ = 0.0;  // arrival = offset_ + slope_ * device (relative units), lower envelope
  size_t resets_ = 0;
};

}  // namespace ips::drivers
