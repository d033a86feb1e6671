#pragma once
// The process framework: one Node per process wraps the LCM connections, typed subscribe and publish with
// counting of everything that goes wrong, the health message once per second, and clean shutdown on SIGINT
// and SIGTERM. Algorithms never see it: a process main feeds them plain types from its handlers.
//
// Two buses: the bulk channels (images, dense maps: channels::isBulkChannel) travel on their own LCM URL when one is
// set ($IPS_BULK_LCM_URL or --bulk-lcm-url), everything else on the control URL, and a Node joins the bulk bus only
// when it subscribes to or publishes a bulk channel. A process that reads IMU samples then never has image datagrams
// in its socket, and a small message is not lost beside the images when the process falls behind (LCM's practice
// for bulk data). Without a bulk URL both are one bus.
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
// The bulk bus's URL: $IPS_BULK_LCM_URL (set by --bulk-lcm-url, applyCommonOptions), else empty: the control bus.
std::string resolveBulkLcmUrl();

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
  // When the message being handled arrived, on the host's clock (LCM's receive time) [us]; for the stream
  // checks' host-clock test. 0 outside a handler.
  int64_t arrivalUs() const { return arrival_us_; }
  Health& health() { return health_; }
  // The control bus's connection (raw access for tests and tools).
  lcm::LCM& lcm() { return *lcm_; }
  // Whether the bulk channels have a bus of their own.
  bool splitBuses() const { return !bulk_url_.empty(); }

  // Subscribes to a channel of type Msg. Messages that do not decode are counted as bad ("decode_error") and
  // never reach the handler (the generated decoders bound every declared length by the datagram's size, see
  // cmake/LcmGen.cmake, and any exception they still throw is caught here); a message that repeats one of the
  // channel's recent messages byte for byte is dropped ("duplicate"); an exception thrown by the handler is
  // counted ("handler_error") and logged, and the process goes on.
  template <class Msg>
  void subscribe(const std::string& channel, std::function<void(const Msg&)> handler);
  // The same for a channel pattern, with the channel each message came on. `drop_repeats` false for a stream
  // whose messages may legitimately repeat byte for byte (an idle process's health reports).
  template <class Msg>
  void subscribeWithChannel(const std::string& pattern, std::function<void(const Msg&, const std::string&)> handler,
                            bool drop_repeats = true);

  // Encodes and publishes on the channel's bus; counts it in the health message.
  template <class Msg>
  bool publish(const std::string& channel, const Msg& msg);
  // Bytes already encoded (a message from a log), on the channel's bus.
  bool publishRaw(const std::string& channel, const void* data, unsigned size);

  // Handles LCM until a stop is requested, publishing the health message every `health_period_s` (wall clock:
  // health is about the running process, no result depends on it). `on_tick`, if set, runs after each
  // handled batch or timeout (at least every 100 ms) in this thread. After the stop it goes on handling what
  // reached its sockets (a pair still being reassembled, a delta sent by a process stopped just before) until they
  // stay quiet for 50 ms, at most 1 s: what was sent before the stop is not lost.
  int run(std::function<void()> on_tick = nullptr, double health_period_s = 1.0);

  // Handles whatever is pending for up to timeout_ms; for tests and custom loops. Returns false on an LCM error.
  bool handleOnce(int timeout_ms);
  // Whether more input already waits in the socket: a process that does heavy work per message reads what has
  // piled up first (a backlog in the kernel's buffer is invisible to it otherwise) and then decides what to do.
  bool inputWaiting(int timeout_ms = 0);
  void publishHealth(double interval_s);
  // Called just before each health message is made, to set figures the process keeps elsewhere (an estimator's
  // counters) once per report instead of at every message.
  void onHealthReport(std::function<void(Health&)> fill) { fill_health_ = std::move(fill); }

 private:
  struct RawSubscription {
    std::function<void(const lcm::ReceiveBuffer*, const std::string&)> fn;
    void handle(const lcm::ReceiveBuffer* rbuf, const std::string& channel) { fn(rbuf, channel); }
  };
  // Fingerprints of a channel's most recent messages, to drop exact repeats (a message sent twice by a
  // faulty link or a replayed packet). Every message type starts with its stamp, so the first bytes and the
  // size tell messages apart without hashing megabytes of image.
  class RecentMessages {
   public:
    bool seenBefore(const void* data, size_t size);  // records the message; true if it repeats a recent one

   private:
    static constexpr size_t kRemembered = 64;
    static constexpr size_t kHashedBytes = 4096;
    uint64_t fingerprints_[kRemembered] = {};
    size_t next_ = 0, count_ = 0;
  };
  void subscribeRaw(const std::string& channel, std::function<void(const lcm::ReceiveBuffer*, const std::string&)> fn);
  // The connection a channel travels on; the bulk one is opened on first use.
  lcm::LCM& lcmFor(const std::string& channel);

  std::string name_;
  int64_t arrival_us_ = 0;
  std::string health_channel_;
  std::unique_ptr<lcm::LCM> lcm_;
  std::string bulk_url_;            // empty: one bus
  std::unique_ptr<lcm::LCM> bulk_;  // opened when a bulk channel is first used
  Health health_;
  std::function<void(Health&)> fill_health_;
  std::vector<std::unique_ptr<RawSubscription>> subscriptions_;
};

template <class Msg>
void Node::subscribe(const std::string& channel, std::function<void(const Msg&)> handler) {
  subscribeWithChannel<Msg>(channel, [handler](const Msg& m, const std::string&) { handler(m); });
}

template <class Msg>
void Node::subscribeWithChannel(const std::string& pattern, std::function<void(const Msg&, const std::string&)> handler,
                                bool drop_repeats) {
  auto recent = drop_repeats ? std::make_shared<RecentMessages>() : nullptr;
  subscribeRaw(pattern, [this, handler, recent](const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    Msg msg;
    int decoded = -1;
    std::string why = "does not decode";
    try {
      decoded = msg.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size));
    } catch (const std::exception& e) {
      why = std::string("makes the decoder throw (") + e.what() + ")";
    }
    if (decoded < 0) {
      health_.received(0);
      health_.bad("decode_error", "a message on " + channel + " (" + std::to_string(rbuf->data_size) + " bytes) " +
                                      why + " as " + Msg::getTypeName());
      return;
    }
    if (recent && recent->seenBefore(rbuf->data, rbuf->data_size)) {
      health_.dropped("duplicate");
      return;
    }
    arrival_us_ = rbuf->recv_utime;
    try {
      handler(msg, channel);
    } catch (const std::exception& e) {
      health_.bad("handler_error", "on " + channel + ": " + e.what());
    }
    arrival_us_ = 0;
  });
}

template <class Msg>
bool Node::publish(const std::string& channel, const Msg& msg) {
  if (lcmFor(channel).publish(channel, &msg) != 0) {
    health_.count("publish_error");
    return false;
  }
  health_.published();
  return true;
}

}  // namespace ips::fw
