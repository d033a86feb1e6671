#pragma once
// The process framework: one Node per process wraps the LCM connection, typed subscribe and publish with
// counting of everything that goes wrong, the health message once per second, and clean shutdown on SIGINT
// and SIGTERM. Algorithms never see it: a process main feeds them plain types from its handlers.
#include <atomic>
#include <chrono>
#include <functional>
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <string>
#include <vector>

#include "ips/framework/health.hpp"
#include "ips/log.hpp"

namespace ips::fw {

// LCM URL: the --lcm-url option if given, else $LCM_DEFAULT_URL, else LCM's own default.
std::string resolveLcmUrl(const std::string& cli_url);

// Installs SIGINT/SIGTERM handlers that set a flag (idempotent); stopRequested() reads it.
void installSignalHandlers();
bool stopRequested();
void requestStop();

class Node {
 public:
  // Throws std::runtime_error if LCM cannot be initialised with this URL.
  Node(const std::string& process_name, const std::string& lcm_url);
  ~Node();
  Node(const Node&) = delete;
  Node& operator=(const Node&) = delete;

  const std::string& name() const { return name_; }
  Health& health() { return health_; }
  lcm::LCM& lcm() { return *lcm_; }

  // Subscribes to a channel of type Msg. Messages that do not decode are counted as bad ("decode_error") and
  // never reach the handler; an exception thrown by the handler is counted ("handler_error") and logged,
  // and the process goes on.
  template <class Msg>
  void subscribe(const std::string& channel, std::function<void(const Msg&)> handler);

  // Encodes and publishes; counts it in the health message.
  template <class Msg>
  bool publish(const std::string& channel, const Msg& msg);

  // Handles LCM until a stop is requested, publishing the health message every `health_period_s` (wall clock:
  // health is about the running process, no result depends on it). `on_tick`, if set, runs after each
  // handled batch or timeout (at least every 100 ms) in this thread.
  int run(std::function<void()> on_tick = nullptr, double health_period_s = 1.0);

  // Handles whatever is pending for up to timeout_ms; for tests and custom loops. Returns false on an LCM error.
  bool handleOnce(int timeout_ms);
  void publishHealth(double interval_s);

 private:
  struct RawSubscription {
    std::function<void(const lcm::ReceiveBuffer*, const std::string&)> fn;
    void handle(const lcm::ReceiveBuffer* rbuf, const std::string& channel) { fn(rbuf, channel); }
  };
  void subscribeRaw(const std::string& channel, std::function<void(const lcm::ReceiveBuffer*, const std::string&)> fn);

  std::string name_;
  std::string health_channel_;
  std::unique_ptr<lcm::LCM> lcm_;
  Health health_;
  std::vector<std::unique_ptr<RawSubscription>> subscriptions_;
};

template <class Msg>
void Node::subscribe(const std::string& channel, std::function<void(const Msg&)> handler) {
  subscribeRaw(channel, [this, channel, handler](const lcm::ReceiveBuffer* rbuf, const std::string&) {
    Msg msg;
    if (msg.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0) {
      health_.received(0);
      health_.bad("decode_error", "a message on " + channel + " (" + std::to_string(rbuf->data_size) +
                                      " bytes) does not decode as " + Msg::getTypeName());
      return;
    }
    try {
      handler(msg);
    } catch (const std::exception& e) {
      health_.bad("handler_error", "on " + channel + ": " + e.what());
    }
  });
}

template <class Msg>
bool Node::publish(const std::string& channel, const Msg& msg) {
  if (lcm_->publish(channel, &msg) != 0) {
    health_.count("publish_error");
    return false;
  }
  health_.published();
  return true;
}

}  // namespace ips::fw
