#include "ips/calib/camera_imu.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "ips/rotation.hpp"

namespace ips::calib {
namespace {

constexpr double kDeg = M_PI / 180.0;

// The gyro's rotation over [a, b] (microseconds, any real values inside the samples): body at b in body at a,
// rates linear between samples, each piece between sample times by the mid-point rule (the rates are linear there,
// so the error is of third order in the piece's length).
class GyroRotations {
 public:
  explicit GyroRotations(std::vector<GyroSample> gyro) : g_(std::move(gyro)) {
    std::sort(g_.begin(), g_.end(), [](const GyroSample& x, const GyroSample& y) { return x.utime < y.utime; });
    g_.erase(
        std::unique(g_.begin(), g_.end(), [](const GyroSample& x, const GyroSample& y) { return x.utime == y.utime; }),
        g_.end());
  }
  bool covers(double a, double b) const { return g_.size() >= 2 && a >= g_.front().utime && b <= g_.back().utime; }

  Eigen::Matrix3d rotation(double a, double b, const Eigen::Vector3d& bias) const {
    Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
    // First sample after a.
    size_t i = static_cast<size_t>(
        std::upper_bound(g_.begin(), g_.end(), a, [](double v, const GyroSample& s) { return v < s.utime; }) -
        g_.begin());
    double t = a;
    while (t < b) {
      const double end = i < g_.size() ? std::min(b, static_cast<double>(g_[i].utime)) : b;
      if (end > t) {
        const Eigen::Vector3d rate = rateAt(0.5 * (t + end)) - bias;
        R = R * expSO3(rate * ((end - t) * 1e-6));
      }
      t = end;
      ++i;
    }
    return R;
  }

 private:
  Eigen::Vector3d rateAt(double t) const {
    auto it = std::upper_bound(g_.begin(), g_.end(), t, [](double v, const GyroSample& s) { return v < s.utime; });
    const size_t i = static_cast<size_t>(it - g_.begin());
    if (i == 0) return g_.front().rate;
    if (i >= g_.size()) return g_.back().rate;
    const GyroSample& x = g_[i - 1];
    const GyroSample& y = g_[i];
    const double w = (t - x.utime) / static_cast<double>(y.utime - x.utime);
    return x.rate + w * (y.rate - x.rate);
  }

  std::vector<GyroSample> g_;
};

struct Interval {
  double t0, t1;
  Eigen::Matrix3d R_tracker;
};

// Parameters of the fit: R_cam_imu (perturbed on the right by a rotation vector in the IMU frame), bias, delay.
struct Fit {
  Eigen::Matrix3d R_cam_imu = Eigen::Matrix3d::Identity();
  Eigen::Vector3d bias = Eigen::Vector3d::Zero();
  double delay_us = 0;
};

Eigen::Vector3d residual(const Interval& v, const Eigen::Matrix3d& R_cam_imu, const Eigen::Matrix3d& G) {
  return logSO3(v.R_tracker.transpose() * R_cam_imu * G * R_cam_imu.transpose());
}

}  // namespace

CameraImuEstimate calibrateCameraImu(const std::vector<GyroSample>& gyro_in, const std::vector<TrackerRotation>& deltas,
                                     const CameraImuConfig& config) {
  if (config.iterations < 1 || !(config.outlier_sigmas > 0) || config.min_rotation_deg < 0)
    throw std::invalid_argument(
        "camera-IMU calibration: need iterations >= 1, outlier_sigmas > 0, min_rotation_deg >= 0");
  CameraImuEstimate out;

  // 1. The delay from the rates' magnitudes.
  const DelayEstimate coarse = estimateCameraImuDelay(gyro_in, deltas, config.coarse);
  out.coarse_delay_us = coarse.delay_us;
  out.coarse_correlation = coarse.correlation;
  if (!coarse.ok) {
    out.reason = "the rates' magnitudes give no delay (" + std::to_string(coarse.intervals) +
                 " intervals, too little rotation or too short a recording)";
    return out;
  }
  const GyroRotations gyro(gyro_in);
  // Intervals the gyro covers with two grid steps to spare around the coarse delay: the refinement moves the delay
  // by a fraction of a step.
  const double margin = static_cast<double>(config.coarse.step_us) * 2;
  std::vector<Interval> intervals;
  for (const auto& d : deltas) {
    const double t0 = static_cast<double>(d.utime_prev), t1 = static_cast<double>(d.utime);
    if (!(t1 > t0)) continue;
    if (!gyro.covers(t0 - coarse.delay_us - margin, t1 - coarse.delay_us + margin)) continue;
    intervals.push_back({t0, t1, d.rotation.normalized().toRotationMatrix()});
  }

  Fit fit;
  fit.delay_us = coarse.delay_us;
  auto gyroOf = [&](const Interval& v, const Eigen::Vector3d& bias, double delay) {
    return gyro.rotation(v.t0 - delay, v.t1 - delay, bias);
  };

  // 2. The rotation in closed form: camera rotation vectors = R_cam_imu * IMU rotation vectors (Kabsch), unless known.
  const bool rotation_known = config.known_R_imu_cam.has_value();
  if (rotation_known) {
    fit.R_cam_imu = config.known_R_imu_cam->transpose();
  } else {
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    size_t turning = 0;
    for (const Interval& v : intervals) {
      const Eigen::Vector3d a = logSO3(v.R_tracker), b = logSO3(gyroOf(v, fit.bias, fit.delay_us));
      if (a.norm() < config.min_rotation_deg * kDeg || b.norm() < config.min_rotation_deg * kDeg) continue;
      H += b * a.transpose();
      ++turning;
    }
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
    const Eigen::Vector3d s = svd.singularValues();
    // The rotation is fixed only if the head turned about at least two different axes.
    if (turning < config.coarse.min_intervals || !(s(1) > 1e-3 * s(0))) {
      out.reason = "the head turned about one axis only (or too little): turn it about all axes";
      out.intervals = turning;
      return out;
    }
    Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
    D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() > 0 ? 1 : -1;
    fit.R_cam_imu = svd.matrixV() * D * svd.matrixU().transpose();
  }

  // 3. Gauss-Newton on the 7 parameters (rotation, bias, delay; 4 with the rotation known) with numeric derivatives,
  // outliers left out by a robust bound.
  constexpr int kParams = 7;
  // The parameters fitted: all, or bias and delay (the rotation's columns of the normal equations held at zero step).
  const int first = rotation_known ? 3 : 0, fitted = kParams - first;
  // Below this spread (rad) residuals are rounding: noise-free data must not turn every interval into an outlier.
  constexpr double kSigmaFloor = 1e-7;
  const double h_rot = 1e-6, h_bias = 1e-5, h_delay = 50.0;
  std::vector<char> kept(intervals.size(), 1);
  std::vector<Eigen::Vector3d> r(intervals.size());
  Eigen::Matrix<double, kParams, kParams> JtJ;
  double sigma = 0;
  auto evaluate = [&](const Fit& f) {
    for (size_t k = 0; k < intervals.size(); ++k)
      r[k] = residual(intervals[k], f.R_cam_imu, gyroOf(intervals[k], f.bias, f.delay_us));
  };
  auto robustSigma = [&]() {
    std::vector<double> abs_values;
    for (size_t k = 0; k < intervals.size(); ++k)
      if (kept[k])
        for (int j = 0; j < 3; ++j) abs_values.push_back(std::fabs(r[k][j]));
    if (abs_values.empty()) return 0.0;
    std::nth_element(abs_values.begin(), abs_values.begin() + abs_values.size() / 2, abs_values.end());
    return 1.4826 * abs_values[abs_values.size() / 2];
  };
  evaluate(fit);
  for (int iteration = 0; iteration < config.iterations; ++iteration) {
    // Outliers against the current fit (from the first iteration on: the closed form is already close).
    sigma = std::max(robustSigma(), kSigmaFloor);
    for (size_t k = 0; k < intervals.size(); ++k) kept[k] = r[k].cwiseAbs().maxCoeff() <= config.outlier_sigmas * sigma;
    JtJ.setZero();
    Eigen::Matrix<double, kParams, 1> Jtr = Eigen::Matrix<double, kParams, 1>::Zero();
    for (size_t k = 0; k < intervals.size(); ++k) {
      if (!kept[k]) continue;
      const Interval& v = intervals[k];
      const Eigen::Matrix3d G = gyroOf(v, fit.bias, fit.delay_us);
      Eigen::Matrix<double, 3, kParams> J = Eigen::Matrix<double, 3, kParams>::Zero();
      for (int j = 0; j < 3; ++j) {
        const Eigen::Vector3d e = Eigen::Vector3d::Unit(j);
        if (!rotation_known)
          J.col(j) =
              (residual(v, fit.R_cam_imu * expSO3(h_rot * e), G) - residual(v, fit.R_cam_imu * expSO3(-h_rot * e), G)) /
              (2 * h_rot);
        J.col(3 + j) = (residual(v, fit.R_cam_imu, gyroOf(v, fit.bias + h_bias * e, fit.delay_us)) -
                        residual(v, fit.R_cam_imu, gyroOf(v, fit.bias - h_bias * e, fit.delay_us))) /
                       (2 * h_bias);
      }
      J.col(6) = (residual(v, fit.R_cam_imu, gyroOf(v, fit.bias, fit.delay_us + h_delay)) -
                  residual(v, fit.R_cam_imu, gyroOf(v, fit.bias, fit.delay_us - h_delay))) /
                 (2 * h_delay);
      JtJ += J.transpose() * J;
      Jtr += J.transpose() * r[k];
    }
    Eigen::Matrix<double, kParams, 1> step = Eigen::Matrix<double, kParams, 1>::Zero();
    step.tail(fitted) = -JtJ.bottomRightCorner(fitted, fitted).ldlt().solve(Jtr.tail(fitted));
    if (!step.allFinite()) break;
    fit.R_cam_imu = fit.R_cam_imu * expSO3(step.head<3>());
    fit.bias += step.segment<3>(3);
    fit.delay_us += step(6);
    evaluate(fit);
    if (step.head<3>().norm() < 1e-9 && step.segment<3>(3).norm() < 1e-9 && std::fabs(step(6)) < 0.01) break;
  }

  // Figures of the final fit over the intervals kept.
  double sum_sq = 0;
  size_t n = 0;
  for (size_t k = 0; k < intervals.size(); ++k)
    if (kept[k]) {
      sum_sq += r[k].squaredNorm();
      ++n;
    }
  out.intervals = n;
  out.rejected = intervals.size() - n;
  if (n <= static_cast<size_t>(fitted)) {
    out.reason = "too few intervals left after the outliers";
    return out;
  }
  const double variance = sum_sq / static_cast<double>(3 * n - fitted);
  Eigen::Matrix<double, kParams, kParams> covariance = Eigen::Matrix<double, kParams, kParams>::Zero();
  covariance.bottomRightCorner(fitted, fitted) =
      variance * JtJ.bottomRightCorner(fitted, fitted).ldlt().solve(Eigen::MatrixXd::Identity(fitted, fitted));
  out.residual_rms_deg = std::sqrt(sum_sq / static_cast<double>(3 * n)) / kDeg;
  out.R_imu_cam = fit.R_cam_imu.transpose();
  // The perturbation is on the right of R_cam_imu, i.e. in the IMU frame.
  for (int j = 0; j < 3; ++j) out.rotation_sigma_deg[j] = std::sqrt(std::max(0.0, covariance(j, j))) / kDeg;
  out.gyro_bias = fit.bias;
  out.delay_us = fit.delay_us;
  out.delay_sigma_us = std::sqrt(std::max(0.0, covariance(6, 6)));
  out.ok = covariance.allFinite();
  if (!out.ok) out.reason = "the fit did not converge";
  return out;
}

}  // namespace ips::calib
