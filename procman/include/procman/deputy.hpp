#pragma once
// The procman deputy: runs on every machine, starts, watches and stops the commands a sheriff orders (through
// its ProcessTable, which knows nothing of LCM), and reports them. Speaks the procman LCM protocol (package
// procman_lcm) so that the upstream procman sheriff can drive it and our sheriff can drive an upstream deputy:
//   PM_DISCOVER  discovery_t    sent for `discovery_ms` after start; another deputy with our id -> exit 2
//   PM_INFO      deputy_info_t  sent every `info_period_ms` and after every change
//   PM_ORDERS    orders_t       listened to only after the discovery period
//   PM_OUTPUT    output_t       what the commands write to their pseudo-terminals (batched)
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <memory>
#include <string>

#include "procman/process_table.hpp"
#include "procman/safe_subscribe.hpp"
#include "procman_lcm/deputy_info_t.hpp"
#include "procman_lcm/discovery_t.hpp"
#include "procman_lcm/orders_t.hpp"
#include "procman_lcm/output_t.hpp"

namespace ips::procman {

inline constexpr const char* kOrdersChannel = "PM_ORDERS";
inline constexpr const char* kInfoChannel = "PM_INFO";
inline constexpr const char* kOutputChannel = "PM_OUTPUT";
inline constexpr const char* kDiscoverChannel = "PM_DISCOVER";

// Exit codes of the deputy (same meaning as the upstream deputy's).
inline constexpr int kExitClean = 0;
inline constexpr int kExitError = 1;
inline constexpr int kExitConflict = 2;  // another deputy with the same id is on the bus

struct DeputyOptions {
  std::string deputy_id;  // default: the host name
  std::string lcm_url;    // "" = LCM's default ($LCM_DEFAULT_URL or udpm://239.255.76.67:7667?ttl=0)
  bool verbose = false;
  // Defaults are the upstream deputy's, so both behave alike for a sheriff.
  int discovery_ms = 500;         // listen for a conflicting deputy this long before accepting orders
  int discovery_period_ms = 200;  // discovery message period during that time
  int info_period_ms = 1000;
  int respawn_min_ms = 10;    // auto-respawn back-off: starts here, doubles while the command keeps dying
  int respawn_max_ms = 1000;  // within this time of its start, and is capped here
  int respawn_backoff_factor = 2;
  double max_order_age_s = 60.0;           // older orders are ignored (clock check between sheriff and deputy)
  int output_flush_ms = 10;                // output is batched for at most this long ...
  size_t output_flush_bytes = 4096;        // ... or this many bytes
  int default_stop_signal = 2;             // used when an order carries stop_signal <= 0 (SIGINT)
  float max_stop_time_allowed_s = 3600.f;  // longer (or NaN/negative: 0) stop times in orders are clamped
};

class Deputy {
 public:
  // Throws std::runtime_error when LCM cannot be set up.
  explicit Deputy(DeputyOptions options);
  ~Deputy();
  Deputy(const Deputy&) = delete;
  Deputy& operator=(const Deputy&) = delete;

  // Runs until SIGINT, SIGTERM, SIGHUP or SIGQUIT (then stops every command: stop signal, SIGKILL after the
  // longest stop_time_allowed) or until a conflicting deputy is seen. Returns the exit code.
  int run();

 private:
  void onDiscovery(const lcm::ReceiveBuffer*, const std::string&, const procman_lcm::discovery_t* msg);
  void onInfo(const lcm::ReceiveBuffer*, const std::string&, const procman_lcm::deputy_info_t* msg);
  void onOrders(const lcm::ReceiveBuffer*, const std::string&, const procman_lcm::orders_t* msg);

  void discoveryTick(int64_t now);
  void handleTimers(int64_t now);
  void publishInfo();
  void transmit(const std::string& command_id, const std::string& text);
  void note(const std::string& command_id, const std::string& text);  // deputy's own message, also to stderr
  void flushOutput(bool force);
  void beginExit();

  DeputyOptions opt_;
  std::unique_ptr<lcm::LCM> lcm_;
  std::unique_ptr<SafeSubscriber> subscriber_;  // drops (and notes) messages that do not decode
  lcm::Subscription* info_sub_ = nullptr;
  lcm::Subscription* orders_sub_ = nullptr;
  int signal_fd_ = -1;
  int64_t start_us_ = 0;
  int64_t nonce_ = 0;
  bool discovering_ = true;
  int64_t next_discovery_us_ = 0;
  int64_t next_info_us_ = 0;
  bool exiting_ = false;
  int64_t exit_deadline_us_ = 0;
  bool quit_ = false;
  int exit_code_ = kExitClean;
  std::unique_ptr<ProcessTable> table_;  // the commands: process control without LCM
  procman_lcm::output_t pending_output_;
  size_t pending_bytes_ = 0;
  int64_t last_flush_us_ = 0;
};

}  // namespace ips::procman
