// The camera's delay against the IMU estimated online (ips/filter/camera_delay.hpp) on a simulated head whose camera
// stamps are late by a known amount: the latency schedule takes the estimate once it is certain, from a stamp past the
// deltas it used, and depends on the stamps alone (deltas arriving early or late against the gyro give the same).
#include <gtest/gtest.h>

#include <cstdio>

#include "ips/filter/camera_delay.hpp"
#include "simulated_motion.hpp"

using ips::calib::testing::SimulatedMotion;
using ips::calib::testing::simulateMotion;
using ips::filter::CameraDelayEstimator;
using ips::filter::CameraDelayParams;

namespace {

// Feeds gyro and deltas in arrival order: each delta arrives lag_us after its stamp, among the gyro samples.
CameraDelayEstimator feed(const SimulatedMotion& sim, int64_t lag_us, int64_t initial_latency_us) {
  CameraDelayParams params;
  CameraDelayEstimator estimator(params, sim.R_cam_imu.transpose(), initial_latency_us);
  size_t d = 0;
  for (const auto& g : sim.gyro) {
    for (; d < sim.deltas.size() && sim.deltas[d].utime + lag_us <= g.utime; ++d)
      estimator.addDelta(sim.deltas[d].utime_prev, sim.deltas[d].utime, sim.deltas[d].rotation);
    estimator.addGyro(g.utime, g.rate);
  }
  return estimator;
}

}  // namespace

TEST(CameraDelay, TheEstimateReplacesTheConfiguredLatencyOnceCertain) {
  const int64_t late = 3'000, configured = 500;
  const SimulatedMotion sim = simulateMotion(45.0, late, 21);  // within the window of 480 intervals
  const CameraDelayEstimator e = feed(sim, 300'000, configured);
  const CameraDelayEstimator::Figures& f = e.figures();
  std::printf("delay %.1f us (sigma %.1f, true %lld) from %zu intervals, %lld estimates\n", f.delay_us, f.sigma_us,
              static_cast<long long>(late), f.intervals, static_cast<long long>(f.estimates));
  ASSERT_TRUE(f.applied);
  // Within its own uncertainty (this head's tracker noise, 0.5 mrad per axis, gives about 100 us over 480 intervals).
  EXPECT_NEAR(f.delay_us, static_cast<double>(late), 4 * f.sigma_us);
  EXPECT_LT(f.sigma_us, CameraDelayParams().max_sigma_us);
  // Early stamps keep the configured latency; the last ones have the estimate.
  EXPECT_EQ(e.latencyAt(sim.deltas.front().utime), configured);
  EXPECT_NEAR(static_cast<double>(e.latencyAt(sim.deltas.back().utime)), static_cast<double>(late), 4 * f.sigma_us);
  // Not before the deltas of min_intervals (8 s at 10 Hz) plus the switch's margin.
  const int64_t first = sim.deltas.front().utime;
  EXPECT_EQ(e.latencyAt(first + 8'000'000), configured);
}

TEST(CameraDelay, TheScheduleDependsOnTheStampsNotOnArrival) {
  const SimulatedMotion sim = simulateMotion(60.0, -4'000, 5);
  const CameraDelayEstimator early = feed(sim, 50'000, 0), late = feed(sim, 900'000, 0);
  ASSERT_TRUE(early.figures().applied);
  EXPECT_EQ(early.figures().estimates, late.figures().estimates);
  for (const auto& d : sim.deltas) ASSERT_EQ(early.latencyAt(d.utime), late.latencyAt(d.utime)) << d.utime;
}

TEST(CameraDelay, OffLeavesTheConfiguredLatency) {
  const SimulatedMotion sim = simulateMotion(40.0, 3'000, 9);
  CameraDelayParams params;
  params.estimate = false;
  CameraDelayEstimator e(params, sim.R_cam_imu.transpose(), 1'234);
  for (const auto& g : sim.gyro) e.addGyro(g.utime, g.rate);
  for (const auto& d : sim.deltas) e.addDelta(d.utime_prev, d.utime, d.rotation);
  EXPECT_FALSE(e.figures().applied);
  EXPECT_EQ(e.figures().estimates, 0);
  EXPECT_EQ(e.latencyAt(sim.deltas.back().utime), 1'234);
}

// A head whose configured latency is right keeps it exactly: the estimates agree with it within their uncertainty.
TEST(CameraDelay, ARightLatencyIsKept) {
  const SimulatedMotion sim = simulateMotion(60.0, 2'000, 13);
  const CameraDelayEstimator e = feed(sim, 300'000, 2'000);
  EXPECT_GT(e.figures().estimates, 10);
  EXPECT_NEAR(e.figures().delay_us, 2'000.0, 4 * e.figures().sigma_us);
  EXPECT_FALSE(e.figures().applied);
  for (const auto& d : sim.deltas) ASSERT_EQ(e.latencyAt(d.utime), 2'000);
}
