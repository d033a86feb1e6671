// Models and filters of ips_filter against references: analytic Jacobians vs central differences, the
// chi-square quantiles vs tabulated values, EKF vs UKF on a mildly nonlinear case, the gate.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>
#include <random>

#include "ips/eval/filter_testbed.hpp"
#include "ips/filter/kalman.hpp"
#include "ips/filter/models.hpp"
#include "ips/filter/optional_states.hpp"
#include "ips/random_vector.hpp"

using namespace ips::filter;
using namespace ips::eval;

namespace {

NavState randomNav(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  auto v3 = [&](double s) -> Eigen::Vector3d { return s * ips::drawVector3([&] { return n(rng); }); };
  NavState x;
  x.utime = 1'000'000;
  x.position = v3(3);
  x.velocity = v3(1);
  x.acceleration = v3(2);
  x.accel_bias = v3(0.05);
  x.angular_rate = v3(1.0);
  x.gyro_bias = v3(0.01);
  x.orientation = expQuat(v3(1.0));
  return x;
}

FullState randomFull(std::mt19937& rng, int clones) {
  FullState x;
  x.nav = randomNav(rng);
  for (int i = 0; i < clones; ++i) {
    const NavState c = randomNav(rng);
    x.clones.push_back({1000 + i, c.position, c.orientation});
  }
  return x;
}

// Numeric derivative of a residual: H_num = -(r(x (+) e_i h) - r(x (-) e_i h)) / 2h.
Eigen::MatrixXd numericH(const Measurement& m, const FullState& x) {
  const int n = x.errorDim();
  Eigen::MatrixXd H(m.dim(), n);
  const double h = 1e-6;
  for (int i = 0; i < n; ++i) {
    Eigen::VectorXd d = Eigen::VectorXd::Zero(n);
    d(i) = h;
    const MeasVector rp = m.residual(boxplus(x, d));
    const MeasVector rm = m.residual(boxplus(x, -d));
    H.col(i) = -(rp - rm) / (2 * h);
  }
  return H;
}

}  // namespace

TEST(FilterModels, BoxplusBoxminusRoundTrip) {
  std::mt19937 rng(1);
  const FullState x = randomFull(rng, 2);
  Eigen::VectorXd d = Eigen::VectorXd::Random(x.errorDim()) * 0.3;
  EXPECT_LT((boxminus(boxplus(x, d), x) - d).norm(), 1e-12);
  EXPECT_THROW(boxplus(x, Eigen::VectorXd::Zero(5)), std::invalid_argument);
}

// The start frame's map and its Jacobian (FilterParams::output_frame start) against central differences through the
// error state, with the anchor among other clones; and the map is the identity while the anchor is where it started.
TEST(FilterModels, StartFrameJacobianMatchesNumeric) {
  std::mt19937 rng(31);
  const FullState x = randomFull(rng, 3);
  const int anchor = 1;
  const PoseClone start = randomFull(rng, 1).clones.front();
  const Eigen::MatrixXd J = startFrameJacobian(x, anchor, start);
  ASSERT_EQ(J.rows(), kCoreErrorDim);
  ASSERT_EQ(J.cols(), x.errorDim());
  const NavState y = toStartFrame(x.nav, x.clones[anchor], start);
  const double h = 1e-6;
  Eigen::MatrixXd Jn(kCoreErrorDim, x.errorDim());
  for (int i = 0; i < x.errorDim(); ++i) {
    Eigen::VectorXd d = Eigen::VectorXd::Zero(x.errorDim());
    d(i) = h;
    const FullState xp = boxplus(x, d), xm = boxplus(x, (-d).eval());
    Jn.col(i) = (boxminus(toStartFrame(xp.nav, xp.clones[anchor], start), y) -
                 boxminus(toStartFrame(xm.nav, xm.clones[anchor], start), y)) /
                (2 * h);
  }
  EXPECT_LT((J - Jn).cwiseAbs().maxCoeff(), 1e-6) << "analytic\n" << J << "\nnumeric\n" << Jn;

  const PoseClone unmoved = x.clones[anchor];
  const NavState same = toStartFrame(x.nav, unmoved, unmoved);
  EXPECT_LT(boxminus(same, x.nav).norm(), 1e-12);
}

TEST(FilterModels, So3RightJacobian) {
  const Eigen::Vector3d phi(0.4, -0.7, 0.2), d(1e-6, -2e-6, 1.5e-6);
  const Eigen::Matrix3d lhs = expSO3(phi + d);
  const Eigen::Matrix3d rhs = expSO3(phi) * expSO3(rightJacobianSO3(phi) * d);
  EXPECT_LT((lhs - rhs).norm(), 1e-11);
  EXPECT_LT((logSO3(expSO3(phi)) - phi).norm(), 1e-12);
}

TEST(FilterModels, ProcessJacobianMatchesNumeric) {
  std::mt19937 rng(2);
  for (double dt : {0.005, 0.1, 0.5}) {
    const NavState x = randomNav(rng);
    const Matrix21d F = processJacobian(x, dt);
    const NavState fx = propagateNav(x, dt);
    Matrix21d Fn;
    const double h = 1e-6;
    for (int i = 0; i < 21; ++i) {
      Vector21d d = Vector21d::Zero();
      d(i) = h;
      Fn.col(i) =
          (boxminus(propagateNav(boxplus(x, d), dt), fx) - boxminus(propagateNav(boxplus(x, (-d).eval()), dt), fx)) /
          (2 * h);
    }
    EXPECT_LT((F - Fn).cwiseAbs().maxCoeff(), 1e-7) << "dt=" << dt << "\n" << F - Fn;
  }
}

TEST(FilterModels, ProcessNoiseIsSymmetricPositive) {
  std::mt19937 rng(3);
  const Matrix21d Q = processNoise(randomNav(rng), 0.01, ProcessNoise{});
  EXPECT_LT((Q - Q.transpose()).norm(), 1e-15);
  Eigen::SelfAdjointEigenSolver<Matrix21d> es(Q);
  EXPECT_GT(es.eigenvalues().minCoeff(), 0.0);
}

TEST(FilterModels, ImuJacobianMatchesNumeric) {
  std::mt19937 rng(4);
  const FullState x = randomFull(rng, 2);
  const ImuMeasurement m(Eigen::Vector3d(0.1, 0.2, 0.3), Eigen::Vector3d(0.5, -0.2, 9.7), 9.81, 1e-3, 1e-2);
  EXPECT_LT((m.jacobian(x) - numericH(m, x)).cwiseAbs().maxCoeff(), 1e-6);
}

TEST(FilterModels, TiltJacobianMatchesNumeric) {
  std::mt19937 rng(5);
  FullState x = randomFull(rng, 1);
  x.nav.orientation = expQuat(Eigen::Vector3d(0.2, -0.3, 1.0));
  const Eigen::Matrix3d R_bt = expSO3(Eigen::Vector3d(0.01, 0.02, 0.5));
  x.nav.acceleration = Eigen::Vector3d(1.5, -2.0, 3.0);
  for (bool specific_force : {false, true}) {
    const TiltMeasurement m(0.1, -0.2, R_bt, 1e-3, 9.81, specific_force);
    const Eigen::MatrixXd H = m.jacobian(x);
    EXPECT_LT((H - numericH(m, x)).cwiseAbs().maxCoeff(), 1e-6);
    // Only the specific-force model depends on the acceleration.
    EXPECT_EQ((H.block<2, 3>(0, kErrA).isZero()), !specific_force);
  }
}

TEST(FilterModels, TiltAnglesFollowTheirConvention) {
  // Pitching the nose up (negative rotation about body y) raises the x axis: angle_x > 0.
  const Eigen::Quaterniond q(Eigen::AngleAxisd(-0.1, Eigen::Vector3d::UnitY()));
  const Eigen::Vector2d z = TiltMeasurement::predict(q, Eigen::Matrix3d::Identity());
  EXPECT_NEAR(z.x(), 0.1, 1e-12);
  EXPECT_NEAR(z.y(), 0.0, 1e-12);
}

TEST(FilterModels, DeltaJacobianMatchesNumeric) {
  std::mt19937 rng(6);
  const FullState x = randomFull(rng, 3);
  Eigen::Isometry3d T_imu_cam = Eigen::Isometry3d::Identity();
  T_imu_cam.linear() = expSO3(Eigen::Vector3d(1.2, -0.4, 0.3));
  T_imu_cam.translation() = Eigen::Vector3d(0.1, -0.05, 0.2);
  // Measurement equal to the prediction: the residual is zero and its derivative is exactly -H.
  const Eigen::Isometry3d z = DeltaMeasurement::predict(x.clones[0], x.clones[2], T_imu_cam);
  const DeltaMeasurement m(0, 2, z, Matrix6d::Identity() * 1e-6, T_imu_cam);
  EXPECT_LT(m.residual(x).norm(), 1e-12);
  EXPECT_LT((m.jacobian(x) - numericH(m, x)).cwiseAbs().maxCoeff(), 1e-6);
}

TEST(FilterModels, DeltaJacobianWithTheLeverArmEstimatedMatchesNumeric) {
  std::mt19937 rng(9);
  FullState x = randomFull(rng, 3);
  x.lever_arm = Eigen::Vector3d(-0.05, 0.02, -0.06);
  EXPECT_EQ(x.errorDim(), kCoreErrorDim + optionalStateDim(kLeverArm) + 3 * kCloneErrorDim);
  Eigen::Isometry3d T_imu_cam = Eigen::Isometry3d::Identity();
  T_imu_cam.linear() = expSO3(Eigen::Vector3d(1.2, -0.4, 0.3));
  T_imu_cam.translation() = Eigen::Vector3d(0.1, -0.05, 0.2);  // the calibration's: the state's replaces it
  Eigen::Isometry3d T_state = T_imu_cam;
  T_state.translation() = *x.lever_arm;
  const Eigen::Isometry3d z = DeltaMeasurement::predict(x.clones[0], x.clones[2], T_state);
  const DeltaMeasurement m(0, 2, z, Matrix6d::Identity() * 1e-6, T_imu_cam);
  EXPECT_LT(m.residual(x).norm(), 1e-12);
  const Eigen::MatrixXd H = m.jacobian(x);
  EXPECT_LT((H - numericH(m, x)).cwiseAbs().maxCoeff(), 1e-6);
  // The lever arm moves the translation only, and does so (the clones' attitudes differ).
  EXPECT_GT(H.middleCols(kCoreErrorDim, 3).topRows(3).norm(), 0.1);
  EXPECT_EQ(H.middleCols(kCoreErrorDim, 3).bottomRows(3).norm(), 0.0);
  // Equal attitudes of the two clones: the lever arm cancels (no turn, nothing to see).
  x.clones[2].orientation = x.clones[0].orientation;
  EXPECT_LT(m.jacobian(x).middleCols(kCoreErrorDim, 3).topRows(3).norm(), 1e-12);
}

// The tracker's scale error as a state, after the lever arm: the tracker's delta (from_tracker) measures (1 + s) times
// the predicted translation, a delta from the dense maps (not from_tracker) does not see s.
TEST(FilterModels, DeltaJacobianWithTheScaleEstimatedMatchesNumeric) {
  std::mt19937 rng(11);
  FullState x = randomFull(rng, 3);
  x.lever_arm = Eigen::Vector3d(-0.05, 0.02, -0.06);
  x.delta_scale = 0.004;
  EXPECT_EQ(x.errorDim(),
            kCoreErrorDim + optionalStateDim(kLeverArm) + optionalStateDim(kDeltaScale) + 3 * kCloneErrorDim);
  EXPECT_EQ(x.offset(kDeltaScale), kCoreErrorDim + optionalStateDim(kLeverArm));
  Eigen::Isometry3d T_imu_cam = Eigen::Isometry3d::Identity();
  T_imu_cam.linear() = expSO3(Eigen::Vector3d(1.2, -0.4, 0.3));
  T_imu_cam.translation() = *x.lever_arm;
  const Eigen::Isometry3d predicted = DeltaMeasurement::predict(x.clones[0], x.clones[2], T_imu_cam);
  Eigen::Isometry3d z = predicted;
  z.translation() *= 1.0 + *x.delta_scale;
  const DeltaMeasurement tracker_delta(0, 2, z, Matrix6d::Identity() * 1e-6, T_imu_cam, true);
  EXPECT_LT(tracker_delta.residual(x).norm(), 1e-12);
  const Eigen::MatrixXd H = tracker_delta.jacobian(x);
  EXPECT_LT((H - numericH(tracker_delta, x)).cwiseAbs().maxCoeff(), 1e-6);
  // d (1 + s) t / d s = t, in the translation rows only.
  EXPECT_LT((H.col(x.offset(kDeltaScale)).head<3>() - predicted.translation()).norm(), 1e-12);
  EXPECT_EQ(H.col(x.offset(kDeltaScale)).tail<3>().norm(), 0.0);
  const DeltaMeasurement unscaled(0, 2, predicted, Matrix6d::Identity() * 1e-6, T_imu_cam);
  EXPECT_LT(unscaled.residual(x).norm(), 1e-12);
  EXPECT_EQ(unscaled.jacobian(x).col(x.offset(kDeltaScale)).norm(), 0.0);
  EXPECT_LT((unscaled.jacobian(x) - numericH(unscaled, x)).cwiseAbs().maxCoeff(), 1e-6);
}

// The turn of the tracker's steps b and its rotation drift r as states: the tracker's delta measures
// (1 + s)(I + [b]x) t_pred and Exp(|t_meas| r) R_pred; a delta from the dense maps (not from_tracker) sees neither.
// With every state before the clones present, so that the offsets are checked in their order, and with a drift far
// larger than the tracker's so that its second-order terms count.
TEST(FilterModels, DeltaJacobianWithTheStepDirectionAndRotationDriftMatchesNumeric) {
  std::mt19937 rng(15);
  FullState x = randomFull(rng, 3);
  x.lever_arm = Eigen::Vector3d(-0.05, 0.02, -0.06);
  x.delta_scale = 0.004;
  x.delta_direction = Eigen::Vector3d(0.002, -0.003, 0.001);
  x.delta_rotation_drift = Eigen::Vector3d(0.03, -0.05, 0.02);
  x.tilt_offset = Eigen::Vector2d(0.004, -0.007);
  x.camera_alignment = expQuat(Eigen::Vector3d(0.002, -0.001, 0.003));
  EXPECT_EQ(x.offset(kDeltaDirection), kCoreErrorDim + optionalStateDim(kLeverArm) + optionalStateDim(kDeltaScale));
  EXPECT_EQ(x.offset(kDeltaRotationDrift), x.offset(kDeltaDirection) + optionalStateDim(kDeltaDirection));
  EXPECT_EQ(x.offset(kTiltOffset), x.offset(kDeltaRotationDrift) + optionalStateDim(kDeltaRotationDrift));
  EXPECT_EQ(x.cloneOffset(0), x.offset(kCameraAlignment) + optionalStateDim(kCameraAlignment));
  Eigen::Isometry3d T_imu_cam = Eigen::Isometry3d::Identity();
  T_imu_cam.linear() = expSO3(Eigen::Vector3d(1.2, -0.4, 0.3));
  Eigen::Isometry3d T_state = T_imu_cam;
  T_state.translation() = *x.lever_arm;
  T_state.linear() = T_imu_cam.linear() * x.camera_alignment->toRotationMatrix();
  const Eigen::Isometry3d predicted = DeltaMeasurement::predict(x.clones[0], x.clones[2], T_state);
  Eigen::Isometry3d z = predicted;
  z.translation() =
      (1.0 + *x.delta_scale) * (predicted.translation() + x.delta_direction->cross(predicted.translation()));
  const double step = z.translation().norm();
  ASSERT_GT(step, 0.1);
  z.linear() = expSO3(step * *x.delta_rotation_drift) * predicted.linear();
  const DeltaMeasurement tracker(0, 2, z, Matrix6d::Identity() * 1e-6, T_imu_cam, true);
  EXPECT_LT(tracker.residual(x).norm(), 1e-12);
  const Eigen::MatrixXd H = tracker.jacobian(x);
  EXPECT_LT((H - numericH(tracker, x)).cwiseAbs().maxCoeff(), 1e-6);
  // d (1 + s) (t + b x t) / d b = -(1 + s) [t]x, in the translation rows only.
  const Eigen::Matrix3d expected = -(1.0 + *x.delta_scale) * skew(predicted.translation());
  EXPECT_LT((H.block<3, 3>(0, x.offset(kDeltaDirection)) - expected).norm(), 1e-12);
  EXPECT_EQ((H.block<3, 3>(3, x.offset(kDeltaDirection)).norm()), 0.0);
  // The drift in the rotation rows only, about |t| J_l per axis.
  EXPECT_EQ((H.block<3, 3>(0, x.offset(kDeltaRotationDrift)).norm()), 0.0);
  EXPECT_GT((H.block<3, 3>(3, x.offset(kDeltaRotationDrift)).norm()), step);
  const DeltaMeasurement maps(0, 2, predicted, Matrix6d::Identity() * 1e-6, T_imu_cam);
  EXPECT_LT(maps.residual(x).norm(), 1e-12);
  EXPECT_EQ(maps.jacobian(x).middleCols(x.offset(kDeltaDirection), 3).norm(), 0.0);
  EXPECT_EQ(maps.jacobian(x).middleCols(x.offset(kDeltaRotationDrift), 3).norm(), 0.0);
  EXPECT_LT((maps.jacobian(x) - numericH(maps, x)).cwiseAbs().maxCoeff(), 1e-6);
  // Without the drift the tilt offsets follow the step direction.
  FullState no_drift = x;
  no_drift.delta_rotation_drift.reset();
  EXPECT_EQ(no_drift.offset(kTiltOffset), no_drift.offset(kDeltaDirection) + optionalStateDim(kDeltaDirection));
}

TEST(FilterModels, BoxplusBoxminusRoundTripWithTheStepDirectionAndRotationDrift) {
  std::mt19937 rng(16);
  FullState x = randomFull(rng, 2);
  x.delta_scale = -0.002;
  x.delta_direction = Eigen::Vector3d(0.001, 0.002, -0.003);
  x.delta_rotation_drift = Eigen::Vector3d(1e-4, -2e-4, 5e-5);
  const Eigen::VectorXd d = Eigen::VectorXd::Random(x.errorDim()) * 0.3;
  const FullState y = boxplus(x, d);
  EXPECT_LT((*y.delta_direction - *x.delta_direction - d.segment<3>(x.offset(kDeltaDirection))).norm(), 1e-15);
  EXPECT_LT((*y.delta_rotation_drift - *x.delta_rotation_drift - d.segment<3>(x.offset(kDeltaRotationDrift))).norm(),
            1e-15);
  EXPECT_LT((boxminus(y, x) - d).norm(), 1e-12);
  for (int which = 0; which < 2; ++which) {
    FullState without = x;
    if (which == 0)
      without.delta_direction.reset();
    else
      without.delta_rotation_drift.reset();
    EXPECT_THROW(boxminus(x, without), std::invalid_argument);
  }
}

// The tilt sensor's offsets as states, after the scale: they add to the predicted angles; a measurement built without
// offset_state ignores them and stays core-only (the UKF's cheaper path).
TEST(FilterModels, TiltJacobianWithTheOffsetEstimatedMatchesNumeric) {
  std::mt19937 rng(13);
  FullState x = randomFull(rng, 2);
  x.nav.orientation = expQuat(Eigen::Vector3d(0.2, -0.3, 1.0));
  x.nav.acceleration = Eigen::Vector3d(0.5, -0.2, 0.1);
  x.delta_scale = 0.001;
  x.tilt_offset = Eigen::Vector2d(0.004, -0.007);
  EXPECT_EQ(x.offset(kTiltOffset), kCoreErrorDim + optionalStateDim(kDeltaScale));
  EXPECT_EQ(x.cloneOffset(0), kCoreErrorDim + optionalStateDim(kDeltaScale) + optionalStateDim(kTiltOffset));
  const Eigen::Matrix3d R_bt = expSO3(Eigen::Vector3d(0.01, 0.02, 0.5));
  const TiltMeasurement with(0.1, -0.2, R_bt, 1e-3, 9.81, true, true);
  EXPECT_FALSE(with.coreOnly());
  const Eigen::MatrixXd H = with.jacobian(x);
  EXPECT_LT((H - numericH(with, x)).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_TRUE((H.block<2, 2>(0, x.offset(kTiltOffset)).isIdentity(0)));
  const TiltMeasurement without(0.1, -0.2, R_bt, 1e-3, 9.81, true, false);
  EXPECT_TRUE(without.coreOnly());
  EXPECT_LT((with.residual(x) - without.residual(x) + *x.tilt_offset).norm(), 1e-15);
  EXPECT_EQ((without.jacobian(x).block<2, 2>(0, x.offset(kTiltOffset)).norm()), 0.0);
}

// The camera's alignment as states, after the others: it turns the predicted translation and conjugates the predicted
// rotation, for the tracker's deltas (from_tracker) and the far points' rotations alike.
TEST(FilterModels, DeltaAndRotationJacobiansWithTheCameraAlignmentMatchNumeric) {
  std::mt19937 rng(14);
  FullState x = randomFull(rng, 3);
  x.lever_arm = Eigen::Vector3d(-0.05, 0.02, -0.06);
  x.delta_scale = 0.003;
  x.camera_alignment = expQuat(Eigen::Vector3d(0.002, -0.001, 0.003));
  EXPECT_EQ(x.offset(kCameraAlignment), kCoreErrorDim + optionalStateDim(kLeverArm) + optionalStateDim(kDeltaScale));
  Eigen::Isometry3d T_imu_cam = Eigen::Isometry3d::Identity();
  T_imu_cam.linear() = expSO3(Eigen::Vector3d(1.2, -0.4, 0.3));
  Eigen::Isometry3d T_state = T_imu_cam;
  T_state.translation() = *x.lever_arm;
  T_state.linear() = T_imu_cam.linear() * x.camera_alignment->toRotationMatrix();
  const Eigen::Isometry3d predicted = DeltaMeasurement::predict(x.clones[0], x.clones[2], T_state);
  Eigen::Isometry3d z = predicted;
  z.translation() *= 1.0 + *x.delta_scale;
  const DeltaMeasurement delta(0, 2, z, Matrix6d::Identity() * 1e-6, T_imu_cam, true);
  EXPECT_LT(delta.residual(x).norm(), 1e-12);
  const Eigen::MatrixXd H = delta.jacobian(x);
  EXPECT_LT((H - numericH(delta, x)).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_GT(H.middleCols(x.offset(kCameraAlignment), 3).topRows(3).norm(), 0.1);  // it turns the step
  const RotationMeasurement rotation(0, 2, predicted.linear(), Eigen::Matrix3d::Identity() * 1e-8, T_imu_cam);
  EXPECT_LT(rotation.residual(x).norm(), 1e-12);
  EXPECT_LT((rotation.jacobian(x) - numericH(rotation, x)).cwiseAbs().maxCoeff(), 1e-6);
}

TEST(FilterModels, BoxplusBoxminusRoundTripWithTheScale) {
  std::mt19937 rng(12);
  FullState x = randomFull(rng, 2);
  x.delta_scale = -0.002;
  Eigen::VectorXd d = Eigen::VectorXd::Random(x.errorDim()) * 0.3;
  const FullState y = boxplus(x, d);
  EXPECT_NEAR(*y.delta_scale - *x.delta_scale, d(kCoreErrorDim), 1e-15);
  EXPECT_LT((boxminus(y, x) - d).norm(), 1e-12);
  FullState without = x;
  without.delta_scale.reset();
  EXPECT_THROW(boxminus(x, without), std::invalid_argument);
  x.tilt_offset = Eigen::Vector2d(0.01, -0.02);
  d = Eigen::VectorXd::Random(x.errorDim()) * 0.3;
  const FullState z = boxplus(x, d);
  EXPECT_LT((*z.tilt_offset - *x.tilt_offset - d.segment<2>(x.offset(kTiltOffset))).norm(), 1e-15);
  EXPECT_LT((boxminus(z, x) - d).norm(), 1e-12);
  x.camera_alignment = expQuat(Eigen::Vector3d(0.01, 0.02, -0.03));
  d = Eigen::VectorXd::Random(x.errorDim()) * 0.3;
  const FullState w = boxplus(x, d);
  EXPECT_LT((logQuat(x.camera_alignment->conjugate() * *w.camera_alignment) - d.segment<3>(x.offset(kCameraAlignment)))
                .norm(),
            1e-12);
  EXPECT_LT((boxminus(w, x) - d).norm(), 1e-12);
}

TEST(FilterModels, BoxplusBoxminusRoundTripWithTheLeverArm) {
  std::mt19937 rng(10);
  FullState x = randomFull(rng, 2);
  x.lever_arm = Eigen::Vector3d(0.1, 0.2, 0.3);
  Eigen::VectorXd d = Eigen::VectorXd::Random(x.errorDim()) * 0.3;
  const FullState y = boxplus(x, d);
  EXPECT_LT((*y.lever_arm - *x.lever_arm - d.segment<3>(kCoreErrorDim)).norm(), 1e-15);
  EXPECT_LT((boxminus(y, x) - d).norm(), 1e-12);
  FullState without = x;
  without.lever_arm.reset();
  EXPECT_THROW(boxminus(x, without), std::invalid_argument);
}

TEST(FilterModels, ChiSquareQuantilesMatchTables) {
  EXPECT_NEAR(chiSquareQuantile(0.95, 1), 3.841, 1e-3);
  EXPECT_NEAR(chiSquareQuantile(0.95, 2), 5.991, 1e-3);
  EXPECT_NEAR(chiSquareQuantile(0.99, 6), 16.812, 1e-3);
  EXPECT_NEAR(chiSquareQuantile(0.025, 60), 40.482, 1e-3);
  EXPECT_NEAR(chiSquareQuantile(0.975, 60), 83.298, 1e-3);
  EXPECT_NEAR(chiSquareCdf(12.592, 6), 0.95, 1e-4);
}

namespace {

// Runs the same sequence through a filter: time updates, IMU and tilt samples, clones and a delta.
void runSequence(KalmanFilter& kf, const FullState& x0, const Eigen::MatrixXd& P0, double* last_m2 = nullptr) {
  kf.reset(x0, P0);
  const double g = 9.81;
  const Eigen::Matrix3d R_bt = expSO3(Eigen::Vector3d(0.01, -0.02, 0.3));
  Eigen::Isometry3d T_ic = Eigen::Isometry3d::Identity();
  T_ic.linear() = expSO3(Eigen::Vector3d(1.2, -1.2, 1.2));
  T_ic.translation() = Eigen::Vector3d(0.05, 0.1, 0.0);
  kf.addClone();
  for (int k = 0; k < 40; ++k) {
    kf.predict(0.005);
    const double t = 0.005 * (k + 1);
    const ImuMeasurement imu(Eigen::Vector3d(0.3 + 0.1 * t, -0.2, 0.5), Eigen::Vector3d(0.8, 0.3, 9.9), g, 2e-3, 5e-2);
    kf.update(imu, std::numeric_limits<double>::infinity());
    if (k % 10 == 5)
      kf.update(TiltMeasurement(0.06, -0.03, R_bt, 3e-3, g, false), std::numeric_limits<double>::infinity());
  }
  kf.addClone();
  // A delta a little off the current estimate.
  Eigen::Isometry3d z = DeltaMeasurement::predict(kf.state().clones[0], kf.state().clones[1], T_ic);
  z.translation() += Eigen::Vector3d(0.004, -0.003, 0.002);
  z.linear() = expSO3(Eigen::Vector3d(0.002, 0.001, -0.002)) * z.linear();
  Matrix6d R = Matrix6d::Zero();
  R.diagonal() << 1e-5, 1e-5, 1e-5, 1e-6, 1e-6, 1e-6;
  const UpdateResult r = kf.update(DeltaMeasurement(0, 1, z, R, T_ic), std::numeric_limits<double>::infinity());
  if (last_m2) *last_m2 = r.mahalanobis2;
  kf.predict(0.02);
}

}  // namespace

TEST(FilterKalman, EkfAndUkfAgreeOnMildlyNonlinearCase) {
  FilterParams params;
  FullState x0;
  x0.nav.orientation = expQuat(Eigen::Vector3d(0.1, -0.05, 0.8));
  x0.nav.angular_rate = Eigen::Vector3d(0.3, -0.2, 0.5);
  x0.nav.velocity = Eigen::Vector3d(0.5, 0.1, 0.0);
  Vector21d sd;
  sd << Eigen::Vector3d::Constant(0.01), Eigen::Vector3d::Constant(0.05), Eigen::Vector3d::Constant(0.2),
      Eigen::Vector3d::Constant(0.02), Eigen::Vector3d::Constant(0.02), Eigen::Vector3d::Constant(0.005),
      Eigen::Vector3d::Constant(0.02);
  const Eigen::MatrixXd P0 = Matrix21d(sd.cwiseAbs2().asDiagonal());
  ExtendedKalmanFilter ekf(params);
  UnscentedKalmanFilter ukf(params);
  double m2_ekf = 0, m2_ukf = 0;
  runSequence(ekf, x0, P0, &m2_ekf);
  runSequence(ukf, x0, P0, &m2_ukf);
  const Eigen::MatrixXd& Pe = ekf.covariance();
  const Eigen::MatrixXd& Pu = ukf.covariance();
  ASSERT_EQ(Pe.rows(), 33);
  const Eigen::VectorXd diff = boxminus(ukf.state(), ekf.state());
  const Eigen::VectorXd sigma = Pe.diagonal().cwiseSqrt();
  // Means agree to a small part of a standard deviation, covariances to a few percent.
  EXPECT_LT((diff.array() / sigma.array()).abs().maxCoeff(), 0.05);
  EXPECT_LT((Pu.diagonal().cwiseSqrt().array() / sigma.array() - 1.0).abs().maxCoeff(), 0.03);
  EXPECT_NEAR(m2_ekf, m2_ukf, 0.02 * m2_ekf);
  // And the update did something: the delta reduced the clone uncertainty.
  EXPECT_LT(Pe(27, 27), Pe(21, 21) + 1e-3);
}

TEST(FilterKalman, GateRejectsAnOutlierAndKeepsTheState) {
  FilterParams params;
  for (FilterType type : {FilterType::Ekf, FilterType::Ukf}) {
    params.type = type;
    auto kf = makeKalmanFilter(params);
    FullState x0;
    Matrix21d P = Matrix21d::Identity() * 1e-4;
    kf->reset(x0, P);
    const double gate = chiSquareQuantile(0.9995, 2);
    // Level head; a tilt reading of 5 degrees is far outside sigma = 0.1 degree.
    const UpdateResult bad = kf->update(TiltMeasurement(0.087, 0.0, Eigen::Matrix3d::Identity(), 1.75e-3), gate);
    EXPECT_FALSE(bad.applied);
    EXPECT_GT(bad.mahalanobis2, gate);
    EXPECT_LT(boxminus(kf->state(), FullState{x0}).norm(), 1e-15);
    const UpdateResult good = kf->update(TiltMeasurement(0.002, -0.001, Eigen::Matrix3d::Identity(), 1.75e-3), gate);
    EXPECT_TRUE(good.applied);
    EXPECT_LT(good.mahalanobis2, gate);
  }
}

TEST(FilterKalman, ClonesCarryCorrelationsThroughPrediction) {
  FilterParams params;
  for (FilterType type : {FilterType::Ekf, FilterType::Ukf}) {
    params.type = type;
    auto kf = makeKalmanFilter(params);
    FullState x0;
    x0.nav.velocity = Eigen::Vector3d(1, 0, 0);
    kf->reset(x0, Matrix21d::Identity() * 1e-2);
    kf->addClone();
    kf->predict(0.5);
    // Position error after 0.5 s = dp + 0.5 dv + 0.125 da: its covariance with the cloned position is var(dp).
    EXPECT_NEAR(kf->covariance()(0, 21), 1e-2, 1e-9);
    EXPECT_NEAR(kf->covariance()(3, 21), 0.0, 1e-12);
    kf->removeClone(0);
    EXPECT_EQ(kf->covariance().rows(), 21);
  }
}

TEST(FilterKalman, LeverArmStatesKeepTheirPlaceAndCorrelationsAsClonesComeAndGo) {
  FilterParams params;
  for (FilterType type : {FilterType::Ekf, FilterType::Ukf}) {
    params.type = type;
    auto kf = makeKalmanFilter(params);
    FullState x0;
    x0.nav.velocity = Eigen::Vector3d(1, 0, 0);
    x0.lever_arm = Eigen::Vector3d(0.1, 0.0, -0.05);
    Eigen::MatrixXd P = Eigen::MatrixXd::Identity(24, 24) * 1e-2;
    P(0, 21) = P(21, 0) = 5e-3;  // position error correlated with the lever arm's x
    kf->reset(x0, P);
    kf->addClone();
    kf->addClone();
    ASSERT_EQ(kf->covariance().rows(), 36);
    // The clones come after the lever arm: their position error is the core's, correlated with the lever arm alike.
    EXPECT_NEAR(kf->covariance()(24, 21), 5e-3, 1e-12);
    EXPECT_NEAR(kf->covariance()(30, 21), 5e-3, 1e-12);
    kf->predict(0.5);
    // The process leaves the lever arm alone: its variance and its correlation with the clones are unchanged.
    EXPECT_NEAR(kf->covariance()(21, 21), 1e-2, 1e-9);
    EXPECT_NEAR(kf->covariance()(24, 21), 5e-3, 1e-9);
    kf->removeClone(0);
    ASSERT_EQ(kf->covariance().rows(), 30);
    EXPECT_NEAR(kf->covariance()(21, 21), 1e-2, 1e-9);
    EXPECT_NEAR(kf->covariance()(24, 21), 5e-3, 1e-9);
    EXPECT_TRUE(kf->state().lever_arm.has_value());
  }
}

// The tracker's scale and step direction walk by their psds (ProcessNoise::delta_scale_psd, delta_direction_psd):
// psd * dt onto each of their variances, in both filters, and nothing elsewhere: their correlations with the core and
// the clones are carried as the lever arm's are. Layout [21 core | 1 scale (21) | 3 direction (22-24) | clone (25-30)].
TEST(FilterKalman, ScaleStepDirectionAndRotationDriftStatesWalkByTheirPsdsAndKeepTheirCorrelations) {
  FilterParams params;
  params.process.delta_scale_psd = 2e-7;
  params.process.delta_direction_psd = 3e-8;
  params.process.delta_rotation_drift_psd = 4e-10;
  for (FilterType type : {FilterType::Ekf, FilterType::Ukf}) {
    params.type = type;
    auto kf = makeKalmanFilter(params);
    FullState x0;
    x0.nav.velocity = Eigen::Vector3d(1, 0, 0);
    x0.delta_scale = 0.001;
    x0.delta_direction = Eigen::Vector3d(0.001, -0.002, 0.0);
    x0.delta_rotation_drift = Eigen::Vector3d(1e-4, 0.0, -1e-4);
    // layout [21 core | 1 scale | 3 direction | 3 rotation drift]
    Eigen::MatrixXd P = Eigen::MatrixXd::Identity(28, 28) * 1e-2;
    P(21, 21) = 1e-5;
    P.block<3, 3>(22, 22) = Eigen::Matrix3d::Identity() * 1e-6;
    P.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * 1e-8;
    P(0, 21) = P(21, 0) = 2e-4;  // position error along the path correlated with the scale
    P(1, 23) = P(23, 1) = 5e-5;  // position error across the path correlated with the turn
    P(2, 26) = P(26, 2) = 3e-6;  // the height correlated with the rotation drift
    kf->reset(x0, P);
    kf->addClone();
    ASSERT_EQ(kf->covariance().rows(), 34);
    // The clone's position takes the core's correlations.
    EXPECT_NEAR(kf->covariance()(28, 21), 2e-4, 1e-15);
    EXPECT_NEAR(kf->covariance()(29, 23), 5e-5, 1e-15);
    EXPECT_NEAR(kf->covariance()(30, 26), 3e-6, 1e-15);
    kf->predict(0.5);
    EXPECT_NEAR(kf->covariance()(21, 21), 1e-5 + 2e-7 * 0.5, 1e-15) << toString(type);
    for (int i = 22; i < 25; ++i) EXPECT_NEAR(kf->covariance()(i, i), 1e-6 + 3e-8 * 0.5, 1e-15) << toString(type);
    for (int i = 25; i < 28; ++i) EXPECT_NEAR(kf->covariance()(i, i), 1e-8 + 4e-10 * 0.5, 1e-15) << toString(type);
    EXPECT_NEAR(kf->covariance()(28, 21), 2e-4, 1e-12) << toString(type);
    EXPECT_NEAR(kf->covariance()(29, 23), 5e-5, 1e-12) << toString(type);
    EXPECT_NEAR(kf->covariance()(30, 26), 3e-6, 1e-12) << toString(type);
    EXPECT_NEAR(*kf->state().delta_scale, 0.001, 1e-15) << toString(type);
    EXPECT_LT((*kf->state().delta_direction - Eigen::Vector3d(0.001, -0.002, 0.0)).norm(), 1e-15) << toString(type);
    EXPECT_LT((*kf->state().delta_rotation_drift - Eigen::Vector3d(1e-4, 0.0, -1e-4)).norm(), 1e-15) << toString(type);
  }
}

TEST(FilterModels, RotationJacobianMatchesNumericAndEqualsTheDeltasRotationRows) {
  std::mt19937 rng(7);
  const FullState x = randomFull(rng, 3);
  Eigen::Isometry3d T_imu_cam = Eigen::Isometry3d::Identity();
  T_imu_cam.linear() = expSO3(Eigen::Vector3d(1.2, -0.4, 0.3));
  T_imu_cam.translation() = Eigen::Vector3d(0.1, -0.05, 0.2);
  const Eigen::Isometry3d z = DeltaMeasurement::predict(x.clones[0], x.clones[2], T_imu_cam);
  const RotationMeasurement m(0, 2, z.linear(), Eigen::Matrix3d::Identity() * 1e-8, T_imu_cam);
  EXPECT_LT(m.residual(x).norm(), 1e-12);
  EXPECT_LT((m.jacobian(x) - numericH(m, x)).cwiseAbs().maxCoeff(), 1e-6);
  // A rotation-only measurement is the 6-DoF delta without its translation rows.
  const DeltaMeasurement d(0, 2, z, Matrix6d::Identity() * 1e-6, T_imu_cam);
  EXPECT_LT((m.jacobian(x) - d.jacobian(x).bottomRows(3)).cwiseAbs().maxCoeff(), 1e-12);
  // Off by a known rotation: the residual is that rotation (left perturbation, camera 0 at the older time).
  const Eigen::Vector3d off(2e-3, -1e-3, 5e-4);
  const RotationMeasurement m2(0, 2, expSO3(off) * z.linear(), Eigen::Matrix3d::Identity() * 1e-8, T_imu_cam);
  EXPECT_LT((Eigen::Vector3d(m2.residual(x)) - off).norm(), 1e-9);
}

// The motion's process noise measured from the samples (ProcessNoise::from_imu) against the densities that made them:
// an acceleration and an angular rate that are random walks of known density on one axis, the sensor's white noise of
// its description on all. Above the configured floors the excess is the vibration; the sensor's noise alone (a head
// at rest) adds none, and neither does a gap in the samples.
TEST(FilterModels, MotionNoiseFindsTheDensitiesOfTheSamples) {
  ProcessNoise floor;  // jerk 4, angular acceleration 20
  ImuNoise imu;        // MMQ-50 at 200 Hz
  const double jerk_psd = 500.0, angular_psd = 80.0, dt = 1.0 / imu.rate_hz;
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  const double white_f = imu.accel_noise_density * std::sqrt(imu.rate_hz);
  const double white_w = imu.gyro_noise_density * std::sqrt(imu.rate_hz);
  MotionNoise moving(floor, imu), resting(floor, imu);
  Eigen::Vector3d a = Eigen::Vector3d::Zero(), w = Eigen::Vector3d::Zero();
  int64_t t = 1'000'000;
  for (int i = 0; i < 2000; ++i, t += 5000) {
    a.y() += std::sqrt(jerk_psd * dt) * n(rng);
    w.z() += std::sqrt(angular_psd * dt) * n(rng);
    const Eigen::Vector3d noise_f(white_f * n(rng), white_f * n(rng), white_f * n(rng));
    const Eigen::Vector3d noise_w(white_w * n(rng), white_w * n(rng), white_w * n(rng));
    moving.add(t, w + noise_w, a + Eigen::Vector3d(0, 0, 9.81) + noise_f);
    resting.add(t, noise_w, Eigen::Vector3d(0, 0, 9.81) + noise_f);
  }
  // One second of 200 samples: the mean square's own spread is 10 %.
  EXPECT_NEAR(moving.current().vibration_jerk_psd, jerk_psd - floor.jerk_psd, 0.3 * jerk_psd);
  EXPECT_NEAR(moving.current().vibration_angular_accel_psd, angular_psd - floor.angular_accel_psd, 0.3 * angular_psd);
  EXPECT_EQ(moving.current().jerk_psd, floor.jerk_psd);
  EXPECT_EQ(resting.current().vibration_jerk_psd, 0.0);
  EXPECT_EQ(resting.current().vibration_angular_accel_psd, 0.0);
  // A difference across a 1 s gap is not counted as one step.
  MotionNoise gap(floor, imu);
  gap.add(t, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  gap.add(t + 1'000'000, Eigen::Vector3d::Constant(1.0), Eigen::Vector3d::Constant(10.0));
  EXPECT_EQ(gap.current().vibration_jerk_psd, 0.0);
  // Off: the configured densities.
  ProcessNoise off = floor;
  off.from_imu = false;
  MotionNoise unused(off, imu);
  unused.add(t, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  unused.add(t + 5000, Eigen::Vector3d::Constant(1.0), Eigen::Vector3d::Constant(10.0));
  EXPECT_EQ(unused.current().vibration_jerk_psd, 0.0);
}
