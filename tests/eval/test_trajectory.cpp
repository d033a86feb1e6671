// Trajectory metrics against analytic cases: a rigidly moved copy aligns to zero ATE, a known end-point
// offset gives its share of the distance, TUM files round-trip, NEES of a known error.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "ips/eval/trajectory.hpp"
#include "ips/shared_data_test.hpp"

using namespace ips::eval;
using ips::filter::FilterOutput;
using ips::filter::Matrix21d;
using ips::filter::NavState;

namespace {

Trajectory circle(int n, double radius) {
  Trajectory t;
  for (int i = 0; i < n; ++i) {
    const double a = 0.01 * i;
    TrajPoint p;
    p.t = 0.1 * i;
    p.p = Eigen::Vector3d(radius * std::cos(a), radius * std::sin(a), 0.1 * std::sin(3 * a));
    p.q = Eigen::Quaterniond(Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()));
    t.push_back(p);
  }
  return t;
}

}  // namespace

TEST(TrajEval, RigidlyMovedCopyAlignsToZeroError) {
  const Trajectory ref = circle(300, 5.0);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(1, -2, 0.5);
  Trajectory est = ref;
  for (TrajPoint& p : est) {
    p.p = T * p.p;
    p.q = Eigen::Quaterniond(T.linear()) * p.q;
  }
  const Eigen::Isometry3d A = alignSE3(est, ref);
  EXPECT_LT((A.linear() - T.linear().transpose()).norm(), 1e-9);
  const TrajectoryErrors e = evaluate(est, ref, 2.0);
  EXPECT_LT(e.ate_rmse_m, 1e-9);
  EXPECT_LT(e.rpe_percent, 1e-7);  // relative motion is frame independent
  double length = 0;
  for (size_t i = 1; i < ref.size(); ++i) length += (ref[i].p - ref[i - 1].p).norm();
  EXPECT_NEAR(e.distance_m, length, 1e-9);
  EXPECT_NEAR(e.distance_m, 5.0 * 2.99, 0.1);  // the arc, plus a little for the z wiggle
}

TEST(TrajEval, EndPointErrorIsItsShareOfTheDistance) {
  const Trajectory ref = circle(300, 5.0);
  Trajectory est = ref;
  // A drift growing linearly to 0.1 m in x at the end.
  for (size_t i = 0; i < est.size(); ++i) est[i].p.x() += 0.1 * i / (est.size() - 1);
  const TrajectoryErrors e = evaluate(est, ref, 2.0);
  EXPECT_NEAR(e.endpoint_error_m, 0.1, 1e-12);
  EXPECT_NEAR(e.endpoint_percent, 100.0 * 0.1 / e.distance_m, 1e-9);
  EXPECT_GT(e.ate_rmse_m, 0.0);
  EXPECT_LT(e.ate_rmse_m, 0.05);  // alignment absorbs part of a linear drift
}

TEST(TrajEval, TumRoundTripAndAssociation) {
  const Trajectory ref = circle(50, 2.0);
  const std::string path = (std::filesystem::temp_directory_path() / "ips_traj_eval_test.tum").string();
  writeTum(path, ref);
  const Trajectory back = readTum(path);
  ASSERT_EQ(back.size(), ref.size());
  for (size_t i = 0; i < ref.size(); ++i) {
    EXPECT_NEAR(back[i].t, ref[i].t, 1e-6);
    EXPECT_LT((back[i].p - ref[i].p).norm(), 1e-5);
    EXPECT_LT(back[i].q.angularDistance(ref[i].q), 1e-8);
  }
  // Estimates half way between reference samples are interpolated.
  Trajectory est;
  for (size_t i = 0; i + 1 < ref.size(); ++i) {
    TrajPoint p;
    p.t = 0.5 * (ref[i].t + ref[i + 1].t);
    p.p = 0.5 * (ref[i].p + ref[i + 1].p);
    est.push_back(p);
  }
  Trajectory e, r;
  associate(est, ref, 0.2, &e, &r);
  ASSERT_EQ(e.size(), est.size());
  EXPECT_LT((r[3].p - est[3].p).norm(), 1e-12);
  std::filesystem::remove(path);
  // Broken files are refused with the file and line in the message.
  {
    std::ofstream bad(path);
    bad << "0.0 1 2 3 0 0 0 1\n0.1 1 2\n";
  }
  try {
    readTum(path);
    FAIL() << "no exception";
  } catch (const std::runtime_error& ex) {
    EXPECT_NE(std::string(ex.what()).find(":2:"), std::string::npos) << ex.what();
  }
  std::filesystem::remove(path);
}

TEST(TrajEval, PoseNeesOfAKnownError) {
  FilterOutput out;
  out.covariance = Matrix21d::Identity() * 0.01;  // sigma 0.1 everywhere
  NavState truth = out.state;
  truth.position.x() += 0.2;                                                                 // 2 sigma
  truth.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitZ()));  // 1 sigma
  EXPECT_NEAR(poseNees(out, truth), 4.0 + 1.0, 1e-9);
  EXPECT_NEAR(fullNees(out, truth), 5.0, 1e-9);
}

TEST(TrajEval, PlotIsWritten) {
  const Trajectory ref = circle(100, 3.0);
  const std::string path = (std::filesystem::temp_directory_path() / "ips_traj_eval_test.png").string();
  plotTopDown(path, ref, {ref}, {"same"});
  EXPECT_GT(std::filesystem::file_size(path), 1000u);
  std::filesystem::remove(path);
}

// Halfway between two poses: the mean position and half the turn; outside, the end poses.
TEST(TrajEval, InterpolatedPoseIsLinearInPositionAndSlerpInAttitude) {
  Trajectory traj(2);
  traj[1].t = 2.0;
  traj[1].p = Eigen::Vector3d(2, 4, 0);
  traj[1].q = Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()));
  const TrajPoint mid = interpolate(traj, 1.0);
  EXPECT_NEAR((mid.p - Eigen::Vector3d(1, 2, 0)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(mid.q.angularDistance(Eigen::Quaterniond(Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitZ()))), 0.0, 1e-12);
  EXPECT_EQ(interpolate(traj, -1.0).p, traj[0].p);
  EXPECT_EQ(interpolate(traj, 3.0).p, traj[1].p);
}

// Steps along x, alternately 2 mm long and short with a 1 mm sigma: translation NEES 4, lag-1 correlation -1; a
// rotation 0.2 mrad off with a 0.1 mrad sigma: rotation NEES 4. A step outside the truth does not count.
TEST(TrajEval, DeltaConsistencyOfKnownErrors) {
  Trajectory truth;
  for (int i = 0; i <= 10; ++i) {
    TrajPoint p;
    p.t = 0.1 * i;
    p.p = Eigen::Vector3d(0.1 * i, 0, 0);
    truth.push_back(p);
  }
  std::vector<RelativePoseMeasurement> steps;
  for (int i = 1; i <= 11; ++i) {
    RelativePoseMeasurement m;
    m.t0 = 0.1 * (i - 1);
    m.t1 = 0.1 * i;
    m.T.translation() = Eigen::Vector3d(0.1 + (i % 2 ? 0.002 : -0.002), 0, 0);
    m.T.linear() = Eigen::AngleAxisd(2e-4, Eigen::Vector3d::UnitY()).toRotationMatrix();
    m.covariance.diagonal() << 1e-6, 1e-6, 1e-6, 1e-8, 1e-8, 1e-8;
    steps.push_back(m);
  }
  const DeltaConsistency c = deltaConsistency(steps, truth);
  EXPECT_EQ(c.deltas, 10);
  EXPECT_NEAR(c.nees_translation, 4.0, 1e-6);
  EXPECT_NEAR(c.nees_rotation, 4.0, 1e-6);
  EXPECT_NEAR(c.lag1_correlation, -0.9, 1e-9);  // 9 neighbouring pairs over 10 squared errors
}

namespace {

// A walk along a circle (radius 2 m, 1.5 m/s, 1.1 m/s^2 inwards) bobbing 5 cm at 2 Hz, sampled at `rate_hz`.
Trajectory circleWalk(double rate_hz, double duration_s) {
  Trajectory out;
  for (int i = 0; i * (1.0 / rate_hz) <= duration_s; ++i) {
    const double t = i / rate_hz, a = 0.75 * t;
    TrajPoint p;
    p.t = 100.0 + t;
    p.p = Eigen::Vector3d(2 * std::cos(a), 2 * std::sin(a), 0.05 * std::sin(2 * M_PI * 2 * t));
    p.q = Eigen::Quaterniond(Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()));
    out.push_back(p);
  }
  return out;
}

}  // namespace

TEST(TrajEval, SmoothTruthsHaveNoPositionSteps) {
  for (const double rate : {200.0, 100.0, 10.0}) {
    Trajectory truth = circleWalk(rate, 20);
    const Trajectory original = truth;
    EXPECT_TRUE(removePositionSteps(truth).empty()) << rate << " Hz";
    for (size_t i = 0; i < truth.size(); ++i) ASSERT_EQ(truth[i].p, original[i].p);
  }
}

TEST(TrajEval, APositionStepIsRemovedFromTheLaterSamplesOnly) {
  const Trajectory smooth = circleWalk(200, 5);
  Trajectory truth = smooth;
  const Eigen::Vector3d step(-0.002, 0.004, -0.0022);  // 5 mm between samples 300 and 301
  for (size_t i = 301; i < truth.size(); ++i) truth[i].p += step;
  const std::vector<PositionStep> steps = removePositionSteps(truth);
  ASSERT_EQ(steps.size(), 1u);
  EXPECT_DOUBLE_EQ(steps[0].t, smooth[301].t);
  EXPECT_LT((steps[0].step - step).norm(), 1e-5);  // the walk's own second difference: 0.2 mm
  for (size_t i = 0; i < truth.size(); ++i) ASSERT_LT((truth[i].p - smooth[i].p).norm(), 1e-5) << i;
  // Below 5 g over one sample (1.25 mm at 200 Hz) a displacement is motion, and stays.
  Trajectory small = smooth;
  for (size_t i = 301; i < small.size(); ++i) small[i].p += Eigen::Vector3d(0.001, 0, 0);
  EXPECT_TRUE(removePositionSteps(small).empty());
}

TEST(TrajEval, TheSharedMh01TruthHoldsTwoSteps) {
  IPS_REQUIRE_SHARED_DATA("euroc/MH_01_easy_first150");
  Trajectory truth = readTum(ips::dataPath("euroc/MH_01_easy_first150/groundtruth/MH_01_easy_tum_window.txt"));
  ASSERT_GT(truth.size(), 1800u);
  const std::vector<PositionStep> steps = removePositionSteps(truth);
  // 30 ms before the first image and 0.77 s after it (a 5 ms increment there is 2.7 mm long).
  ASSERT_EQ(steps.size(), 2u);
  EXPECT_NEAR(steps[0].t, 1403636584.73356, 1e-4);
  EXPECT_NEAR(steps[0].step.norm(), 0.0086, 0.0002);
  EXPECT_NEAR(steps[1].t, 1403636585.53356, 1e-4);
  EXPECT_NEAR(steps[1].step.norm(), 0.0050, 0.0002);
}
