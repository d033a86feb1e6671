#pragma once
// Checks of incoming messages before anything uses them. Each returns an empty string when the message is
// usable, else the reason (for the health counter) and a description. A process counts the reason and drops
// only that message.
#include <cstdint>
#include <ips/disparity_map_t.hpp>
#include <ips/filter_state_t.hpp>
#include <ips/imu_sample_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <ips/tilt_sample_t.hpp>
#include <ips/tracker_delta_t.hpp>
#include <string>

#include "ips/framework/health.hpp"

namespace ips::fw {

struct Verdict {
  std::string reason;  // "" when ok; else a counter name: "bad_size", "nan", "bad_value", ...
  std::string detail;
  bool ok() const { return reason.empty(); }
};

// Limits on image sizes a process accepts (a corrupt header must not make it allocate gigabytes).
inline constexpr int32_t kMaxImageSide = 16384;

Verdict validate(const ips::stereo_pair_t& m);
Verdict validate(const ips::imu_sample_t& m);
Verdict validate(const ips::tilt_sample_t& m);
Verdict validate(const ips::tracker_delta_t& m);
Verdict validate(const ips::filter_state_t& m);
Verdict validate(const ips::disparity_map_t& m);

// Order of one stream of stamped messages: time must increase; a sequence number that jumps means lost
// messages (counted, the message itself is fine).
class StreamOrder {
 public:
  struct Result {
    bool accept = true;  // false: the time went backwards or repeated
    int64_t gap = 0;     // messages missing before this one, from the sequence numbers
  };
  Result check(int64_t utime, int64_t seq);
  int64_t lastUtime() const { return last_utime_; }

 private:
  bool first_ = true;
  int64_t last_utime_ = 0;
  int64_t last_seq_ = 0;
};

// The checks every consumer of stereo pairs makes before it uses one: a valid message of the calibrated size
// whose stamp goes forward. Counts what it rejects (bad) and the pairs lost before this one (dropped, from
// the sequence numbers) in `health`; false means: drop this pair.
class StereoAdmission {
 public:
  StereoAdmission(int width, int height) : width_(width), height_(height) {}
  bool admit(const ips::stereo_pair_t& m, Health& health);

 private:
  int width_, height_;
  StreamOrder order_;
};

}  // namespace ips::fw
