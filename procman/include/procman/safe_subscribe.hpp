#pragma once
// Typed LCM subscriptions that survive bad packets. LCM's own typed subscribe lets an exception out of the
// generated decoder (a negative or huge array or string length makes it throw std::length_error or
// std::bad_alloc) and out of the handler, which ends the process inside handle(). Here both are caught,
// counted and reported, and the message is dropped: a deputy must never exit on a bad packet.
#include <cstdint>
#include <exception>
#include <functional>
#include <lcm/lcm-cpp.hpp>
#include <list>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>

namespace ips::procman {

class SafeSubscriber {
 public:
  // Called for every dropped message with its channel, the reason and the number dropped so far on that channel
  // (counted per channel, so that a flood on one channel does not hide the first bad packet on another).
  using Reporter = std::function<void(const std::string& channel, const std::string& reason, uint64_t dropped)>;

  SafeSubscriber(lcm::LCM& lcm, Reporter report) : lcm_(lcm), report_(std::move(report)) {}
  SafeSubscriber(const SafeSubscriber&) = delete;
  SafeSubscriber& operator=(const SafeSubscriber&) = delete;

  // Like lcm::LCM::subscribe with a typed member handler.
  template <class Msg, class Owner>
  lcm::Subscription* subscribe(const std::string& channel,
                               void (Owner::*method)(const lcm::ReceiveBuffer*, const std::string&, const Msg*),
                               Owner* owner) {
    auto entry = std::make_unique<Entry>();
    entry->self = this;
    entry->dispatch = [method, owner](const lcm::ReceiveBuffer* rbuf, const std::string& ch) {
      Msg msg;
      if (msg.decode(rbuf->data, 0, static_cast<int>(rbuf->data_size)) < 0)
        throw std::runtime_error(std::string("does not decode as ") + Msg::getTypeName());
      (owner->*method)(rbuf, ch, &msg);
    };
    Entry* raw = entry.get();
    entries_.push_back(std::move(entry));
    return lcm_.subscribe(channel, &Entry::onMessage, raw);
  }

  uint64_t dropped() const { return dropped_; }
  uint64_t dropped(const std::string& channel) const {
    const auto it = dropped_per_channel_.find(channel);
    return it == dropped_per_channel_.end() ? 0 : it->second;
  }

 private:
  struct Entry {
    SafeSubscriber* self = nullptr;
    std::function<void(const lcm::ReceiveBuffer*, const std::string&)> dispatch;
    void onMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
      try {
        dispatch(rbuf, channel);
      } catch (const std::exception& e) {
        self->drop(channel, e.what());
      } catch (...) {
        self->drop(channel, "unknown exception");
      }
    }
  };
  void drop(const std::string& channel, const std::string& reason) {
    ++dropped_;
    const uint64_t on_channel = ++dropped_per_channel_[channel];
    if (report_) report_(channel, reason, on_channel);
  }

  lcm::LCM& lcm_;
  Reporter report_;
  std::list<std::unique_ptr<Entry>> entries_;
  uint64_t dropped_ = 0;
  std::map<std::string, uint64_t> dropped_per_channel_;
};

}  // namespace ips::procman
