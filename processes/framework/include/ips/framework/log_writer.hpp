#pragma once
// Writes an LCM log (lcm-logger's format): the simulator's walk, a converted recording, test logs. A failed write
// throws LogError naming the file, so that no tool leaves a half-written log behind without saying so.
#include <cstdio>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <vector>

#include "ips/framework/log_reader.hpp"

namespace ips::fw {

// The bytes LCM sends for `m` (fingerprint first).
template <class Msg>
std::vector<uint8_t> encodeMessage(const Msg& m) {
  std::vector<uint8_t> buf(static_cast<size_t>(m.getEncodedSize()));
  m.encode(buf.data(), 0, static_cast<int>(buf.size()));
  return buf;
}

class LogWriter {
 public:
  explicit LogWriter(const std::string& path) : path_(path), log_(path, "w") {
    if (!log_.good()) throw LogError(path + ": cannot open LCM log for writing");
  }
  // One event; `utime` is its log time stamp [us].
  void write(const std::string& channel, int64_t utime, const std::vector<uint8_t>& bytes) {
    lcm::LogEvent e{};
    e.timestamp = utime;
    e.channel = channel;
    e.datalen = static_cast<int32_t>(bytes.size());
    e.data = const_cast<uint8_t*>(bytes.data());
    if (log_.writeEvent(&e) != 0) throw LogError(path_ + ": writing the LCM log failed (disk full?)");
    ++events_;
  }
  template <class Msg>
  void write(const std::string& channel, int64_t utime, const Msg& m) {
    write(channel, utime, encodeMessage(m));
  }
  // Hands what is buffered to the kernel, so that a process killed later leaves every event written so far.
  void flush() {
    if (std::fflush(log_.getFilePtr()) != 0) throw LogError(path_ + ": writing the LCM log failed (disk full?)");
  }
  int64_t events() const { return events_; }

 private:
  std::string path_;
  lcm::LogFile log_;
  int64_t events_ = 0;
};

}  // namespace ips::fw
