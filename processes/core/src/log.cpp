#include "ips/log.hpp"

#include <atomic>
#include <cstdio>
#include <ctime>
#include <mutex>
#include <stdexcept>

namespace ips {
namespace {
std::atomic<int> g_level{static_cast<int>(LogLevel::Info)};
std::mutex g_mutex;
std::string g_name = "ips";
const char* levelName(LogLevel l) {
  switch (l) {
    case LogLevel::Debug:
      return "DEBUG";
    case LogLevel::Info:
      return "INFO";
    case LogLevel::Warn:
      return "WARN";
    case LogLevel::Error:
      return "ERROR";
  }
  return "?";
}
}  // namespace

void setLogLevel(LogLevel level) { g_level = static_cast<int>(level); }
LogLevel logLevel() { return static_cast<LogLevel>(g_level.load()); }

LogLevel parseLogLevel(const std::string& name) {
  if (name == "debug") return LogLevel::Debug;
  if (name == "info") return LogLevel::Info;
  if (name == "warn") return LogLevel::Warn;
  if (name == "error") return LogLevel::Error;
  throw std::invalid_argument("unknown log level '" + name + "' (debug, info, warn, error)");
}

void setLogName(const std::string& name) {
  std::lock_guard<std::mutex> lock(g_mutex);
  g_name = name;
}

void logMessage(LogLevel level, const std::string& text) {
  // The wall clock here only decorates the human-readable line; no result depends on it.
  std::lock_guard<std::mutex> lock(g_mutex);
  std::fprintf(stderr, "[%s] %s: %s\n", levelName(level), g_name.c_str(), text.c_str());
  std::fflush(stderr);
}

bool LogThrottle::allow(int64_t now_us, uint64_t* suppressed) {
  if (last_us_ == INT64_MIN || now_us - last_us_ >= interval_us_ || now_us < last_us_) {
    if (suppressed) *suppressed = held_;
    held_ = 0;
    last_us_ = now_us;
    return true;
  }
  ++held_;
  return false;
}

}  // namespace ips
