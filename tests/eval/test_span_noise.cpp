// The three-cornered hat on second differences (ips/eval/span_noise.hpp) on an analytic motion: without noise the
// three measurements agree to a micrometre (frames, lever arm, gravity and the double integration are right); a
// constant accelerometer bias and a wrong gravity are fitted; with white noise of known size in each, the hat gives
// each one's figure that the noise predicts.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "ips/eval/span_noise.hpp"

using namespace ips::eval;

namespace {

constexpr double kG = 9.81;

// Body pose, acceleration (world) at t: smooth sines on every axis, the attitude turning about all three.
struct Motion {
  static Eigen::Vector3d position(double t) {
    return {0.5 * std::sin(0.8 * t), 0.3 * std::sin(1.1 * t + 0.4), 0.1 * std::sin(1.7 * t)};
  }
  static Eigen::Vector3d acceleration(double t) {
    return {-0.5 * 0.64 * std::sin(0.8 * t), -0.3 * 1.21 * std::sin(1.1 * t + 0.4), -0.1 * 2.89 * std::sin(1.7 * t)};
  }
  static Eigen::Quaterniond attitude(double t) {
    return Eigen::Quaterniond(Eigen::AngleAxisd(0.4 * std::sin(0.5 * t), Eigen::Vector3d::UnitZ()) *
                              Eigen::AngleAxisd(0.1 * std::sin(0.7 * t), Eigen::Vector3d::UnitY()) *
                              Eigen::AngleAxisd(0.05 * std::sin(0.9 * t), Eigen::Vector3d::UnitX()));
  }
};

struct Noise {
  double truth_m = 0, estimate_m = 0, accel = 0;  // white, per sample
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();
  double gravity = kG;  // the world's; the evaluation assumes kG
};

// 60 s: truth and IMU at 200 Hz, camera 0 at 20 Hz on every tenth IMU stamp, given in a frame of its own.
SpanNoiseInput makeInput(const Noise& noise, unsigned seed = 7) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  auto white = [&](double s) { return Eigen::Vector3d(s * n01(rng), s * n01(rng), s * n01(rng)); };
  SpanNoiseInput in;
  in.gravity = kG;
  in.T_imu_cam0.linear() =
      (Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  in.T_imu_cam0.translation() = Eigen::Vector3d(-0.02, -0.065, 0.01);
  Eigen::Isometry3d T_est_world = Eigen::Isometry3d::Identity();  // where the estimate's frame lies
  T_est_world.linear() = Eigen::AngleAxisd(1.0, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  T_est_world.translation() = Eigen::Vector3d(3, -1, 2);
  for (int i = 0; i <= 12000; ++i) {
    const double t = 100.0 + 0.005 * i;
    const Eigen::Quaterniond q = Motion::attitude(t);
    TrajPoint g;
    g.t = t;
    g.p = Motion::position(t) + white(noise.truth_m);
    g.q = q;
    in.truth.push_back(g);
    ips::filter::ImuSample s;
    s.utime = static_cast<int64_t>(std::llround(t * 1e6));
    s.specific_force = q.conjugate() * (Motion::acceleration(t) + Eigen::Vector3d(0, 0, noise.gravity)) +
                       noise.accel_bias + white(noise.accel);
    in.imu.push_back(s);
    if (i % 10 == 0) {
      Eigen::Isometry3d T_wb = Eigen::Isometry3d::Identity();
      T_wb.linear() = q.toRotationMatrix();
      T_wb.translation() = Motion::position(t) + white(noise.estimate_m);
      const Eigen::Isometry3d T_ec = T_est_world * T_wb * in.T_imu_cam0;
      TrajPoint c;
      c.t = t;
      c.p = T_ec.translation();
      c.q = Eigen::Quaterniond(T_ec.linear());
      in.estimate.push_back(c);
    }
  }
  return in;
}

}  // namespace

TEST(SpanNoise, WithoutNoiseTheThreeAgree) {
  const std::vector<SpanNoise> r = spanNoise(makeInput({}), {1, 2, 4, 8});
  ASSERT_EQ(r.size(), 4u);
  for (const SpanNoise& s : r) {
    EXPECT_NEAR(s.span_s, 0.05 * s.span_frames, 1e-6);
    EXPECT_GT(s.centres, 1150u);
    EXPECT_LT(s.truth_vs_estimate, 1e-6);
    EXPECT_LT(s.truth_vs_imu, 1e-6) << "span " << s.span_frames;
    EXPECT_LT(s.estimate_vs_imu, 1e-6);
    EXPECT_LT(s.accel_bias.norm(), 1e-4);
    EXPECT_LT(std::abs(s.gravity_error), 1e-4);
  }
}

TEST(SpanNoise, FitsTheAccelerometerBiasAndGravity) {
  Noise noise;
  noise.accel_bias = Eigen::Vector3d(0.05, -0.03, 0.02);
  noise.gravity = 9.80;
  for (const SpanNoise& s : spanNoise(makeInput(noise), {1, 4})) {
    EXPECT_LT((s.accel_bias - noise.accel_bias).norm(), 1e-4) << s.accel_bias.transpose();
    EXPECT_NEAR(s.gravity_error, noise.gravity - kG, 1e-4);
    EXPECT_LT(s.truth_vs_imu, 1e-6);
  }
}

TEST(SpanNoise, TheHatGivesEachOnesWhiteNoise) {
  Noise noise;
  noise.truth_m = 1e-4;
  noise.estimate_m = 1.5e-4;
  noise.accel = 0.3;
  noise.accel_bias = Eigen::Vector3d(0.1, 0.05, -0.08);
  const std::vector<SpanNoise> r = spanNoise(makeInput(noise), {1, 2});
  ASSERT_EQ(r.size(), 2u);
  for (const SpanNoise& s : r) {
    // p(t+T) - 2 p(t) + p(t-T) of white position noise: sqrt(6) sigma; of white acceleration noise integrated twice
    // with the triangle T - |s|: sigma sqrt(dt 2 T^3 / 3).
    const double T = s.span_s;
    EXPECT_NEAR(s.truth, std::sqrt(6.0) * noise.truth_m, 0.15 * std::sqrt(6.0) * noise.truth_m) << "span " << T;
    EXPECT_NEAR(s.estimate, std::sqrt(6.0) * noise.estimate_m, 0.15 * std::sqrt(6.0) * noise.estimate_m);
    const double imu = imuWhiteNoiseSecondDifference(noise.accel * std::sqrt(0.005), T);
    EXPECT_NEAR(s.imu, imu, 0.2 * imu) << "span " << T;
    // Body z stays within 0.11 rad of the world's up: its bias and gravity's error are told apart only by that tilt,
    // their sum is what the data fix.
    EXPECT_LT((s.accel_bias - noise.accel_bias).head<2>().norm(), 0.02) << s.accel_bias.transpose();
    EXPECT_NEAR(s.accel_bias.z() + s.gravity_error, noise.accel_bias.z(), 0.02);
  }
}

TEST(SpanNoise, SkipsGapsAndRefusesTooLittle) {
  SpanNoiseInput in = makeInput({});
  // A lost pair: the centres whose sides would cross it are left out, the rest agree as before.
  in.estimate.erase(in.estimate.begin() + 500);
  const std::vector<SpanNoise> r = spanNoise(in, {1, 3});
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r[0].centres, 1201u - 2 - 3);
  EXPECT_EQ(r[1].centres, 1201u - 6 - 7);
  EXPECT_LT(r[1].truth_vs_imu, 1e-6);
  SpanNoiseInput few = in;
  few.imu.resize(2);
  EXPECT_THROW(spanNoise(few, {1}), std::invalid_argument);
  EXPECT_THROW(spanNoise(in, {0}), std::invalid_argument);
}

TEST(SpanNoise, WithoutAnEstimateTheImuIsJudgedAgainstTheTruthAtItsSamples) {
  Noise noise;
  noise.truth_m = 1e-4;
  noise.accel = 0.3;
  noise.accel_bias = Eigen::Vector3d(0.1, 0.05, -0.08);
  SpanNoiseInput in = makeInput(noise);
  in.estimate.clear();
  const std::vector<SpanNoise> r = spanNoise(in, {10, 20});  // the truth's 200 Hz: 50 and 100 ms
  ASSERT_EQ(r.size(), 2u);
  for (const SpanNoise& s : r) {
    EXPECT_NEAR(s.span_s, 0.005 * s.span_frames, 1e-6);
    EXPECT_GT(s.centres, 11900u);
    // Both errors together: the truth's sqrt(6) sigma and the IMU's double integral of its white noise.
    const double imu = imuWhiteNoiseSecondDifference(noise.accel * std::sqrt(0.005), s.span_s);
    const double both = std::hypot(std::sqrt(6.0) * noise.truth_m, imu);
    EXPECT_NEAR(s.truth_vs_imu, both, 0.1 * both) << "span " << s.span_s;
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(s.truth_vs_imu_axes(j), both, 0.15 * both) << "axis " << j;
    EXPECT_TRUE(std::isnan(s.truth_vs_estimate) && std::isnan(s.estimate_vs_imu));
    EXPECT_TRUE(std::isnan(s.truth) && std::isnan(s.estimate) && std::isnan(s.imu));
    EXPECT_LT((s.accel_bias - noise.accel_bias).head<2>().norm(), 0.02) << s.accel_bias.transpose();
  }
  // Without noise they agree.
  SpanNoiseInput clean = makeInput({});
  clean.estimate.clear();
  for (const SpanNoise& s : spanNoise(clean, {1, 20})) EXPECT_LT(s.truth_vs_imu, 1e-6) << "span " << s.span_s;
}
