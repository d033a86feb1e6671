#pragma once
// A sensor on a serial line: the port (opened again after a failure), a parser, and the time stamps. Samples
// are stamped at arrival on the common clock (each frame dated by the arrival of its last byte, back-dated by
// the bytes behind it in the same read) minus the sensor's calibrated constant delay. A line that goes silent
// is counted once per silence, its partial frame dropped, and reading goes on when bytes come back.
// Parser: Mmq50Parser or Z260Parser (same interface).
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "ips/drivers/common_clock.hpp"
#include "ips/drivers/serial_port.hpp"
#include "ips/log.hpp"

namespace ips::drivers {

struct SerialReaderConfig {
  SerialSettings port;
  int64_t delay_us = 0;    // calibrated constant delay of the sensor: subtracted from the arrival time
  double silence_s = 0.5;  // no good frame for this long: the line is silent
  double reopen_interval_s = 1.0;

  // A driver's reader settings from the section `sensor` of its config: <sensor>/port, delay_us, silence_s
  // (default `default_silence_s`: a few of the sensor's periods), reopen_interval_s.
  static SerialReaderConfig fromConfig(const Config& cfg, const std::string& sensor, double default_silence_s);
};

template <class Parser>
class SerialReader {
 public:
  using Sample = typename decltype(std::declval<Parser>().feed(nullptr, 0, 0, 0.0))::value_type;

  SerialReader(SerialReaderConfig config, Parser parser) : config_(std::move(config)), parser_(std::move(parser)) {
    for (const char* name : {"silences", "reopens", "open_failures", "read_errors", "bytes", "stamps_clamped"})
      counters_[name] = 0;
  }

  // Reads for up to timeout_ms and returns the samples completed, stamped and in increasing time.
  std::vector<Sample> poll(int timeout_ms) {
    std::vector<Sample> out;
    const int64_t now = commonClockNowUs();
    if (!port_) {
      if (now - last_open_attempt_us_ < static_cast<int64_t>(config_.reopen_interval_s * 1e6)) {
        sleepMs(timeout_ms);
        return out;
      }
      last_open_attempt_us_ = now;
      try {
        port_ = std::make_unique<SerialPort>(config_.port);
        if (opened_once_) ++counters_["reopens"];
        opened_once_ = true;
        last_good_us_ = now;
        IPS_INFO("serial " << config_.port.device << " open at " << config_.port.baud << " baud");
      } catch (const std::exception& e) {
        if (++counters_["open_failures"] == 1) IPS_WARN(e.what() << "; retrying");
        sleepMs(timeout_ms);
        return out;
      }
    }
    uint8_t buffer[4096];
    size_t n = 0;
    try {
      n = port_->read(buffer, sizeof buffer, timeout_ms);
    } catch (const std::exception& e) {
      IPS_WARN(e.what() << "; reopening");
      ++counters_["read_errors"];
      port_.reset();
      parser_.dropPartial();
      return out;
    }
    const int64_t arrival = commonClockNowUs();
    if (n > 0) {
      counters_["bytes"] += static_cast<int64_t>(n);
      for (auto& s : parser_.feed(buffer, n, arrival, config_.port.byteTimeUs())) {
        s.utime -= config_.delay_us;
        if (s.utime <= last_utime_) {
          // Bytes batched by the line (USB adapters) can make back-dating non-monotonic: keep order.
          s.utime = last_utime_ + 1;
          ++counters_["stamps_clamped"];
        }
        last_utime_ = s.utime;
        out.push_back(s);
      }
    }
    if (!out.empty()) {
      last_good_us_ = arrival;
      silent_ = false;
    } else if (!silent_ && arrival - last_good_us_ > static_cast<int64_t>(config_.silence_s * 1e6)) {
      silent_ = true;
      ++counters_["silences"];
      parser_.dropPartial();  // what came before the silence cannot be completed with what comes after
      IPS_WARN("serial " << config_.port.device << ": no data for " << config_.silence_s << " s");
    }
    return out;
  }

  bool open() const { return port_ != nullptr; }
  bool silent() const { return silent_; }
  Parser& parser() { return parser_; }
  // Parser and line counters: frames, checksum_errors, garbage_bytes, bad_frames, counter_gaps,
  // partial_frames, silences, reopens, open_failures, read_errors, bytes, stamps_clamped.
  std::map<std::string, int64_t> counters() const {
    auto all = counters_;
    const auto& c = parser_.counters();
    all["frames"] = c.frames;
    all["checksum_errors"] = c.checksum_errors;
    all["garbage_bytes"] = c.garbage_bytes;
    all["bad_frames"] = c.bad_frames;
    all["counter_gaps"] = c.counter_gaps;
    all["partial_frames"] = parser_.partialFrames();
    return all;
  }

 private:
  static void sleepMs(int ms) {
    struct timespec ts {
      ms / 1000, (ms % 1000) * 1000000L
    };
    nanosleep(&ts, nullptr);
  }
  SerialReaderConfig config_;
  Parser parser_;
  std::unique_ptr<SerialPort> port_;
  std::map<std::string, int64_t> counters_;
  bool opened_once_ = false;
  bool silent_ = false;
  int64_t last_open_attempt_us_ = INT64_MIN / 2;
  int64_t last_good_us_ = 0;
  int64_t last_utime_ = INT64_MIN;
};

}  // namespace ips::drivers
