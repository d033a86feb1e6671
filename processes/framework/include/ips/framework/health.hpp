#pragma once
// Counters and rates of one process, turned into an ips::health_t once per report interval.
// Thread-safe: LCM handlers and worker threads both count.
// Counter names are made valid (toHealthName, validate.hpp) as they are counted: one name the health validator
// refuses would make every consumer drop the whole message from then on, and the process would look silent.
#include <cstdint>
#include <ips/health_t.hpp>
#include <map>
#include <mutex>
#include <string>

#include "ips/log.hpp"

namespace ips::fw {

class Health {
 public:
  explicit Health(std::string process);

  // An input arrived (utime: its stamp). The health stamp is the newest stamp of an accepted input: a refused one,
  // far ahead, must not hold it there.
  void received(int64_t utime);
  void accepted();  // the input last received passed the checks and was processed or queued
  // A stream started again at `utime` (its first stamps were left behind as forged or stale): the health stamp
  // follows it there, down from a forged first stamp that was accepted before any other could judge it.
  void restartClock(int64_t utime);
  void published();
  // An input that could not be used: counted under `reason` (e.g. "decode_error", "bad_size", "nan",
  // "time_backwards") and in `bad`; logged at most every few seconds with the number held back.
  void bad(const std::string& reason, const std::string& detail);
  // An input skipped or lost (replaced by a newer one, a sequence gap): counted under `reason` and in `dropped`.
  void dropped(const std::string& reason, int64_t count = 1);
  void count(const std::string& name, int64_t increment = 1);  // any other counter
  void set(const std::string& name, int64_t value);            // a gauge shown among the counters
  void latency(double ms);                                     // processing time of one input
  void queueLength(int n);

  int64_t counter(const std::string& name) const;
  const std::string& host() const { return host_; }
  int64_t badCount() const;
  int64_t droppedCount() const;

  // The message for the interval since the previous call (rates over `interval_s`).
  ips::health_t report(double interval_s);

 private:
  mutable std::mutex mutex_;
  std::string process_;
  std::string host_;
  int64_t last_utime_ = 0;
  int64_t received_utime_ = 0;
  int64_t received_ = 0, published_ = 0, dropped_ = 0, bad_ = 0;
  int64_t interval_accepted_ = 0, interval_published_ = 0;
  double interval_latency_sum_ms_ = 0;
  int64_t interval_latency_n_ = 0;
  int queue_length_ = 0;
  std::map<std::string, int64_t> counters_;
  LogThrottle bad_log_;
  int64_t bad_log_clock_ = 0;  // a counter, not a clock: the throttle lets a line through every N bad inputs
};

}  // namespace ips::fw
