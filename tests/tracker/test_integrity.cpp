// Epipolar integrity: the row search against a known vertical shift of a real image, the monitor against its
// analytic model (a known correction, a step, an unchanged head), the rectification with a right-camera correction,
// and the schedule by which E3D takes corrections.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "ips/calibration.hpp"
#include "ips/tracker/corners.hpp"
#include "ips/tracker/epipolar_integrity.hpp"
#include "test_util.hpp"

using namespace ips;
using namespace ips::tracker;

namespace {

constexpr double kDeg = M_PI / 180;

StereoRectification geometry() {
  StereoRectification r;
  r.size = cv::Size(1360, 1024);
  r.f = 744.19;
  r.cx = 679.5;
  r.cy = 511.5;
  r.baseline = 0.2;
  return r;
}

// A pair's matches as the model says a right camera needing `truth` shows them when rectified with `applied`:
// points spread over the image, with noise of sigma_px.
std::vector<VerticalMatch> syntheticPair(const EpipolarMonitor& m, const Eigen::Vector4d& truth,
                                         const Eigen::Vector4d& applied, double sigma_px, std::mt19937& rng) {
  std::uniform_real_distribution<double> ux(20, 1340), uy(20, 1004);
  std::normal_distribution<double> noise(0, sigma_px);
  std::vector<VerticalMatch> out(100);
  for (VerticalMatch& v : out) {
    v.xl = float(ux(rng));
    v.xr = v.xl - 20;
    v.y = float(uy(rng));
    v.dy = float(m.rowOffset(truth - applied, v.xr, v.y) + noise(rng));
    v.ncc = 0.95f;
  }
  return out;
}

}  // namespace

TEST(Integrity, RowSearchFindsAKnownVerticalShift) {
  IPS_REQUIRE_SHARED_DATA("stereo/teddy/left.png");
  // A real image and itself moved 2.3 px down and 12 px left (subpixel by bilinear interpolation): every corner's
  // vertical disparity is 2.3 px.
  const cv::Mat left = cv::imread(test::dataDir() + "/stereo/teddy/left.png", cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(left.empty());
  const double shift_y = 2.3;
  const cv::Mat warp = (cv::Mat_<double>(2, 3) << 1, 0, -12, 0, 1, shift_y);
  cv::Mat right;
  cv::warpAffine(left, right, warp, left.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  TrackerParams tp;
  const std::vector<Corner> corners = detectCorners(left, tp.detector, 30);
  ASSERT_GT(corners.size(), 50u);
  IntegrityParams ip;
  const std::vector<VerticalMatch> m = matchAcrossRows(left, right, corners, tp.matcher, ip);
  ASSERT_GT(m.size(), corners.size() / 2);
  std::vector<double> dy, dx;
  for (const VerticalMatch& v : m) {
    dy.push_back(v.dy);
    dx.push_back(v.xl - v.xr);
  }
  std::sort(dy.begin(), dy.end());
  std::sort(dx.begin(), dx.end());
  EXPECT_NEAR(dy[dy.size() / 2], shift_y, 0.1);
  EXPECT_NEAR(dx[dx.size() / 2], 12.0, 0.1);
  // Nine in ten within 0.25 px: the parabola's subpixel step.
  EXPECT_NEAR(dy[dy.size() / 20], shift_y, 0.25);
  EXPECT_NEAR(dy[dy.size() * 19 / 20], shift_y, 0.25);
}

TEST(Integrity, MonitorFindsAKnownCorrectionAndAppliesIt) {
  EpipolarMonitor monitor(geometry(), IntegrityParams());
  const Eigen::Vector4d truth(0.10 * kDeg, 0.05 * kDeg, -0.08 * kDeg, 3e-4);
  std::mt19937 rng(7);
  int64_t utime = 1'000'000;
  for (int k = 0; k < 80; ++k, utime += 125'000) {
    const Eigen::Vector4d applied = toVector(monitor.status().applied);
    monitor.update(utime, syntheticPair(monitor, truth, applied, 0.15, rng), 100);
  }
  const IntegrityStatus& s = monitor.status();
  EXPECT_GE(s.corrections, 1);
  EXPECT_TRUE(s.certain);
  EXPECT_EQ(s.state, IntegrityStatus::State::Ok);  // the applied correction has put the rows back
  const Eigen::Vector4d est = toVector(s.estimate);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(est[i] / kDeg, truth[i] / kDeg, 0.003) << "axis " << i;
  EXPECT_NEAR(est[3], truth[3], 5e-5);
  EXPECT_LT(monitor.largestOffset(toVector(s.applied) - truth), 0.1);
}

TEST(Integrity, MonitorSeesAStepAtOnceAndNothingOnAnUnchangedHead) {
  EpipolarMonitor monitor(geometry(), IntegrityParams());
  std::mt19937 rng(11);
  int64_t utime = 1'000'000;
  const Eigen::Vector4d none = Eigen::Vector4d::Zero();
  // 60 s unchanged: no alarm, no step, nothing to correct.
  for (int k = 0; k < 480; ++k, utime += 125'000)
    monitor.update(utime, syntheticPair(monitor, none, toVector(monitor.status().applied), 0.15, rng), 100);
  EXPECT_EQ(monitor.status().alarms, 0);
  EXPECT_EQ(monitor.status().steps, 0);
  EXPECT_EQ(monitor.status().corrections, 0);
  EXPECT_EQ(monitor.status().state, IntegrityStatus::State::Ok);
  // A knock of 0.2 deg: the alarm within alarm_pairs pairs, one step, and the rows back after the correction.
  const Eigen::Vector4d knock(0.1414 * kDeg, 0, 0.1414 * kDeg, 0);
  int alarm_after = -1;
  for (int k = 0; k < 40; ++k, utime += 125'000) {
    monitor.update(utime, syntheticPair(monitor, knock, toVector(monitor.status().applied), 0.15, rng), 100);
    if (alarm_after < 0 && monitor.status().state == IntegrityStatus::State::Alarm) alarm_after = k + 1;
  }
  EXPECT_GE(alarm_after, 1);
  EXPECT_LE(alarm_after, IntegrityParams().alarm_pairs);
  EXPECT_EQ(monitor.status().alarms, 1);
  EXPECT_EQ(monitor.status().steps, 1);
  EXPECT_EQ(monitor.status().state, IntegrityStatus::State::Ok);
  EXPECT_LT((toVector(monitor.status().estimate) - knock).head<3>().norm() / kDeg, 0.003);
}

TEST(Integrity, MonitorIgnoresPairsWithTooFewPointsAndOlderStamps) {
  EpipolarMonitor monitor(geometry(), IntegrityParams());
  std::mt19937 rng(3);
  std::vector<VerticalMatch> few = syntheticPair(monitor, Eigen::Vector4d::Zero(), Eigen::Vector4d::Zero(), 0.1, rng);
  few.resize(IntegrityParams().min_points - 1);
  monitor.update(2'000'000, few, 100);
  EXPECT_FALSE(monitor.status().pair_valid);
  EXPECT_EQ(monitor.status().pairs_without_measurement, 1);
  EXPECT_EQ(monitor.status().state, IntegrityStatus::State::NoData);
  const int64_t before = monitor.status().utime;
  monitor.update(1'000'000, few, 100);  // older: ignored
  EXPECT_EQ(monitor.status().utime, before);
  EXPECT_EQ(monitor.status().pairs_without_measurement, 1);
}

TEST(Integrity, RectificationWithARightCorrectionKeepsTheLeftAndTurnsTheRight) {
  StereoCalibration calib;
  calib.cam0.width = calib.cam1.width = 640;
  calib.cam0.height = calib.cam1.height = 480;
  calib.cam0.K << 500, 0, 319.5, 0, 500, 239.5, 0, 0, 1;
  calib.cam1.K = calib.cam0.K;
  calib.t_cam1_cam0 = Eigen::Vector3d(-0.2, 0, 0);
  const StereoRectification plain = computeRectification(calib);
  RightCameraCorrection c;
  c.rotation = Eigen::Vector3d(0.002, -0.001, 0.003);
  c.focal_scale = 1e-3;
  const StereoRectification turned = computeRectification(calib, 0.0, c);
  EXPECT_EQ(cv::norm(plain.map0x, turned.map0x, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(plain.map0y, turned.map0y, cv::NORM_INF), 0.0);
  EXPECT_EQ(plain.f, turned.f);
  EXPECT_EQ(plain.baseline, turned.baseline);
  // wx and wz turn the camera; the yaw wy moves rows only.
  const Eigen::Vector3d turn(c.rotation.x(), 0, c.rotation.z());
  const Eigen::Matrix3d expected =
      Eigen::AngleAxisd(turn.norm(), turn.normalized()).toRotationMatrix() * plain.R_rect1_cam1;
  EXPECT_LT((turned.R_rect1_cam1 - expected).norm(), 1e-12);
  // A rectified right pixel (x, y) samples the raw image where the turned and scaled ray through (x, y - f u v wy)
  // lands: on the optical axis the keystone is zero, in a corner it is f u v wy.
  const double fx = 500 * (1 + c.focal_scale);
  auto ray = [&](double x, double y) {
    const Eigen::Vector3d r =
        turned.R_rect1_cam1.transpose() * Eigen::Vector3d((x - turned.cx) / turned.f, (y - turned.cy) / turned.f, 1.0);
    return Eigen::Vector2d(319.5 + fx * r.x() / r.z(), 239.5 + fx * r.y() / r.z());
  };
  for (const cv::Point px :
       {cv::Point(int(std::lround(plain.cx)), int(std::lround(plain.cy))), cv::Point(40, 30), cv::Point(600, 450)}) {
    const double u = (px.x - turned.cx) / turned.f, v = (px.y - turned.cy) / turned.f;
    const Eigen::Vector2d raw = ray(px.x, px.y - turned.f * u * v * c.rotation.y());
    EXPECT_NEAR(turned.map1x.at<float>(px), raw.x(), 2e-3) << px;
    EXPECT_NEAR(turned.map1y.at<float>(px), raw.y(), 2e-3) << px;
  }
  // The yaw's keystone is there in a corner (f u v wy is 0.12 px at (40, 30)).
  RightCameraCorrection no_yaw = c;
  no_yaw.rotation.y() = 0;
  const StereoRectification without = computeRectification(calib, 0.0, no_yaw);
  EXPECT_GT(std::abs(turned.map1y.at<float>(30, 40) - without.map1y.at<float>(30, 40)), 0.08);
  // A disparity offset reads the right image that much further right: pixel (x, y) samples where (x + offset, y)
  // did (on this undistorted head the map is linear along a row there), and the left stays.
  RightCameraCorrection shifted = c;
  shifted.disparity_offset_px = 0.37;
  const StereoRectification moved = computeRectification(calib, 0.0, shifted);
  EXPECT_EQ(cv::norm(plain.map0x, moved.map0x, cv::NORM_INF), 0.0);
  for (const cv::Point px : {cv::Point(320, 240), cv::Point(40, 30), cv::Point(600, 450)}) {
    const double u = (px.x + shifted.disparity_offset_px - moved.cx) / moved.f, v = (px.y - moved.cy) / moved.f;
    const Eigen::Vector2d raw = ray(px.x + shifted.disparity_offset_px, px.y - moved.f * u * v * c.rotation.y());
    EXPECT_NEAR(moved.map1x.at<float>(px), raw.x(), 5e-3) << px;
    EXPECT_NEAR(moved.map1y.at<float>(px), raw.y(), 5e-3) << px;
  }
}

TEST(Integrity, ScheduleGivesEachPairTheCorrectionDecidedBeforeIt) {
  RightCorrectionSchedule s;
  RightCameraCorrection a, b;
  a.rotation = Eigen::Vector3d(1e-3, 0, 0);
  b.rotation = Eigen::Vector3d(2e-3, 0, 0);
  EXPECT_TRUE(s.add(100, a));
  EXPECT_TRUE(s.add(200, b));
  EXPECT_FALSE(s.add(150, a));           // out of order
  EXPECT_TRUE(s.forPair(100).isZero());  // decided on this pair: applies to the next
  EXPECT_EQ(s.forPair(101), a);
  EXPECT_EQ(s.forPair(200), a);
  EXPECT_EQ(s.forPair(201), b);
  s.dropBefore(300);
  EXPECT_EQ(s.size(), 1u);
  EXPECT_EQ(s.forPair(301), b);
}
