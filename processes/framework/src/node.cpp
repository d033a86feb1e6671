#include "ips/framework/node.hpp"

#include <poll.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <stdexcept>

#include "ips/framework/channels.hpp"
#include "ips/framework/validate.hpp"

namespace ips::fw {

namespace {
constexpr int kSmallQueue = 4000, kBulkQueue = 30;
constexpr int kDrainQuietMs = 50, kDrainMaxMs = 1000;  // handling what came before a stop (Node::run)
std::atomic<bool> g_stop{false};
extern "C" void onSignal(int) { g_stop = true; }
}  // namespace

std::string resolveLcmUrl(const std::string& cli_url) {
  if (!cli_url.empty()) return cli_url;
  const char* env = std::getenv("LCM_DEFAULT_URL");
  return env ? std::string(env) : std::string();
}

std::string resolveBulkLcmUrl() {
  const char* env = std::getenv("IPS_BULK_LCM_URL");
  return env ? std::string(env) : std::string();
}

void installSignalHandlers() {
  struct sigaction sa {};
  sa.sa_handler = onSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  signal(SIGPIPE, SIG_IGN);
}

bool stopRequested() { return g_stop.load(); }
void requestStop() { g_stop = true; }

Node::Node(const std::string& process_name, const std::string& lcm_url)
    : name_(process_name),
      health_channel_(healthChannel(process_name)),
      lcm_(std::make_unique<lcm::LCM>(resolveLcmUrl(lcm_url))),
      bulk_url_(resolveBulkLcmUrl()),
      health_(process_name) {
  if (!bulk_url_.empty() && bulk_url_ == resolveLcmUrl(lcm_url)) bulk_url_.clear();
  if (!lcm_->good()) throw std::runtime_error("cannot initialise LCM with URL '" + resolveLcmUrl(lcm_url) + "'");
  setLogName(process_name);
  installSignalHandlers();
  // A second process started under this name by mistake (two trackers) would publish on the same channels and
  // the same health channel; its health messages carry another host or pid, which is counted and warned of.
  // Two reports of an idle process are identical: not repeats to drop.
  subscribeWithChannel<ips::health_t>(
      health_channel_,
      [this](const ips::health_t& h, const std::string&) {
        const Verdict v = validate(h, health_channel_);
        if (!v.ok()) return health_.bad(v.reason, v.detail);
        if (h.pid == static_cast<int32_t>(getpid()) && h.host == health_.host()) return;
        if (health_.counter("other_process_same_name") == 0)
          IPS_WARN("another process named '" << name_ << "' runs on " << h.host << " (pid " << h.pid
                                             << "): both publish on the same channels");
        health_.count("other_process_same_name");
      },
      /*drop_repeats=*/false);
}

Node::~Node() {
  for (auto& s : subscriptions_) (void)s;  // lcm::LCM's destructor unsubscribes everything
}

void Node::subscribeRaw(const std::string& channel,
                        std::function<void(const lcm::ReceiveBuffer*, const std::string&)> fn) {
  auto sub = std::make_unique<RawSubscription>();
  sub->fn = std::move(fn);
  // LCM 1.3.1 treats the channel as a regex anchored at both ends; escape nothing: our names are plain.
  lcm::Subscription* lcm_sub = lcmFor(channel).subscribe(channel, &RawSubscription::handle, sub.get());
  // LCM queues at most 30 received messages per subscription for the handling thread and drops the rest: 0.15 s of
  // IMU samples, which a loaded machine's scheduler can keep a process from handling. Small messages get room for
  // far more than any stall (kSmallQueue: 20 s of a 200 Hz IMU, a few MB); images and maps keep LCM's 30, which
  // bounds the memory (30 full-size pairs are 84 MB) and a tracker that falls behind skips pairs anyway.
  if (lcm_sub) lcm_sub->setQueueCapacity(channels::isBulkChannel(channel) ? kBulkQueue : kSmallQueue);
  subscriptions_.push_back(std::move(sub));
}

bool Node::RecentMessages::seenBefore(const void* data, size_t size) {
  // FNV-1a over the first bytes and the size.
  uint64_t h = 1469598103934665603ull;
  const auto* p = static_cast<const unsigned char*>(data);
  const size_t n = size < kHashedBytes ? size : kHashedBytes;
  for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;
  h = (h ^ size) * 1099511628211ull;
  for (size_t i = 0; i < count_; ++i)
    if (fingerprints_[i] == h) return true;
  fingerprints_[next_] = h;
  next_ = (next_ + 1) % kRemembered;
  if (count_ < kRemembered) ++count_;
  return false;
}

lcm::LCM& Node::lcmFor(const std::string& channel) {
  if (bulk_url_.empty() || !channels::isBulkChannel(channel)) return *lcm_;
  if (!bulk_) {
    bulk_ = std::make_unique<lcm::LCM>(bulk_url_);
    if (!bulk_->good()) throw std::runtime_error("cannot initialise LCM with the bulk URL '" + bulk_url_ + "'");
  }
  return *bulk_;
}

bool Node::publishRaw(const std::string& channel, const void* data, unsigned size) {
  if (lcmFor(channel).publish(channel, data, size) != 0) {
    health_.count("publish_error");
    return false;
  }
  health_.published();
  return true;
}

bool Node::handleOnce(int timeout_ms) {
  if (!bulk_) return lcm_->handleTimeout(timeout_ms) >= 0;
  // LCM's receive thread queues whole messages and signals them on this descriptor, so handling a ready one never
  // waits for a datagram.
  pollfd fds[2] = {{lcm_->getFileno(), POLLIN, 0}, {bulk_->getFileno(), POLLIN, 0}};
  if (::poll(fds, 2, timeout_ms) < 0) return errno == EINTR;
  bool ok = true;
  if (fds[0].revents & POLLIN) ok = lcm_->handleTimeout(0) >= 0 && ok;
  if (fds[1].revents & POLLIN) ok = bulk_->handleTimeout(0) >= 0 && ok;
  return ok;
}

bool Node::inputWaiting(int timeout_ms) {
  pollfd fds[2] = {{lcm_->getFileno(), POLLIN, 0}, {bulk_ ? bulk_->getFileno() : -1, POLLIN, 0}};
  return ::poll(fds, bulk_ ? 2 : 1, timeout_ms) > 0 && ((fds[0].revents & POLLIN) || (fds[1].revents & POLLIN));
}

void Node::publishHealth(double interval_s) {
  if (fill_health_) fill_health_(health_);
  ips::health_t msg = health_.report(interval_s);
  lcm_->publish(health_channel_, &msg);
}

int Node::run(std::function<void()> on_tick, double health_period_s) {
  using clock = std::chrono::steady_clock;
  auto last_health = clock::now();
  int errors = 0;
  while (!stopRequested()) {
    if (!handleOnce(100)) {
      if (++errors > 50) {
        IPS_ERROR("LCM keeps failing; stopping");
        return 1;
      }
    }
    if (on_tick) on_tick();
    const auto now = clock::now();
    const double since = std::chrono::duration<double>(now - last_health).count();
    if (since >= health_period_s) {
      publishHealth(since);
      last_health = now;
    }
  }
  const auto drain_end = clock::now() + std::chrono::milliseconds(kDrainMaxMs);
  while (clock::now() < drain_end && inputWaiting(kDrainQuietMs)) handleOnce(0);
  publishHealth(std::chrono::duration<double>(clock::now() - last_health).count());
  IPS_INFO("stopped");
  return 0;
}

}  // namespace ips::fw
