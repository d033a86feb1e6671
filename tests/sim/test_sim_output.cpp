// What the sim process makes of the simulation besides messages: ground-truth disparity in 1/16 px, the path of the
// true calibration beside a perturbed one, and live mode's clock.
#include <gtest/gtest.h>

#include "ips/sim/output.hpp"

namespace {

using ips::sim::FixedPointDisparity;
using ips::sim::LiveClock;

TEST(SimOutput, GroundTruthDisparityInSixteenthsOfAPixel) {
  cv::Mat gt = (cv::Mat_<float>(2, 3) << 0.0f, 1.5f, -1.0f, 0.03125f, 10.2f, 2047.9f);
  FixedPointDisparity f = ips::sim::toFixedPoint(gt);
  ASSERT_EQ(f.data.type(), CV_16SC1);
  ASSERT_EQ(f.data.size(), gt.size());
  EXPECT_EQ(f.data.at<int16_t>(0, 0), FixedPointDisparity::kInvalid);  // nothing seen
  EXPECT_EQ(f.data.at<int16_t>(0, 1), 24);
  EXPECT_EQ(f.data.at<int16_t>(0, 2), FixedPointDisparity::kInvalid);
  EXPECT_EQ(f.data.at<int16_t>(1, 0), 1);  // half of 1/16 px rounds up
  EXPECT_EQ(f.data.at<int16_t>(1, 1), 163);
  EXPECT_EQ(f.data.at<int16_t>(1, 2), 32766);  // 32766.4 still fits
  EXPECT_EQ(f.num_disparities, 2047);

  gt.at<float>(1, 2) = 2048.0f;  // 32768: does not fit
  f = ips::sim::toFixedPoint(gt);
  EXPECT_EQ(f.data.at<int16_t>(1, 2), FixedPointDisparity::kInvalid);
  EXPECT_EQ(f.num_disparities, 2047);  // the most a map holds
  gt.at<float>(1, 2) = 0.0f;
  EXPECT_EQ(ips::sim::toFixedPoint(gt).num_disparities, 12);  // ceil(10.2) + 1
}

TEST(SimOutput, TheTrueCalibrationGoesBesideThePerturbedOne) {
  EXPECT_EQ(ips::sim::truthCalibrationPath("out/walk.lcmlog.calib.yaml"), "out/walk.lcmlog.true.calib.yaml");
  EXPECT_EQ(ips::sim::truthCalibrationPath("sim.yaml"), "sim.yaml.true.calib.yaml");
  EXPECT_EQ(ips::sim::truthCalibrationPath(".calib.yaml"), ".calib.yaml.true.calib.yaml");
}

TEST(SimOutput, LiveEventsAreDueAtTheirTimeOverTheRateHalfASecondAfterTheFirst) {
  LiveClock clock(10'000'000, 2.0);
  const LiveClock::Clock::time_point t0{std::chrono::seconds(100)};
  const auto first = clock.due(11'000'000, t0);
  EXPECT_EQ(first, t0 + std::chrono::milliseconds(500));
  // Later calls keep the clock: 0.5 s of log time at rate 2 is 0.25 s.
  EXPECT_EQ(clock.due(11'500'000, t0 + std::chrono::seconds(7)), first + std::chrono::milliseconds(250));
  EXPECT_EQ(clock.due(11'000'000, t0), first);
  EXPECT_FALSE(LiveClock::late(first, first + std::chrono::milliseconds(50)));
  EXPECT_TRUE(LiveClock::late(first, first + std::chrono::milliseconds(51)));
  EXPECT_FALSE(LiveClock::late(first, first - std::chrono::seconds(1)));
}

}  // namespace
