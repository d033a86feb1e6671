#include "ips/framework/log_reader.hpp"

#include <lcm/eventlog.h>
#include <sys/stat.h>

#include <cstdio>

namespace ips::fw {

namespace {
// An event on disk: sync word, event number, time stamp, channel length, data length, channel, data.
constexpr int64_t kEventHeaderBytes = 4 + 8 + 8 + 4 + 4;
}  // namespace

LogReader::LogReader(const std::string& path) : path_(path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) throw LogError(path + ": cannot open LCM log");
  size_ = static_cast<int64_t>(st.st_size);
  log_ = lcm_eventlog_create(path.c_str(), "r");
  if (!log_) throw LogError(path + ": cannot open LCM log");
}

LogReader::~LogReader() {
  if (log_) lcm_eventlog_destroy(log_);
}

bool LogReader::next(LogMessage* out) {
  lcm_eventlog_event_t* e = lcm_eventlog_read_next_event(log_);
  if (!e) {
    if (offset_ == size_) return false;
    throw LogError(path_ + ": damaged LCM log: " + std::to_string(size_ - offset_) + " bytes at byte " +
                   std::to_string(offset_) + " after event " + std::to_string(events_) +
                   " are not a whole event (truncated or corrupt)");
  }
  const int64_t end = static_cast<int64_t>(std::ftell(log_->f));
  const int64_t length = kEventHeaderBytes + e->channellen + e->datalen;
  if (end - length != offset_) {
    const int64_t skipped = end - length - offset_;
    lcm_eventlog_free_event(e);
    throw LogError(path_ + ": damaged LCM log: " + std::to_string(skipped) + " bytes of garbage at byte " +
                   std::to_string(offset_) + " after event " + std::to_string(events_));
  }
  offset_ = end;
  out->channel.assign(e->channel, static_cast<size_t>(e->channellen));
  out->timestamp = e->timestamp;
  out->eventnum = e->eventnum;
  const auto* p = static_cast<const uint8_t*>(e->data);
  out->data.assign(p, p + e->datalen);
  lcm_eventlog_free_event(e);
  ++events_;
  return true;
}

}  // namespace ips::fw
