// The whole tracker: textured-plane stereo sequences with a known motion (images by plane homographies of
// a real image), the real EuRoC pairs against both ground truths, priors, recovery and bad input.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cstdio>
#include <opencv2/imgcodecs.hpp>

#include "ips/tracker/euroc_calibration.hpp"
#include "ips/tracker/stereo_tracker.hpp"
#include "test_util.hpp"

using namespace ips::tracker;

namespace {

double rotationErrorDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return logSO3(a.transpose() * b).norm() * 180.0 / M_PI;
}

struct EurocCase {
  ips::StereoCalibration calib;
  cv::Mat l0, r0, l1, r1;
  Eigen::Isometry3d T_imu_cam0;
};

EurocCase loadEuroc(const std::string& t0, const std::string& t1) {
  const std::string dir = test::dataDir() + "/euroc/V1_01_easy/moving_pairs/";
  EurocCase c;
  c.calib = calibrationFromEuroc(dir + "sensorLeft.yaml", dir + "sensorRight.yaml");
  c.l0 = cv::imread(dir + t0 + "_left.png", cv::IMREAD_GRAYSCALE);
  c.r0 = cv::imread(dir + t0 + "_right.png", cv::IMREAD_GRAYSCALE);
  c.l1 = cv::imread(dir + t1 + "_left.png", cv::IMREAD_GRAYSCALE);
  c.r1 = cv::imread(dir + t1 + "_right.png", cv::IMREAD_GRAYSCALE);
  return c;
}

// Ground-truth motion of camera 0 (X_0 = R X_1 + t) from body poses and T_body_cam0.
Eigen::Isometry3d groundTruthDelta(const std::string& source, const std::string& t0, const std::string& t1,
                                   const Eigen::Isometry3d& T_imu_cam0) {
  auto poses = test::eurocPoses();
  const Eigen::Isometry3d A = poses.at(source).at(t0) * T_imu_cam0;
  const Eigen::Isometry3d B = poses.at(source).at(t1) * T_imu_cam0;
  return A.inverse() * B;
}

}  // namespace

// The real two-frame test of the issue: 0.5 s apart, 0.32 m and 15.6 deg, no prior.
TEST(TrackerEuroc, MovingPairsAgainstBothGroundTruths) {
  const std::string t0 = "1403715400262142976", t1 = "1403715400762142976";
  const EurocCase c = loadEuroc(t0, t1);
  ASSERT_FALSE(c.l0.empty());
  StereoTracker tracker(c.calib, TrackerParams());
  EXPECT_FALSE(tracker.process(0, c.l0, c.r0).valid);  // first pair: nothing to compare with
  const TrackResult r = tracker.process(500000, c.l1, c.r1);
  ASSERT_TRUE(r.valid);
  EXPECT_EQ(r.utime_prev, 0);
  EXPECT_EQ(r.prior_source, MotionPrior::Source::None);
  for (const char* source : {"openvins_vicon2gt", "euroc_original"}) {
    const Eigen::Isometry3d gt = groundTruthDelta(source, t0, t1, c.calib.T_imu_cam0);
    const double rot_err = rotationErrorDeg(r.rotation.toRotationMatrix(), gt.linear());
    const double t_err = (r.translation - gt.translation()).norm();
    const double rel = t_err / gt.translation().norm();
    std::printf("[ EUROC    ] %s: motion %.3f m %.2f deg; error rotation %.3f deg, translation %.4f m = %.2f %%\n",
                source, gt.translation().norm(), logSO3(gt.linear()).norm() * 180 / M_PI, rot_err, t_err, 100 * rel);
    RecordProperty(std::string(source) + "_rotation_error_deg", std::to_string(rot_err));
    RecordProperty(std::string(source) + "_translation_error_percent", std::to_string(100 * rel));
    EXPECT_LT(rot_err, 0.3) << source;
    if (std::string(source) == "openvins_vicon2gt") {
      EXPECT_LT(rel, 0.03) << source;  // the target is stated against this one
    }
    // The two ground truths differ by about 4 cm on this motion (mostly a lever arm).
    EXPECT_LT(rel, 0.2) << source;
  }
  // The covariance is a proper one.
  Eigen::SelfAdjointEigenSolver<Matrix6d> eig(r.covariance);
  EXPECT_GT(eig.eigenvalues().minCoeff(), 0.0);
  EXPECT_GT(r.num_inliers, 30);
}
