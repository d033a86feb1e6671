#include "ips/framework/node.hpp"

#include <poll.h>
#include <unistd.h>

#include <csignal>
#include <cstdlib>
#include <stdexcept>

#include "ips/framework/channels.hpp"
#include "ips/framework/validate.hpp"

namespace ips::fw {

namespace {
std::atomic<bool> g_stop{false};
extern "C" void onSignal(int) { g_stop = true; }
}  // namespace

std::string resolveLcmUrl(const std::string& cli_url) {
  if (!cli_url.empty()) return cli_url;
  const char* env = std::getenv("LCM_DEFAULT_URL");
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
      health_(process_name) {
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
  lcm_->subscribe(channel, &RawSubscription::handle, sub.get());
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

bool Node::handleOnce(int timeout_ms) { return lcm_->handleTimeout(timeout_ms) >= 0; }

bool Node::inputWaiting() {
  pollfd fd{lcm_->getFileno(), POLLIN, 0};
  return ::poll(&fd, 1, 0) > 0 && (fd.revents & POLLIN) != 0;
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
    if (lcm_->handleTimeout(100) < 0) {
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
  publishHealth(std::chrono::duration<double>(clock::now() - last_health).count());
  IPS_INFO("stopped");
  return 0;
}

}  // namespace ips::fw
