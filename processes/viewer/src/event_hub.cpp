#include "ips/viewer/event_hub.hpp"

#include <algorithm>
#include <chrono>

namespace ips::viewer {

bool EventHub::Client::next(std::string* text, double timeout_s) {
  std::unique_lock<std::mutex> lock(mutex_);
  ready_.wait_for(lock, std::chrono::duration<double>(timeout_s), [this] { return closed_ || !queue_.empty(); });
  text->clear();
  for (const std::string& e : queue_) *text += e;
  queue_.clear();
  return !closed_;
}

int64_t EventHub::Client::dropped() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return dropped_;
}

void EventHub::Client::push(const std::string& sse, int64_t* hub_dropped) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (closed_) return;
    if (queue_.size() >= capacity_) {
      queue_.pop_front();
      ++dropped_;
      ++*hub_dropped;
    }
    queue_.push_back(sse);
  }
  ready_.notify_one();
}

void EventHub::Client::close() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    closed_ = true;
  }
  ready_.notify_all();
}

EventHub::EventHub(size_t queue_capacity, int max_clients)
    : queue_capacity_(std::max<size_t>(1, queue_capacity)), max_clients_(max_clients) {}

EventHub::~EventHub() { close(); }

std::shared_ptr<EventHub::Client> EventHub::connect() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (closed_ || static_cast<int>(clients_.size()) >= max_clients_) {
    ++refused_;
    return nullptr;
  }
  clients_.push_back(std::make_shared<Client>(queue_capacity_));
  return clients_.back();
}

void EventHub::disconnect(const std::shared_ptr<Client>& client) {
  std::lock_guard<std::mutex> lock(mutex_);
  clients_.erase(std::remove(clients_.begin(), clients_.end(), client), clients_.end());
}

void EventHub::broadcast(const std::string& event, const std::string& json) {
  const std::string sse = "event: " + event + "\ndata: " + json + "\n\n";
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& c : clients_) c->push(sse, &dropped_);
}

void EventHub::close() {
  std::lock_guard<std::mutex> lock(mutex_);
  closed_ = true;
  for (const auto& c : clients_) c->close();
}

int EventHub::clients() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return static_cast<int>(clients_.size());
}

int64_t EventHub::dropped() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return dropped_;
}

int64_t EventHub::refused() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return refused_;
}

}  // namespace ips::viewer
