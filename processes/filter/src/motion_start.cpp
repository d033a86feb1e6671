#include "ips/filter/motion_start.hpp"

#include <Eigen/Cholesky>
#include <cmath>

#include "ips/filter/state.hpp"

namespace ips::filter {

namespace {

// Calls fn(rate, specific_force, dt [s]) for the pieces of [ta, tb] between IMU samples, with the mean of the
// samples' values over the piece (linear between consecutive samples: the integrals are exact to second order, which
// a zero-order hold is not: it would turn each interval's rotation by half a sample's change of the rate). Returns
// false when the samples do not cover the interval (the last one may hold up to one interval beyond its stamp).
template <class Fn>
bool forEachPiece(const std::vector<ImuSample>& imu, int64_t ta, int64_t tb, Fn&& fn) {
  if (imu.size() < 2 || imu.front().utime > ta) return false;
  const int64_t last_interval = imu.back().utime - imu[imu.size() - 2].utime;
  if (tb > imu.back().utime + last_interval) return false;
  auto at = [&](size_t k, int64_t t, const Eigen::Vector3d ImuSample::*field) -> Eigen::Vector3d {
    if (k + 1 >= imu.size()) return imu[k].*field;
    const double u = static_cast<double>(t - imu[k].utime) / static_cast<double>(imu[k + 1].utime - imu[k].utime);
    return (1 - u) * (imu[k].*field) + u * (imu[k + 1].*field);
  };
  // The sample at or before ta.
  size_t k = 0;
  while (k + 1 < imu.size() && imu[k + 1].utime <= ta) ++k;
  int64_t t = ta;
  while (t < tb) {
    const int64_t end = k + 1 < imu.size() ? std::min(tb, imu[k + 1].utime) : tb;
    if (end > t)
      fn(Eigen::Vector3d(0.5 * (at(k, t, &ImuSample::angular_rate) + at(k, end, &ImuSample::angular_rate))),
         Eigen::Vector3d(0.5 * (at(k, t, &ImuSample::specific_force) + at(k, end, &ImuSample::specific_force))),
         static_cast<double>(end - t) * 1e-6);
    t = end;
    ++k;
  }
  return true;
}

Eigen::Isometry3d deltaPose(const TrackerDelta& d) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = d.rotation.normalized().toRotationMatrix();
  T.translation() = d.translation;
  return T;
}

std::nullopt_t fail(std::string* why, const std::string& what) {
  if (why) *why = what;
  return std::nullopt;
}

}  // namespace

std::optional<MotionStart> estimateMotionStart(const MotionStartInput& in, std::string* why) {
  if (in.deltas.size() < 2) return fail(why, "fewer than two deltas");
  for (size_t k = 1; k < in.deltas.size(); ++k)
    if (in.deltas[k].utime_prev != in.deltas[k - 1].utime) return fail(why, "the deltas are not a chain");
  const Eigen::Matrix3d R_ic = in.T_imu_cam0.linear();
  const double gyro_var_density = in.gyro_noise_density * in.gyro_noise_density;
  const double accel_var_density = in.accel_noise_density * in.accel_noise_density;

  // 1. The gyro bias: each delta's rotation, in the body frame, against the gyro's over the same interval. The
  // integrated rotation with bias b + db is R(b) Exp(J db) (the preintegration Jacobian J), so the residual
  // Log(R(b)^T R_tracker) falls by J db: Gauss-Newton, relinearised as b moves.
  MotionStart out;
  out.utime = in.deltas.front().utime_prev;
  // One delta against the gyro with bias b: the residual Log(R(b)^T R_tracker), its covariance (the delta's and the
  // gyro's noise over the interval) and J; false where the IMU does not cover the delta.
  struct Residual {
    Eigen::Vector3d r;
    Eigen::Matrix3d cov, J;
  };
  auto residualOf = [&](const TrackerDelta& d, const Eigen::Vector3d& b, Residual* out_r) {
    Eigen::Matrix3d R = Eigen::Matrix3d::Identity(), J = Eigen::Matrix3d::Zero();
    const bool covered =
        forEachPiece(in.imu, d.utime_prev, d.utime, [&](const Eigen::Vector3d& w, const Eigen::Vector3d&, double dt) {
          const Eigen::Vector3d phi = (w - b) * dt;
          const Eigen::Matrix3d step = expSO3(phi);
          J = step.transpose() * J - rightJacobianSO3(phi) * dt;
          R = R * step;
        });
    const Eigen::Matrix3d R_tracker = R_ic * d.rotation.normalized().toRotationMatrix() * R_ic.transpose();
    out_r->r = logSO3(R.transpose() * R_tracker);
    out_r->cov = R_ic * d.covariance.bottomRightCorner<3, 3>() * R_ic.transpose() +
                 Eigen::Matrix3d::Identity() * gyro_var_density * static_cast<double>(d.utime - d.utime_prev) * 1e-6;
    out_r->J = J;
    return covered;
  };
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  Eigen::Matrix3d bias_normal = Eigen::Matrix3d::Zero();
  for (int iteration = 0; iteration < 4; ++iteration) {
    bias_normal.setZero();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    for (const TrackerDelta& d : in.deltas) {
      Residual res;
      if (!residualOf(d, b, &res)) return fail(why, "the IMU samples do not cover the deltas");
      const Eigen::Matrix3d W = res.cov.inverse();
      bias_normal += res.J.transpose() * W * res.J;
      rhs += res.J.transpose() * W * res.r;
    }
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(bias_normal);
    if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return fail(why, "gyro bias unobservable");
    const Eigen::Vector3d db = ldlt.solve(rhs);
    b += db;
    if (db.norm() < 1e-9) break;
  }
  out.gyro_bias = b;
  // The fit's residuals against the deltas' own covariance: a tracker that claims more than its rotations hold
  // (chi-square per degree of freedom above 1) leaves the bias less certain than the normal equations say, and the
  // filter must be free to learn it further (a posteriori variance factor).
  double chi2 = 0;
  for (const TrackerDelta& d : in.deltas) {
    Residual res;
    residualOf(d, b, &res);
    chi2 += res.r.dot(res.cov.ldlt().solve(res.r));
  }
  const double dof = 3.0 * static_cast<double>(in.deltas.size()) - 3.0;
  out.gyro_bias_variance_factor = dof > 0 ? std::max(1.0, chi2 / dof) : 1.0;
  out.gyro_bias_covariance = bias_normal.inverse() * out.gyro_bias_variance_factor;

  // 2. Velocity and gravity at the first image, in its body frame b0: the tracker's chained poses give the body's
  // positions p_k; the IMU, rotated into b0 with the corrected gyro, gives the doubly integrated specific force s_k;
  // p_k = v0 dt_k + g dt_k^2 / 2 + s_k is linear in (v0, g). The accelerometer's bias stays in g (a bias across
  // gravity looks like a tilt until the head turns; the filter separates them later, from its turn-on prior), and
  // |g| is left free: its misfit against the known value says whether the deltas and the IMU agree.
  const Eigen::Isometry3d T_ci = in.T_imu_cam0.inverse();
  Eigen::Isometry3d T_c0_ck = Eigen::Isometry3d::Identity();
  double position_var = 0;
  Eigen::Matrix<double, 6, 6> normal = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> rhs = Eigen::Matrix<double, 6, 1>::Zero();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d v_int = Eigen::Vector3d::Zero(), p_int = Eigen::Vector3d::Zero();
  for (const TrackerDelta& d : in.deltas) {
    T_c0_ck = T_c0_ck * deltaPose(d);
    position_var += d.covariance.topLeftCorner<3, 3>().trace() / 3.0;
    forEachPiece(in.imu, d.utime_prev, d.utime,
                 [&](const Eigen::Vector3d& w, const Eigen::Vector3d& f_body, double dt) {
                   // The specific force rotated with the body's turn over half the piece (midpoint).
                   const Eigen::Matrix3d step = expSO3((w - b) * dt);
                   const Eigen::Vector3d f = R * expSO3((w - b) * (0.5 * dt)) * f_body;
                   p_int += v_int * dt + 0.5 * f * dt * dt;
                   v_int += f * dt;
                   R = R * step;
                 });
    const Eigen::Vector3d p = (in.T_imu_cam0 * T_c0_ck * T_ci).translation();
    const double dt = static_cast<double>(d.utime - out.utime) * 1e-6;
    Eigen::Matrix<double, 3, 6> A;
    A << Eigen::Matrix3d::Identity() * dt, Eigen::Matrix3d::Identity() * (0.5 * dt * dt);
    const double w = 1.0 / (position_var + accel_var_density * dt * dt * dt / 3.0);
    normal += w * A.transpose() * A;
    rhs += w * A.transpose() * (p - p_int);
  }
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(normal);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return fail(why, "velocity and gravity unobservable");
  const Eigen::Matrix<double, 6, 1> x = ldlt.solve(rhs);
  out.velocity_body = x.head<3>();
  out.gravity_body = x.tail<3>();
  out.covariance = normal.inverse();
  out.gravity_error = std::fabs(out.gravity_body.norm() / in.gravity - 1.0);
  if (!(out.gravity_error <= in.max_gravity_error))
    return fail(why, "gravity misfit " + std::to_string(out.gravity_error));
  return out;
}

}  // namespace ips::filter
