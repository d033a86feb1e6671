// Every message type survives a round trip through LCM (memq://, in process) with all fields intact, and the
// framework's checks accept what a well-formed producer sends.
#include <gtest/gtest.h>

#include <ips/disparity_map_t.hpp>
#include <ips/filter_state_t.hpp>
#include <ips/ground_truth_t.hpp>
#include <ips/health_t.hpp>
#include <ips/imu_sample_t.hpp>
#include <ips/point_cloud_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <ips/tilt_sample_t.hpp>
#include <ips/tracker_delta_t.hpp>
#include <opencv2/core.hpp>

#include "ips/framework/image.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/validate.hpp"

namespace {

// Publishes msg on a memq:// LCM and returns what a subscriber decoded.
template <class Msg>
Msg roundTrip(const Msg& msg) {
  ips::fw::Node node("roundtrip", "memq://");
  Msg got;
  int n = 0;
  node.subscribe<Msg>("CH", [&](const Msg& m) {
    got = m;
    ++n;
  });
  EXPECT_TRUE(node.publish("CH", msg));
  node.handleOnce(100);
  EXPECT_EQ(n, 1);
  return got;
}

template <class Msg>
std::vector<uint8_t> encoded(const Msg& m) {
  std::vector<uint8_t> buf(m.getEncodedSize());
  m.encode(buf.data(), 0, static_cast<int>(buf.size()));
  return buf;
}

template <class Msg>
void expectSameBytes(const Msg& a) {
  EXPECT_EQ(encoded(a), encoded(roundTrip(a)));
}

TEST(Messages, StereoPairRoundTrip) {
  cv::Mat left(1024, 1360, CV_8UC1), right(1024, 1360, CV_8UC1);
  cv::randu(left, 0, 255);
  cv::randu(right, 0, 255);
  ips::stereo_pair_t m = ips::fw::makeStereoPair(123456789, 42, left, right, "L1", "R2");
  m.exposure_us[0] = 5000;
  m.gain_db[1] = 1.5f;
  ips::stereo_pair_t r = roundTrip(m);
  EXPECT_TRUE(ips::fw::validate(r).ok());
  EXPECT_EQ(r.utime, 123456789);
  EXPECT_EQ(r.seq, 42);
  EXPECT_EQ(r.serial_right, "R2");
  EXPECT_FLOAT_EQ(r.gain_db[1], 1.5f);
  EXPECT_EQ(cv::norm(ips::fw::leftImage(r), left, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(ips::fw::rightImage(r), right, cv::NORM_INF), 0.0);
}

TEST(Messages, Mono16RoundTrip) {
  cv::Mat left(8, 10, CV_16UC1), right(8, 10, CV_16UC1);
  cv::randu(left, 0, 65535);
  cv::randu(right, 0, 65535);
  ips::stereo_pair_t r = roundTrip(ips::fw::makeStereoPair(1, 1, left, right));
  EXPECT_EQ(r.pixel_format, +ips::stereo_pair_t::PIXEL_MONO16);
  EXPECT_EQ(r.stride, 20);
  EXPECT_EQ(cv::norm(ips::fw::leftImage(r), left, cv::NORM_INF), 0.0);
}

TEST(Messages, ImuAndTiltRoundTrip) {
  ips::imu_sample_t imu{};
  imu.utime = 5;
  imu.seq = 7;
  imu.angular_rate[2] = 0.3;
  imu.specific_force[2] = 9.81;
  expectSameBytes(imu);
  ips::tilt_sample_t tilt{};
  tilt.utime = 9;
  tilt.angle_x = 0.01;
  tilt.angle_y = -0.02;
  expectSameBytes(tilt);
  EXPECT_TRUE(ips::fw::validate(roundTrip(tilt)).ok());
}

TEST(Messages, TrackerDeltaRoundTrip) {
  ips::tracker_delta_t d{};
  d.utime = 2000;
  d.utime_prev = 1000;
  d.valid = true;
  d.rotation[0] = 1;
  d.translation[0] = 0.1;
  for (int i = 0; i < 6; ++i) d.covariance[i * 7] = 1e-4;
  d.num_inliers = 99;
  d.prior_source = ips::tracker_delta_t::PRIOR_FILTER;
  expectSameBytes(d);
  EXPECT_TRUE(ips::fw::validate(roundTrip(d)).ok());
}

TEST(Messages, FilterStateRoundTrip) {
  ips::filter_state_t s{};
  s.utime = 3;
  s.filter_type = ips::filter_state_t::FILTER_UKF;
  s.orientation[0] = 1;
  s.up[2] = 1;
  s.cov_dim = 21;
  s.covariance.assign(21, std::vector<double>(21, 0.0));
  for (int i = 0; i < 21; ++i) s.covariance[i][i] = i + 1;
  s.num_sensors = 3;
  s.sensor_names = {"imu", "tilt", "tracker"};
  s.accepted = {10, 2, 1};
  s.rejected = {0, 1, 0};
  s.too_late = {0, 0, 3};
  s.calibration = {{"delta_scale", "", 1, {0.004}, {0.001}}, {"lever_arm", "m", 3, {0.1, 0.2, 0.3}, {0.01, 0.01, 0.02}}};
  s.num_calibration = 2;
  expectSameBytes(s);
  ips::filter_state_t r = roundTrip(s);
  EXPECT_EQ(r.covariance[20][20], 21.0);
  EXPECT_EQ(r.sensor_names[2], "tracker");
  ASSERT_EQ(r.calibration.size(), 2u);
  EXPECT_EQ(r.calibration[1].name, "lever_arm");
  EXPECT_EQ(r.calibration[1].unit, "m");
  EXPECT_EQ(r.calibration[1].sigma[2], 0.02);
  EXPECT_TRUE(ips::fw::validate(r).ok());
}

TEST(Messages, DisparityRoundTrip) {
  ips::disparity_map_t d{};
  d.utime = 4;
  d.width = 5;
  d.height = 3;
  d.subpixel_scale = 16;
  d.num_disparities = 128;
  d.invalid_value = -1;
  d.data.assign(3, std::vector<int16_t>(5, 0));
  d.data[2][4] = 16 * 37 + 3;
  d.confidence_size = 15;
  d.confidence.assign(15, 200);
  expectSameBytes(d);
  ips::disparity_map_t r = roundTrip(d);
  EXPECT_EQ(r.data[2][4], 16 * 37 + 3);
  EXPECT_TRUE(ips::fw::validate(r).ok());
}

TEST(Messages, PointCloudHealthAndGroundTruthRoundTrip) {
  ips::point_cloud_t p{};
  p.utime = 1;
  p.frame = "world";
  p.num_points = 2;
  p.points = {{1, 2, 3}, {4, 5, 6}};
  p.intensity = {7, 8};
  expectSameBytes(p);
  ips::health_t h{};
  h.process = "tracker";
  h.num_counters = 1;
  h.counter_names = {"nan"};
  h.counter_values = {3};
  expectSameBytes(h);
  ips::ground_truth_t g{};
  g.utime = 8;
  g.orientation[0] = 1;
  g.gyro_bias[1] = 1e-4;
  expectSameBytes(g);
}

}  // namespace
