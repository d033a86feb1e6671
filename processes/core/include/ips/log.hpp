#pragma once
// Levelled logging to stderr, and a rate limiter so that a flood of bad input is logged now and then,
// not once per message.
#include <cstdint>
#include <sstream>
#include <string>

namespace ips {

enum class LogLevel { Debug = 0, Info = 1, Warn = 2, Error = 3 };

void setLogLevel(LogLevel level);
LogLevel logLevel();
// "debug", "info", "warn", "error"; throws std::invalid_argument otherwise.
LogLevel parseLogLevel(const std::string& name);
void setLogName(const std::string& name);  // the process name shown in every line
void logMessage(LogLevel level, const std::string& text);

// Lets a message through at most once per interval (in the caller's time base, e.g. message stamps),
// and counts how many were held back so the next line can say so.
class LogThrottle {
 public:
  explicit LogThrottle(int64_t interval_us = 5'000'000) : interval_us_(interval_us) {}
  // True if a line may be written now; `suppressed` is the number held back since the last one.
  bool allow(int64_t now_us, uint64_t* suppressed = nullptr);

 private:
  int64_t interval_us_;
  int64_t last_us_ = INT64_MIN;
  uint64_t held_ = 0;
};

}  // namespace ips

#define IPS_LOG(level, expr)                                              \
  do {                                                                    \
    if (static_cast<int>(level) >= static_cast<int>(::ips::logLevel())) { \
      std::ostringstream ips_log_os_;                                     \
      ips_log_os_ << expr;                                                \
      ::ips::logMessage(level, ips_log_os_.str());                        \
    }                                                                     \
  } while (0)
#define IPS_DEBUG(expr) IPS_LOG(::ips::LogLevel::Debug, expr)
#define IPS_INFO(expr) IPS_LOG(::ips::LogLevel::Info, expr)
#define IPS_WARN(expr) IPS_LOG(::ips::LogLevel::Warn, expr)
#define IPS_ERROR(expr) IPS_LOG(::ips::LogLevel::Error, expr)
