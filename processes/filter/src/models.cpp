#include "ips/filter/models.hpp"

#include <cmath>
#include <stdexcept>

namespace ips::filter {

// ---------------------------------------------------------------------------------------------- process

NavState propagateNav(const NavState& x, double dt) {
  NavState y = x;
  y.position = x.position + x.velocity * dt + 0.5 * dt * dt * x.acceleration;
  y.velocity = x.velocity + x.acceleration * dt;
  // Body rate: the increment acts from the right.
  y.orientation = (x.orientation * expQuat(x.angular_rate * dt)).normalized();
  y.utime = x.utime + static_cast<int64_t>(std::llround(dt * 1e6));
  return y;
}

Matrix21d processJacobian(const NavState& x, double dt) {
  Matrix21d F = Matrix21d::Identity();
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  F.block<3, 3>(kErrP, kErrV) = dt * I;
  F.block<3, 3>(kErrP, kErrA) = 0.5 * dt * dt * I;
  F.block<3, 3>(kErrV, kErrA) = dt * I;
  // R' = Exp(dth) R Exp((w + dw) dt) = Exp(dth + R' Jr(w dt) dt dw) R'
  const Eigen::Vector3d phi = x.angular_rate * dt;
  const Eigen::Matrix3d R_end = (x.orientation * expQuat(phi)).toRotationMatrix();
  F.block<3, 3>(kErrTh, kErrW) = R_end * rightJacobianSO3(phi) * dt;
  return F;
}

Matrix21d processNoise(const NavState& x_end, double dt, const ProcessNoise& q) {
  Matrix21d Q = Matrix21d::Zero();
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  const double dt2 = dt * dt, dt3 = dt2 * dt, dt4 = dt3 * dt, dt5 = dt4 * dt;
  // (p, v, a) driven by white jerk.
  const double j = q.jerk_psd;
  Q.block<3, 3>(kErrP, kErrP) = j * dt5 / 20.0 * I;
  Q.block<3, 3>(kErrP, kErrV) = j * dt4 / 8.0 * I;
  Q.block<3, 3>(kErrP, kErrA) = j * dt3 / 6.0 * I;
  Q.block<3, 3>(kErrV, kErrV) = j * dt3 / 3.0 * I;
  Q.block<3, 3>(kErrV, kErrA) = j * dt2 / 2.0 * I;
  Q.block<3, 3>(kErrA, kErrA) = (j + q.vibration_jerk_psd) * dt * I;
  Q.block<3, 3>(kErrV, kErrP) = Q.block<3, 3>(kErrP, kErrV);
  Q.block<3, 3>(kErrA, kErrP) = Q.block<3, 3>(kErrP, kErrA);
  Q.block<3, 3>(kErrA, kErrV) = Q.block<3, 3>(kErrV, kErrA);
  // (theta in world, w in body) driven by white angular acceleration: dth' = R dw.
  const double a = q.angular_accel_psd;
  const Eigen::Matrix3d R = x_end.orientation.toRotationMatrix();
  Q.block<3, 3>(kErrW, kErrW) = (a + q.vibration_angular_accel_psd) * dt * I;
  Q.block<3, 3>(kErrTh, kErrTh) = a * dt3 / 3.0 * I;
  Q.block<3, 3>(kErrTh, kErrW) = a * dt2 / 2.0 * R;
  Q.block<3, 3>(kErrW, kErrTh) = a * dt2 / 2.0 * R.transpose();
  Q.block<3, 3>(kErrBa, kErrBa) = q.accel_bias_psd * dt * I;
  Q.block<3, 3>(kErrBg, kErrBg) = q.gyro_bias_psd * dt * I;
  return Q;
}

MotionNoise::MotionNoise(const ProcessNoise& floor, const ImuNoise& imu)
    : floor_(floor),
      current_(floor),
      gyro_var_(imu.gyro_noise_density * imu.gyro_noise_density * imu.rate_hz),
      accel_var_(imu.accel_noise_density * imu.accel_noise_density * imu.rate_hz),
      max_dt_us_(static_cast<int64_t>(3e6 / imu.rate_hz)),
      window_us_(static_cast<int64_t>(floor.from_imu_window_s * 1e6)) {}

void MotionNoise::add(int64_t utime, const Eigen::Vector3d& angular_rate, const Eigen::Vector3d& specific_force) {
  const int64_t prev = last_utime_;
  const Eigen::Vector3d dw = angular_rate - last_w_, df = specific_force - last_f_;
  last_utime_ = utime, last_w_ = angular_rate, last_f_ = specific_force;
  // A difference across a gap (more than three nominal intervals) is not one step of the motion.
  if (!floor_.from_imu || prev == INT64_MIN || utime <= prev || utime - prev > max_dt_us_) return;
  const double dt = static_cast<double>(utime - prev) * 1e-6;
  Difference d;
  d.utime = utime;
  d.gyro2 = (dw.cwiseAbs2() - Eigen::Vector3d::Constant(2 * gyro_var_)) / dt;
  d.accel2 = (df.cwiseAbs2() - Eigen::Vector3d::Constant(2 * accel_var_)) / dt;
  window_.push_back(d);
  gyro_sum_ += d.gyro2, accel_sum_ += d.accel2;
  while (window_.front().utime <= utime - window_us_) {
    gyro_sum_ -= window_.front().gyro2, accel_sum_ -= window_.front().accel2;
    window_.pop_front();
  }
  const double n = static_cast<double>(window_.size());
  current_.vibration_jerk_psd = std::max(0.0, accel_sum_.maxCoeff() / n - floor_.jerk_psd);
  current_.vibration_angular_accel_psd = std::max(0.0, gyro_sum_.maxCoeff() / n - floor_.angular_accel_psd);
}

// ---------------------------------------------------------------------------------------------- IMU

ImuMeasurement::ImuMeasurement(const Eigen::Vector3d& angular_rate, const Eigen::Vector3d& specific_force,
                               double gravity, double gyro_sigma, double accel_sigma)
    : gyro_(angular_rate),
      accel_(specific_force),
      gravity_(gravity),
      gyro_var_(gyro_sigma * gyro_sigma),
      accel_var_(accel_sigma * accel_sigma) {}

MeasVector ImuMeasurement::predict(const NavState& x) const {
  MeasVector h(6);
  h.head<3>() = x.angular_rate + x.gyro_bias;
  const Eigen::Vector3d u = x.acceleration + Eigen::Vector3d(0, 0, gravity_);
  h.tail<3>() = x.orientation.conjugate() * u + x.accel_bias;
  return h;
}

MeasVector ImuMeasurement::residual(const FullState& x) const {
  MeasVector z(6);
  z << gyro_, accel_;
  return z - predict(x.nav);
}

Eigen::MatrixXd ImuMeasurement::jacobian(const FullState& x) const {
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(6, x.errorDim());
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d Rt = x.nav.orientation.toRotationMatrix().transpose();
  const Eigen::Vector3d u = x.nav.acceleration + Eigen::Vector3d(0, 0, gravity_);
  H.block<3, 3>(0, kErrW) = I;
  H.block<3, 3>(0, kErrBg) = I;
  H.block<3, 3>(3, kErrA) = Rt;
  H.block<3, 3>(3, kErrBa) = I;
  H.block<3, 3>(3, kErrTh) = Rt * skew(u);
  return H;
}

MeasMatrix ImuMeasurement::noise() const {
  MeasMatrix R = MeasMatrix::Zero(6, 6);
  R.diagonal() << gyro_var_, gyro_var_, gyro_var_, accel_var_, accel_var_, accel_var_;
  return R;
}

// ---------------------------------------------------------------------------------------------- tilt

TiltMeasurement::TiltMeasurement(double angle_x, double angle_y, const Eigen::Matrix3d& R_body_tilt, double sigma,
                                 double gravity, bool specific_force, bool offset_state)
    : z_(angle_x, angle_y),
      R_body_tilt_(R_body_tilt),
      var_(sigma * sigma),
      gravity_(gravity),
      specific_force_(specific_force),
      offset_state_(offset_state) {}

Eigen::Vector2d TiltMeasurement::predict(const Eigen::Quaterniond& q, const Eigen::Matrix3d& R_body_tilt,
                                         const Eigen::Vector3d& u_world) {
  const Eigen::Vector3d f = R_body_tilt.transpose() * (q.conjugate() * u_world);
  const double n = f.norm();
  if (!(n > 0)) return Eigen::Vector2d::Zero();
  return Eigen::Vector2d(std::asin(std::clamp(f.x() / n, -1.0, 1.0)), std::asin(std::clamp(f.y() / n, -1.0, 1.0)));
}

Eigen::Vector2d TiltMeasurement::predict(const Eigen::Quaterniond& q, const Eigen::Matrix3d& R_body_tilt) {
  return predict(q, R_body_tilt, Eigen::Vector3d::UnitZ());
}

Eigen::Vector3d TiltMeasurement::sensed(const NavState& x) const {
  const Eigen::Vector3d g(0, 0, gravity_);
  return specific_force_ ? Eigen::Vector3d(x.acceleration + g) : g;
}

MeasVector TiltMeasurement::residual(const FullState& x) const {
  Eigen::Vector2d h = predict(x.nav.orientation, R_body_tilt_, sensed(x.nav));
  if (offset_state_ && x.tilt_offset) h += *x.tilt_offset;
  return MeasVector(z_ - h);
}

Eigen::MatrixXd TiltMeasurement::jacobian(const FullState& x) const {
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(2, x.errorDim());
  if (offset_state_ && x.tilt_offset) H.block<2, 2>(0, x.offset(kTiltOffset)).setIdentity();
  const Eigen::Vector3d u = sensed(x.nav);
  const Eigen::Matrix3d A = R_body_tilt_.transpose() * x.nav.orientation.toRotationMatrix().transpose();
  const Eigen::Vector3d f = A * u;
  const double n = f.norm();
  if (!(n > 0)) return H;
  // f(dth, da) = A Exp(-dth) (u + da) ~= f + A [u]x dth + A da (as for the accelerometer).
  const Eigen::Matrix3d df_dth = A * skew(u);
  for (int k = 0; k < 2; ++k) {
    const double s = f(k) / n;
    // d asin(f_k / |f|) / df = (e_k / |f| - f_k f / |f|^3) / sqrt(1 - s^2)
    Eigen::RowVector3d ds = -f.transpose() * f(k) / (n * n * n);
    ds(k) += 1.0 / n;
    ds /= std::sqrt(std::max(1e-12, 1.0 - s * s));
    H.block<1, 3>(k, kErrTh) = ds * df_dth;
    if (specific_force_) H.block<1, 3>(k, kErrA) = ds * A;
  }
  return H;
}

MeasMatrix TiltMeasurement::noise() const {
  MeasMatrix R = MeasMatrix::Zero(2, 2);
  R.diagonal().setConstant(var_);
  return R;
}

// ---------------------------------------------------------------------------------------------- delta

namespace {

// The camera-to-IMU transformation a model uses: the calibration's, with the state's lever arm and the state's
// camera alignment where the filter estimates them.
Eigen::Isometry3d imuCamera(const FullState& x, const Eigen::Isometry3d& T_imu_cam0) {
  Eigen::Isometry3d T = T_imu_cam0;
  if (x.lever_arm) T.translation() = *x.lever_arm;
  if (x.camera_alignment) T.linear() = T_imu_cam0.linear() * x.camera_alignment->toRotationMatrix();
  return T;
}

// Rows `row`..`row`+2 of H for the relative rotation of camera 0 between clones i0 and i1 (DeltaMeasurement's
// rotation part, RotationMeasurement whole): R_pred = R_ci R0^T R1 R_ic, perturbed from the left by
// Exp(A (dth1 - dth0)) with A = R_ci R0^T. The camera alignment's error dphi turns R_ic into R_ic Exp(dphi), and
// R_pred into Exp(-dphi) R_pred Exp(dphi) = Exp((R_pred - I) dphi) R_pred.
void setRotationRows(const FullState& x, int i0, int i1, const Eigen::Isometry3d& T_imu_cam0_calibration, int row,
                     Eigen::MatrixXd& H) {
  const Eigen::Isometry3d T_imu_cam0 = imuCamera(x, T_imu_cam0_calibration);
  const Eigen::Matrix3d A =
      T_imu_cam0.linear().transpose() * x.clones.at(i0).orientation.toRotationMatrix().transpose();
  H.block<3, 3>(row, x.cloneOffset(i1) + 3) = A;
  H.block<3, 3>(row, x.cloneOffset(i0) + 3) = -A;
  if (x.camera_alignment) {
    const Eigen::Matrix3d R_pred = A * x.clones.at(i1).orientation.toRotationMatrix() * T_imu_cam0.linear();
    H.block<3, 3>(row, x.offset(kCameraAlignment)) = R_pred - Eigen::Matrix3d::Identity();
  }
}

}  // namespace

DeltaMeasurement::DeltaMeasurement(int clone0, int clone1, const Eigen::Isometry3d& T_c0_c1, const Matrix6d& covariance,
                                   const Eigen::Isometry3d& T_imu_cam0, bool from_tracker)
    : i0_(clone0), i1_(clone1), z_(T_c0_c1), cov_(covariance), T_imu_cam0_(T_imu_cam0), from_tracker_(from_tracker) {}

Eigen::Isometry3d DeltaMeasurement::predict(const PoseClone& c0, const PoseClone& c1,
                                            const Eigen::Isometry3d& T_imu_cam0) {
  Eigen::Isometry3d T_w_b0 = Eigen::Isometry3d::Identity(), T_w_b1 = Eigen::Isometry3d::Identity();
  T_w_b0.linear() = c0.orientation.toRotationMatrix();
  T_w_b0.translation() = c0.position;
  T_w_b1.linear() = c1.orientation.toRotationMatrix();
  T_w_b1.translation() = c1.position;
  return T_imu_cam0.inverse() * T_w_b0.inverse() * T_w_b1 * T_imu_cam0;
}

Eigen::Matrix3d DeltaMeasurement::turnOf(const FullState& x) const {
  return from_tracker_ && x.delta_direction ? Eigen::Matrix3d(Eigen::Matrix3d::Identity() + skew(*x.delta_direction))
                                            : Eigen::Matrix3d::Identity();
}

Eigen::Vector3d DeltaMeasurement::rotationDriftOf(const FullState& x) const {
  return from_tracker_ && x.delta_rotation_drift ? Eigen::Vector3d(z_.translation().norm() * *x.delta_rotation_drift)
                                                 : Eigen::Vector3d::Zero();
}

MeasVector DeltaMeasurement::residual(const FullState& x) const {
  const Eigen::Isometry3d T = predict(x.clones.at(i0_), x.clones.at(i1_), imuCamera(x, T_imu_cam0_));
  MeasVector r(6);
  r.head<3>() = z_.translation() - scaleOf(x) * turnOf(x) * T.translation();
  r.tail<3>() = logSO3(z_.linear() * (expSO3(rotationDriftOf(x)) * T.linear()).transpose());
  return r;
}

Eigen::MatrixXd DeltaMeasurement::jacobian(const FullState& x) const {
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(6, x.errorDim());
  const PoseClone& c0 = x.clones.at(i0_);
  const PoseClone& c1 = x.clones.at(i1_);
  const Eigen::Matrix3d R0 = c0.orientation.toRotationMatrix();
  const Eigen::Matrix3d R1 = c1.orientation.toRotationMatrix();
  const Eigen::Isometry3d T_imu_cam0 = imuCamera(x, T_imu_cam0_);
  const Eigen::Matrix3d R_ci = T_imu_cam0.linear().transpose();
  const Eigen::Vector3d t_ic = T_imu_cam0.translation();
  const Eigen::Matrix3d A = R_ci * R0.transpose();
  const Eigen::Vector3d d = c1.position + R1 * t_ic - c0.position;
  const int o0 = x.cloneOffset(i0_);
  const int o1 = x.cloneOffset(i1_);
  // t_pred = R_ci R0^T (p1 + R1 t_ic - p0) - R_ci t_ic
  H.block<3, 3>(0, o1) = A;
  H.block<3, 3>(0, o0) = -A;
  H.block<3, 3>(0, o1 + 3) = -A * skew(R1 * t_ic);
  H.block<3, 3>(0, o0 + 3) = A * skew(d);
  // The lever arm shows only where the head turns between the two images: d t_pred / d t_ic = R_ci (R0^T R1 - I).
  if (x.lever_arm) H.block<3, 3>(0, x.offset(kLeverArm)) = A * R1 - R_ci;
  // The camera alignment's error turns R_ci into Exp(-dphi) R_ci: t_pred into t_pred + [t_pred]x dphi.
  if (x.camera_alignment) H.block<3, 3>(0, x.offset(kCameraAlignment)) = skew(A * d - R_ci * t_ic);
  // Measured: (1 + s) (I + [b]x) t_pred.
  const Eigen::Vector3d t_pred = A * d - R_ci * t_ic;
  const Eigen::Matrix3d turn = turnOf(x);
  H.topRows<3>() = (scaleOf(x) * turn * H.topRows<3>()).eval();
  if (from_tracker_ && x.delta_scale) H.block<3, 1>(0, x.offset(kDeltaScale)) = turn * t_pred;
  if (from_tracker_ && x.delta_direction) H.block<3, 3>(0, x.offset(kDeltaDirection)) = -scaleOf(x) * skew(t_pred);
  setRotationRows(x, i0_, i1_, T_imu_cam0_, 3, H);
  // Measured: Exp(c r) R_pred with c = |t_meas|: a perturbation Exp(e) of R_pred shows as Exp(Exp(c r) e), and one of r
  // as Exp(c J_l(c r) dr), J_l(phi) = J_r(-phi).
  if (from_tracker_ && x.delta_rotation_drift) {
    const Eigen::Vector3d drift = rotationDriftOf(x);
    H.middleRows<3>(3) = (expSO3(drift) * H.middleRows<3>(3)).eval();
    H.block<3, 3>(3, x.offset(kDeltaRotationDrift)) = z_.translation().norm() * rightJacobianSO3(-drift);
  }
  return H;
}

// ---------------------------------------------------------------------------------------------- rotation

RotationMeasurement::RotationMeasurement(int clone0, int clone1, const Eigen::Matrix3d& R_c0_c1,
                                         const Eigen::Matrix3d& covariance, const Eigen::Isometry3d& T_imu_cam0)
    : i0_(clone0), i1_(clone1), z_(R_c0_c1), cov_(covariance), T_imu_cam0_(T_imu_cam0) {}

MeasVector RotationMeasurement::residual(const FullState& x) const {
  const Eigen::Isometry3d T = DeltaMeasurement::predict(x.clones.at(i0_), x.clones.at(i1_), imuCamera(x, T_imu_cam0_));
  return MeasVector(logSO3(z_ * T.linear().transpose()));
}

Eigen::MatrixXd RotationMeasurement::jacobian(const FullState& x) const {
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(3, x.errorDim());
  setRotationRows(x, i0_, i1_, T_imu_cam0_, 0, H);
  return H;
}

// ---------------------------------------------------------------------------------------------- chi-square

namespace {

// Regularised lower incomplete gamma P(a, x) (series for x < a + 1, continued fraction otherwise).
double gammaP(double a, double x) {
  if (x <= 0) return 0.0;
  const double gln = std::lgamma(a);
  if (x < a + 1.0) {
    double ap = a, sum = 1.0 / a, del = sum;
    for (int n = 0; n < 500; ++n) {
      ap += 1.0;
      del *= x / ap;
      sum += del;
      if (std::fabs(del) < std::fabs(sum) * 1e-15) break;
    }
    return sum * std::exp(-x + a * std::log(x) - gln);
  }
  const double tiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 500; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::fabs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::fabs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::fabs(del - 1.0) < 1e-15) break;
  }
  return 1.0 - std::exp(-x + a * std::log(x) - gln) * h;
}

}  // namespace

double chiSquareCdf(double x, int dof) {
  if (dof < 1) throw std::invalid_argument("chiSquareCdf: dof must be >= 1");
  return gammaP(0.5 * dof, 0.5 * x);
}

double chiSquareQuantile(double p, int dof) {
  if (!(p > 0 && p < 1) || dof < 1) throw std::invalid_argument("chiSquareQuantile: need 0 < p < 1, dof >= 1");
  double lo = 0.0, hi = std::max(1.0, 2.0 * dof);
  while (chiSquareCdf(hi, dof) < p) hi *= 2.0;
  for (int i = 0; i < 200 && hi - lo > 1e-12 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (chiSquareCdf(mid, dof) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace ips::filter
