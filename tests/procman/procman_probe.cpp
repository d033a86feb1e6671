// procman_probe: attacks running procman deputies and sheriffs over LCM the way a faulty network or a malicious
// host would, for the hostile-input process test (sheriff_hostile_test.sh). For each of procman's channels
// (PM_ORDERS, PM_INFO, PM_OUTPUT, PM_DISCOVER) it publishes a valid message with every 4-byte window replaced by
// a hostile length, and prints how many it sent per channel.
#include <chrono>
#include <cstdio>
#include <lcm/lcm-cpp.hpp>
#include <string>
#include <thread>
#include <vector>

#include "ips/args.hpp"
#include "ips/test_support/procman_samples.hpp"
#include "ips/test_support/sample_messages.hpp"
#include "procman/deputy.hpp"

namespace {

int64_t nowUs() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

template <class Msg>
void attack(lcm::LCM& lcm, const std::string& channel, const Msg& valid) {
  int64_t sent = 0;
  ips::test_support::forEachHostileLength(ips::test_support::encodeMessage(valid),
                                          [&](const std::vector<uint8_t>& bad, size_t, int32_t) {
                                            lcm.publish(channel, bad.data(), static_cast<unsigned>(bad.size()));
                                            ++sent;
                                            // Paced: a burst would test the kernel's socket buffers, not procman.
                                            std::this_thread::sleep_for(std::chrono::microseconds(300));
                                          });
  std::printf("sent %s=%lld\n", channel.c_str(), static_cast<long long>(sent));
}

}  // namespace

int main(int argc, char** argv) {
  try {
    ips::Args args(argc, argv, "publish hostile procman messages (for the sheriff and deputy process test)");
    args.option("--lcm-url", "URL", "LCM URL", "").option("--deputy", "ID", "deputy the messages name", "local");
    if (!args.parse()) return 0;
    lcm::LCM lcm(args.get("--lcm-url"));
    if (!lcm.good()) throw std::runtime_error("procman_probe: cannot open LCM at '" + args.get("--lcm-url") + "'");
    const std::string deputy = args.get("--deputy");
    // Orders are addressed to a deputy that does not exist: every deputy decodes every order to read its
    // address, so the variants still go through the decoder, while the many that remain well formed (a window
    // inside a stamp or a run id) are another deputy's business. Well-formed orders naming this deputy would be
    // obeyed, by protocol: procman has no authentication, as upstream.
    attack(lcm, ips::procman::kOrdersChannel, ips::test_support::sampleOrders(deputy + "-absent", nowUs()));
    attack(lcm, ips::procman::kInfoChannel, ips::test_support::sampleDeputyInfo(deputy, nowUs()));
    attack(lcm, ips::procman::kOutputChannel, ips::test_support::sampleOutput(deputy, nowUs()));
    attack(lcm, ips::procman::kDiscoverChannel, ips::test_support::sampleDiscovery(nowUs()));
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
}
