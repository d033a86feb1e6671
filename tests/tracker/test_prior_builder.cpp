// The tracker's motion-prior builder: camera motion from the filter's states at two image times, the gyro prior
// with the bias of the filter state valid for the interval (chosen by stamp, not by arrival), and the cases
// where no prior can be made.
#include <gtest/gtest.h>

#include "ips/tracker/prior_builder.hpp"

namespace {

using ips::tracker::FilterPriorState;
using ips::tracker::MotionPrior;
using ips::tracker::PriorBuilder;
using ips::tracker::PriorBuilderParams;

Eigen::Isometry3d imuToCam() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.05, 0.0, -0.02);
  return T;
}

FilterPriorState state(int64_t utime, const Eigen::Isometry3d& T_world_body, const Eigen::Vector3d& bias) {
  FilterPriorState s;
  s.utime = utime;
  s.T_world_body = T_world_body;
  s.velocity_cov = Eigen::Matrix3d::Identity() * 0.01;
  s.angular_rate_cov = Eigen::Matrix3d::Identity() * 1e-4;
  s.gyro_bias = bias;
  return s;
}

TEST(PriorBuilder, CameraMotionFromTwoFilterStates) {
  const Eigen::Isometry3d T_imu_cam0 = imuToCam();
  PriorBuilder b(T_imu_cam0, PriorBuilderParams{}, ips::tracker::PriorParams{});
  Eigen::Isometry3d T0 = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T1 = Eigen::Isometry3d::Identity();
  T1.linear() = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T1.translation() = Eigen::Vector3d(0.2, 0.05, 0.0);
  b.addFilterState(state(1'000'000, T0, Eigen::Vector3d::Zero()));
  EXPECT_FALSE(b.fromFilter(1'000'000, 1'125'000).has_value());  // the second state is not there yet
  b.addFilterState(state(1'125'000, T1, Eigen::Vector3d::Zero()));
  const auto prior = b.fromFilter(1'000'000, 1'125'000);
  ASSERT_TRUE(prior.has_value());
  const Eigen::Isometry3d expected = (T0 * T_imu_cam0).inverse() * (T1 * T_imu_cam0);
  const MotionPrior want = MotionPrior::fromFilter(expected.linear(), expected.translation(), prior->covariance);
  EXPECT_LT((prior->R - want.R).norm(), 1e-12);
  EXPECT_LT((prior->t - want.t).norm(), 1e-12);
  // Velocity uncertainty over 0.125 s plus the 1 cm floor.
  EXPECT_NEAR(prior->covariance(0, 0), 0.01 * 0.125 * 0.125 + 0.01 * 0.01, 1e-12);
}

TEST(PriorBuilder, GyroPriorUsesTheBiasValidForTheIntervalByStamp) {
  const Eigen::Isometry3d T_imu_cam0 = imuToCam();
  PriorBuilderParams params;
  PriorBuilder b(T_imu_cam0, params, ips::tracker::PriorParams{});
  const Eigen::Vector3d rate(0.01, -0.2, 0.3);
  for (int64_t t = 990'000; t <= 1'130'000; t += 5'000) b.addGyro(t, rate);
  const Eigen::Vector3d bias_then(0.001, 0.002, -0.003), bias_later(0.05, 0.05, 0.05);
  b.addFilterState(state(900'000, Eigen::Isometry3d::Identity(), bias_then));
  // A state of a later image time that happened to arrive already must not change this interval's prior.
  b.addFilterState(state(1'250'000, Eigen::Isometry3d::Identity(), bias_later));
  const auto prior = b.fromGyro(1'000'000, 1'125'000);
  ASSERT_TRUE(prior.has_value());
  const MotionPrior want = MotionPrior::fromImuRates(rate - bias_then, T_imu_cam0.linear(), 0.125,
                                                     params.gyro_rate_sigma, ips::tracker::PriorParams{});
  EXPECT_LT((prior->R - want.R).norm(), 1e-12);
  EXPECT_LT((prior->covariance - want.covariance).norm(), 1e-12);
  // Samples that do not cover the interval give no prior.
  EXPECT_FALSE(b.fromGyro(1'000'000, 1'200'000).has_value());
}

TEST(PriorBuilder, HoldsABoundedNumberOfStates) {
  PriorBuilderParams params;
  params.max_filter_states = 3;
  PriorBuilder b(imuToCam(), params, ips::tracker::PriorParams{});
  for (int64_t t = 1; t <= 5; ++t)
    b.addFilterState(state(t * 100'000, Eigen::Isometry3d::Identity(), Eigen::Vector3d::Zero()));
  EXPECT_TRUE(b.filterSeen());
  EXPECT_FALSE(b.hasFilterState(200'000));
  EXPECT_TRUE(b.hasFilterState(300'000));
  EXPECT_TRUE(b.hasFilterState(500'000));
}

}  // namespace
