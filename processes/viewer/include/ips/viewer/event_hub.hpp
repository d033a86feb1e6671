#pragma once
// Fan-out of small events to browsers. The bus side broadcasts and never waits for a browser: each client has
// a bounded queue, and when a slow or stalled browser lets it fill up, its oldest events are dropped and
// counted. Browsers recover from drops on their own (every event says what it follows; see the page).
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace ips::viewer {

class EventHub {
 public:
  class Client {
   public:
    explicit Client(size_t capacity) : capacity_(capacity) {}
    // Waits up to timeout_s for events and moves all pending ones into `text` as server-sent events
    // ("event: NAME\ndata: JSON\n\n" each). False once the hub is closed.
    bool next(std::string* text, double timeout_s);
    int64_t dropped() const;

   private:
    friend class EventHub;
    void push(const std::string& sse, int64_t* hub_dropped);
    void close();
    const size_t capacity_;
    mutable std::mutex mutex_;
    std::condition_variable ready_;
    std::deque<std::string> queue_;
    int64_t dropped_ = 0;
    bool closed_ = false;
  };

  // queue_capacity: events one client may have pending; max_clients: browsers served at once.
  EventHub(size_t queue_capacity, int max_clients);
  ~EventHub();

  // A new client, or nullptr when max_clients are connected.
  std::shared_ptr<Client> connect();
  void disconnect(const std::shared_ptr<Client>& client);
  // Queues one event for every client; O(clients), never blocks on a browser.
  void broadcast(const std::string& event, const std::string& json);
  // Wakes every client for good (shutdown).
  void close();

  int clients() const;
  int64_t dropped() const;  // events dropped for slow clients, all clients together since start
  int64_t refused() const;  // connections refused because max_clients were connected

 private:
  const size_t queue_capacity_;
  const int max_clients_;
  mutable std::mutex mutex_;
  std::vector<std::shared_ptr<Client>> clients_;
  int64_t dropped_ = 0, refused_ = 0;
  bool closed_ = false;
};

}  // namespace ips::viewer
