#include "ips/framework/health.hpp"

#include <unistd.h>

#include <cstdint>

#include "ips/framework/validate.hpp"

namespace ips::fw {

namespace {
// Counters saturate instead of wrapping: a nonsense increment must not turn a count negative.
void addSaturating(int64_t& counter, int64_t increment) {
  if (__builtin_add_overflow(counter, increment, &counter)) counter = increment > 0 ? INT64_MAX : INT64_MIN;
}

std::string hostName() {
  char buf[256] = {0};
  if (gethostname(buf, sizeof(buf) - 1) != 0) return "unknown";
  return buf;
}
}  // namespace

// The bad-input log throttle counts inputs, not time, so that replay logs the same lines: one line for the
// first bad input, then one per 100 with the number held back.
Health::Health(std::string process) : process_(std::move(process)), host_(hostName()), bad_log_(100) {}

void Health::received(int64_t utime) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++received_;
  received_utime_ = utime;
}

void Health::accepted() {
  std::lock_guard<std::mutex> lock(mutex_);
  ++interval_accepted_;
  if (received_utime_ > last_utime_) last_utime_ = received_utime_;
}

void Health::restartClock(int64_t utime) {
  std::lock_guard<std::mutex> lock(mutex_);
  last_utime_ = utime;
}

void Health::published() {
  std::lock_guard<std::mutex> lock(mutex_);
  ++published_;
  ++interval_published_;
}

void Health::bad(const std::string& reason, const std::string& detail) {
  uint64_t held = 0;
  bool log = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++bad_;
    ++counters_[toHealthName(reason)];
    log = bad_log_.allow(bad_log_clock_++, &held);
  }
  if (log) {
    IPS_WARN("bad input (" << reason << "): " << detail
                           << (held ? " [" + std::to_string(held) + " more bad inputs not logged]" : ""));
  }
}

void Health::dropped(const std::string& reason, int64_t count) {
  std::lock_guard<std::mutex> lock(mutex_);
  addSaturating(dropped_, count);
  addSaturating(counters_[toHealthName(reason)], count);
}

void Health::count(const std::string& name, int64_t increment) {
  std::lock_guard<std::mutex> lock(mutex_);
  addSaturating(counters_[toHealthName(name)], increment);
}

void Health::set(const std::string& name, int64_t value) {
  std::lock_guard<std::mutex> lock(mutex_);
  counters_[toHealthName(name)] = value;
}

void Health::latency(double ms) {
  std::lock_guard<std::mutex> lock(mutex_);
  interval_latency_sum_ms_ += ms;
  ++interval_latency_n_;
}

void Health::queueLength(int n) {
  std::lock_guard<std::mutex> lock(mutex_);
  queue_length_ = n;
}

int64_t Health::counter(const std::string& name) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = counters_.find(toHealthName(name));
  return it == counters_.end() ? 0 : it->second;
}

int64_t Health::badCount() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return bad_;
}

int64_t Health::droppedCount() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return dropped_;
}

ips::health_t Health::report(double interval_s) {
  std::lock_guard<std::mutex> lock(mutex_);
  ips::health_t msg;
  msg.utime = last_utime_;
  msg.process = process_;
  msg.host = host_;
  msg.pid = static_cast<int32_t>(getpid());
  const double dt = interval_s > 0 ? interval_s : 1.0;
  msg.input_rate_hz = interval_accepted_ / dt;
  msg.output_rate_hz = interval_published_ / dt;
  msg.latency_ms = interval_latency_n_ ? interval_latency_sum_ms_ / interval_latency_n_ : 0.0;
  msg.queue_length = queue_length_;
  msg.received = received_;
  msg.published = published_;
  msg.dropped = dropped_;
  msg.bad = bad_;
  msg.num_counters = static_cast<int32_t>(counters_.size());
  for (const auto& kv : counters_) {
    msg.counter_names.push_back(kv.first);
    msg.counter_values.push_back(kv.second);
  }
  interval_accepted_ = interval_published_ = 0;
  interval_latency_sum_ms_ = 0;
  interval_latency_n_ = 0;
  return msg;
}

}  // namespace ips::fw
