#pragma once
// Reads an LCM log (lcm-logger's format) event by event and says when it is damaged. LCM's own reader skips
// garbage silently until the next sync word and ends at the first truncated event as if the log had ended:
// a tool built on it reports half a run, or two corrupt logs as identical. LogReader checks that each event
// starts where the previous one ended and that the whole file was read, and throws LogError naming the file,
// the byte offset and the event otherwise.
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

struct _lcm_eventlog_t;

namespace ips::fw {

class LogError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct LogMessage {
  std::string channel;
  int64_t timestamp = 0;  // the logger's receive time [us]
  int64_t eventnum = 0;
  std::vector<uint8_t> data;
};

class LogReader {
 public:
  explicit LogReader(const std::string& path);  // throws LogError when the file cannot be opened
  ~LogReader();
  LogReader(const LogReader&) = delete;
  LogReader& operator=(const LogReader&) = delete;

  // The next event into `out`; false at the clean end of the log; LogError when the log is damaged.
  bool next(LogMessage* out);
  int64_t events() const { return events_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  _lcm_eventlog_t* log_ = nullptr;
  int64_t size_ = 0;    // bytes in the file
  int64_t offset_ = 0;  // where the next event must start
  int64_t events_ = 0;
};

}  // namespace ips::fw
