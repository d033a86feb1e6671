// The time base: camera clock mapping against a simulated drifting clock with jittery arrivals, and frame pairing
// with lost frames.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "ips/drivers/clock_mapper.hpp"
#include "ips/drivers/frame_pairer.hpp"

using namespace ips::drivers;

TEST(ClockMapper, FollowsDriftAndIgnoresLatencyJitter) {
  std::mt19937 rng(7);
  std::exponential_distribution<double> jitter(1.0 / 300.0);  // mean 300 us above the latency floor
  std::uniform_real_distribution<double> u(0, 1);
  ClockMapper mapper;  // window 300
  const double drift = 80e-6;
  const int64_t floor_us = 800;
  double worst_late = 0;
  for (int k = 0; k < 900; ++k) {
    const int64_t t = 1'700'000'000'000'000 + k * 33'333;  // true event times, 30 Hz
    const int64_t device = 5'000'000 + static_cast<int64_t>((t - 1'700'000'000'000'000) * (1.0 + drift));
    double latency = floor_us + jitter(rng);
    if (u(rng) < 0.02) latency += 8000;  // now and then a frame waits behind other traffic
    const int64_t mapped = mapper.update(device, t + static_cast<int64_t>(latency));
    if (k >= 150) worst_late = std::max(worst_late, std::fabs(static_cast<double>(mapped - (t + floor_us))));
  }
  std::printf("worst mapping error after warm-up: %.0f us, drift %.1f ppm\n", worst_late, mapper.driftPpm());
  EXPECT_LT(worst_late, 150.0) << "mapped stamps vs event + latency floor";
  EXPECT_NEAR(mapper.driftPpm(), -80.0, 10.0);  // host runs slower than the device by 80 ppm
  EXPECT_EQ(mapper.resets(), 0u);
}

TEST(ClockMapper, DeviceClockRestartResets) {
  ClockMapper mapper;
  for (int k = 0; k < 100; ++k) mapper.update(9'000'000 + k * 100'000, 1'000'000'000 + k * 100'000 + 500);
  EXPECT_EQ(mapper.resets(), 0u);
  // The camera was power-cycled: its clock starts again near zero.
  int64_t mapped = 0;
  for (int k = 0; k < 10; ++k) mapped = mapper.update(1000 + k * 100'000, 1'000'000'000 + (120 + k) * 100'000 + 500);
  EXPECT_EQ(mapper.resets(), 1u);
  EXPECT_NEAR(static_cast<double>(mapped), 1'000'000'000 + 129 * 100'000 + 500, 5.0);
  EXPECT_THROW(ClockMapper().map(0), std::logic_error);
}

namespace {
struct Tagged {
  int id;
};
}  // namespace

TEST(FramePairer, LostFramesAreDroppedNeverMispaired) {
  FramePairer<Tagged> pairer(FramePairerConfig{2000, 4});
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> jitter(-300, 300);
  std::vector<std::pair<int, int>> pairs;
  for (int k = 0; k < 100; ++k) {
    const int64_t t = 1'000'000 + k * 100'000;
    // Arrival order alternates; left frame 10 and right frames 5, 6 are lost.
    for (int side : {k % 2, 1 - k % 2}) {
      if ((side == 0 && k == 10) || (side == 1 && (k == 5 || k == 6))) continue;
      if (auto p = pairer.push(side, t + jitter(rng), Tagged{k})) pairs.emplace_back(p->left.id, p->right.id);
    }
  }
  ASSERT_EQ(pairs.size(), 97u);
  for (const auto& [l, r] : pairs) EXPECT_EQ(l, r);
  EXPECT_EQ(pairer.unpaired(0), 2);  // left 5 and 6 had no partner
  EXPECT_EQ(pairer.unpaired(1), 1);  // right 10
}

TEST(FramePairer, SilentCameraAndDifferentRates) {
  FramePairer<Tagged> pairer(FramePairerConfig{2000, 3});
  int paired = 0;
  for (int k = 0; k < 10; ++k) paired += pairer.push(0, k * 100'000, Tagged{k}).has_value();
  EXPECT_EQ(paired, 0);
  EXPECT_EQ(pairer.waiting(0), 3u);  // the rest dropped while the right camera was silent
  EXPECT_EQ(pairer.unpaired(0), 7);
  // Right camera at half the rate: every right frame pairs with the left frame of its time.
  for (int k = 10; k < 30; ++k) {
    if (auto p = pairer.push(0, k * 100'000, Tagged{k})) {
      EXPECT_EQ(p->left.id, p->right.id);
      ++paired;
    }
    if (k % 2 == 0)
      if (auto p = pairer.push(1, k * 100'000 + 500, Tagged{k})) {
        EXPECT_EQ(p->left.id, p->right.id);
        ++paired;
      }
  }
  EXPECT_EQ(paired, 10);
  EXPECT_EQ(pairer.push(1, 0, Tagged{0}).has_value(), false);  // a stamp going backwards
  EXPECT_EQ(pairer.outOfOrder(1), 1);
}
