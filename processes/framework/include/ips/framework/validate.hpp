#pragma once
// Checks of incoming messages before anything uses them. Each returns an empty string when the message is
// usable, else the reason (for the health counter) and a description. A process counts the reason and drops
// only that message.
#include <algorithm>
#include <cstdint>
#include <ips/disparity_map_t.hpp>
#include <ips/filter_state_t.hpp>
#include <ips/health_t.hpp>
#include <ips/imu_sample_t.hpp>
#include <ips/integrity_t.hpp>
#include <ips/keyframe_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <ips/stereo_time_t.hpp>
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
// An integrity message: a known state, finite figures, and an applied correction a head can have (below 5 deg of
// rotation and 10 % of focal length: anything larger is a broken head or a corrupt message, never a correction).
Verdict validate(const ips::integrity_t& m);
// A keyframe announcement: a stamp and a sequence number a pair can have (not negative).
Verdict validate(const ips::keyframe_t& m);
// A pair's stamp on the control bus: the same.
Verdict validate(const ips::stereo_time_t& m);
// A health message: names a process could have (letters, digits, '_', '-', '.'), non-negative counts, finite
// rates, and received on the channel of the process it names (HEALTH_ + its name in upper case), so that a
// damaged or misdirected one cannot invent a process in an overview.
Verdict validate(const ips::health_t& m, const std::string& channel);
// The channel a process publishes its health on.
std::string healthChannel(const std::string& process_name);
// A name a health message may carry, as a process or a counter: 1 to 64 letters, digits, '_', '-' or '.'.
bool isHealthName(const std::string& name);
// The name itself when it is one, else made one: cut to 64 characters, each other character '_', empty "unnamed".
std::string toHealthName(const std::string& name);

// Order and plausibility of one stream of stamped messages. Time must increase; a stamp far ahead of the
// stream's recent ones (a forged or corrupt message, one bad clock read) is rejected, never adopted, so one bad
// message cannot make every later real one look late. A genuine clock step (a restarted head, a replay started
// again) is followed once `confirm` messages in a row agree with each other on the new time line and none
// fits the old one; `clock_step` in the result says so, for a health warning. A sequence number that jumps
// means lost messages (counted, the message itself is fine); a jump the stream's time cannot explain is a
// sequence reset, not billions of lost messages.
class StreamOrder {
 public:
  struct Limits {
    // Largest plausible step between two consecutive stamps of one stream, before its rhythm is known. Every
    // sensor of the head sends continuously at 8 Hz or more; 10 s of silence followed by data is a different
    // time line.
    int64_t max_forward_step_us = 10'000'000;
    // Once the stream's rhythm is known (the median of its recent steps), a step of more than this many
    // intervals is off the time line: up to that many messages lost in a row is a gap (counted from the
    // sequence numbers), more is a stamp to be confirmed. For the IMU at 200 Hz that is 100 ms, for 8 Hz pairs
    // 2.5 s: a corrupt stamp a few seconds ahead is refused instead of pulling the stream's time forward.
    int gap_intervals = 20;
    // Never tighter than this, whatever the rhythm: jitter of a driver's stamps, a sensor sending in bursts.
    int64_t min_forward_step_us = 50'000;
    // Live, a message cannot be delivered faster than the fastest of its stream: a stamp further ahead of the
    // host's clock (mapped to the stream's clock by that fastest delivery) than this is implausible. Half a
    // second: far above scheduling jitter, and above the drift of a log replayed faster than real time (at 5x,
    // 0.1 s per 8 Hz pair).
    int64_t max_lead_over_host_us = 500'000;
    // Messages in a row on a new time line before it is adopted: one forged stamp never is, and a real clock
    // step costs this many messages.
    int confirm = 5;
    // Highest message rate any stream can have (the IMU's 200 Hz with a wide margin): a sequence jump beyond
    // what this rate and the time elapsed allow is a reset of the source's counter, not lost messages.
    double max_rate_hz = 10'000.0;
  };
  enum class Outcome { accepted, backwards, jump, ahead_of_host };
  struct Result {
    bool accept = true;  // false: the time went backwards, repeated or jumped implausibly far
    Outcome outcome = Outcome::accepted;
    int64_t gap = 0;          // messages missing before this one, from the sequence numbers
    bool clock_step = false;  // accepted as the first message after a confirmed step of the clock
    bool seq_reset = false;   // the sequence number jumped further than the elapsed time allows
    // The stream's first messages did not agree (fewer than `confirm` on a line, then one that does not fit): the
    // line starts again here at once (clock_step too).
    bool rebased = false;
  };
  StreamOrder() : StreamOrder(Limits{}) {}
  explicit StreamOrder(Limits limits) : limits_(limits) {}
  // `arrival_us`: when the message arrived, on the host's clock (LCM's receive time), 0 when unknown (a log
  // read offline): then the host-clock check is skipped.
  Result check(int64_t utime, int64_t seq, int64_t arrival_us = 0);
  int64_t lastUtime() const { return last_utime_; }
  // The health counter name for a rejected message ("time_backwards" or "time_jump").
  static const char* reason(Outcome o);

 private:
  bool fitsAfter(int64_t utime, int64_t previous) const { return utime > previous && utime - previous <= maxStep(); }
  // Live, a longer step is a genuine pause of the source when the host's clock advanced as far between the two
  // arrivals (within the rhythm's allowance): a sensor silent for a second is followed at once, a corrupt stamp
  // arriving in the stream's rhythm is not.
  bool pauseConfirmedByHost(int64_t utime, int64_t arrival_us) const {
    if (arrival_us == 0 || last_arrival_us_ == 0 || utime <= last_utime_) return false;
    const int64_t step = utime - last_utime_;
    return step <= limits_.max_forward_step_us && arrival_us - last_arrival_us_ >= step - maxStep();
  }
  // A replay faster than real time delivers each message up to one interval early: the tolerance is at least
  // the stream's interval (a map every 3 s replayed at twice the speed leads by 1.5 s).
  bool aheadOfHost(int64_t utime, int64_t arrival_us) const {
    if (arrival_us == 0 || !have_delivery_) return false;
    const int64_t tolerance = std::max(limits_.max_lead_over_host_us, maxStep() / limits_.gap_intervals);
    return fastest_delivery_us_ - (arrival_us - utime) > tolerance;
  }
  int64_t maxStep() const;
  void recordStep(int64_t step);
  Limits limits_;
  // The stream's recent accepted steps, for its rhythm.
  static constexpr int kSteps = 9;
  int64_t steps_[kSteps] = {};
  int num_steps_ = 0, next_step_ = 0;
  // The fastest delivery seen (arrival on the host's clock minus stamp): maps the host's clock to the stream's.
  bool have_delivery_ = false;
  int64_t fastest_delivery_us_ = 0;
  int64_t last_arrival_us_ = 0;  // of the last accepted message, 0 when unknown
  bool first_ = true;
  int on_line_ = 0;  // messages accepted on the current time line since it began
  int64_t last_utime_ = 0;
  int64_t last_seq_ = 0;
  // The candidate new time line: its newest stamp and how many messages in a row agree with it.
  int64_t candidate_utime_ = 0;
  int candidate_count_ = 0;
};

// Checks one message of a stream with `order` and counts the outcome in `health` under the stream's name
// `what`: rejected stamps as bad ("time_backwards", "time_jump"), lost messages as dropped ("<what>_seq_gap"),
// sequence resets and confirmed clock steps as counters with a warning. False means: drop this message.
bool admitInOrder(StreamOrder& order, int64_t utime, int64_t seq, Health& health, const std::string& what,
                  int64_t arrival_us = 0);

// The checks every consumer of stereo pairs makes before it uses one: a valid message of the calibrated size
// whose stamp goes forward. Counts what it rejects (bad) and the pairs lost before this one (dropped, from
// the sequence numbers) in `health`; false means: drop this pair.
class StereoAdmission {
 public:
  StereoAdmission(int width, int height) : width_(width), height_(height) {}
  bool admit(const ips::stereo_pair_t& m, Health& health, int64_t arrival_us = 0);

 private:
  int width_, height_;
  StreamOrder order_;
};

}  // namespace ips::fw
