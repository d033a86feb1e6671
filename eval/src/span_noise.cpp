#include "ips/eval/span_noise.hpp"

#include <Eigen/QR>
#include <algorithm>
#include <array>
#include <stdexcept>

namespace ips::eval {
namespace {

constexpr int kBasis = 5;  // the IMU's world accelerations, then the bias's three body axes, then gravity's error

// The IMU's accelerations integrated twice from rest at the origin (the true start's position and velocity drop out
// of every second difference), for the measured specific force and for each unit of the fitted errors. The
// acceleration is linear between samples, as in the trapezoidal rule.
class DoubleIntegral {
 public:
  DoubleIntegral(const std::vector<filter::ImuSample>& imu, const Trajectory& truth, double gravity) {
    t_.reserve(imu.size());
    for (const auto& s : imu) {
      const double t = s.utime * 1e-6;
      const Eigen::Matrix3d R_wb = interpolate(truth, t).q.toRotationMatrix();
      std::array<Eigen::Vector3d, kBasis> a;
      a[0] = R_wb * s.specific_force - Eigen::Vector3d(0, 0, gravity);
      for (int j = 0; j < 3; ++j) a[1 + j] = -R_wb.col(j);  // f_true = f_measured - bias
      a[4] = -Eigen::Vector3d::UnitZ();                     // g_true = gravity + error
      t_.push_back(t);
      a_.push_back(a);
    }
    p_.resize(t_.size());
    v_.resize(t_.size());
    for (int b = 0; b < kBasis; ++b) {
      p_[0][b].setZero();
      v_[0][b].setZero();
    }
    for (size_t i = 0; i + 1 < t_.size(); ++i) {
      const double dt = t_[i + 1] - t_[i];
      for (int b = 0; b < kBasis; ++b) {
        p_[i + 1][b] = p_[i][b] + v_[i][b] * dt + (2 * a_[i][b] + a_[i + 1][b]) * dt * dt / 6;
        v_[i + 1][b] = v_[i][b] + 0.5 * (a_[i][b] + a_[i + 1][b]) * dt;
      }
    }
  }
  double first() const { return t_.front(); }
  double last() const { return t_.back(); }
  // The position of every basis at time t (first() <= t <= last()).
  std::array<Eigen::Vector3d, kBasis> at(double t) const {
    size_t i = std::upper_bound(t_.begin(), t_.end(), t) - t_.begin();
    i = i == 0 ? 0 : std::min(i - 1, t_.size() - 2);
    const double dt = t_[i + 1] - t_[i], tau = t - t_[i];
    std::array<Eigen::Vector3d, kBasis> p;
    for (int b = 0; b < kBasis; ++b)
      p[b] =
          p_[i][b] + v_[i][b] * tau + a_[i][b] * tau * tau / 2 + (a_[i + 1][b] - a_[i][b]) * tau * tau * tau / (6 * dt);
    return p;
  }

 private:
  std::vector<double> t_;
  std::vector<std::array<Eigen::Vector3d, kBasis>> a_, p_, v_;
};

// The second difference through three samples scaled to the one of equal sides: exact for a constant acceleration
// a (a T^2 with T their mean side), zero for any position and velocity.
Eigen::Vector3d secondDifference(double t1, double t2, double t3, const Eigen::Vector3d& p1, const Eigen::Vector3d& p2,
                                 const Eigen::Vector3d& p3) {
  const double h1 = t2 - t1, h2 = t3 - t2;
  return ((p3 - p2) / h2 - (p2 - p1) / h1) * (h1 + h2) / 2;
}

// The variance of each axis of rows of 3-vectors (each axis's mean removed).
Eigen::Vector3d axisVariances(const std::vector<Eigen::Vector3d>& x) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& v : x) mean += v / static_cast<double>(x.size());
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& v : x) sum += (v - mean).cwiseAbs2();
  return sum / static_cast<double>(x.size() - 1);
}

// The same averaged over the axes.
double axisVariance(const std::vector<Eigen::Vector3d>& x) { return axisVariances(x).mean(); }

double rmsOrNan(double variance) { return variance >= 0 ? std::sqrt(variance) : NAN; }

}  // namespace

double imuWhiteNoiseSecondDifference(double density, double span_s) {
  return density * std::sqrt(2.0 * span_s * span_s * span_s / 3.0);
}

std::vector<SpanNoise> spanNoise(const SpanNoiseInput& in, const std::vector<int>& spans_frames) {
  const bool with_estimate = !in.estimate.empty();
  if (in.truth.size() < 3 || (with_estimate && in.estimate.size() < 3) || in.imu.size() < 3)
    throw std::invalid_argument("spanNoise: the truth, the estimate (if any) and the IMU need three samples each");
  // The samples the second differences are taken at: the estimate's, camera 0 carried to the body with its own
  // attitude and put into the truth's world; without an estimate the truth's own.
  Trajectory est;
  if (!with_estimate) {
    est = in.truth;
  } else {
    Trajectory ref;
    associate(rigidlyAttached(in.estimate, in.T_imu_cam0.inverse()), in.truth, 0.1, &est, &ref);
    if (est.size() < 3)
      throw std::invalid_argument("spanNoise: the estimate and the truth overlap in fewer than 3 samples");
    const Eigen::Isometry3d T = alignSE3(est, ref);
    for (TrajPoint& p : est) p.p = T * p.p;
  }

  std::vector<double> intervals;
  for (size_t k = 1; k < est.size(); ++k) intervals.push_back(est[k].t - est[k - 1].t);
  std::nth_element(intervals.begin(), intervals.begin() + intervals.size() / 2, intervals.end());
  const double h = intervals[intervals.size() / 2];
  const DoubleIntegral imu(in.imu, in.truth, in.gravity);

  std::vector<SpanNoise> out;
  for (int m : spans_frames) {
    if (m < 1) throw std::invalid_argument("spanNoise: a span must be at least one sample");
    std::vector<Eigen::Vector3d> a, b;
    std::vector<std::array<Eigen::Vector3d, kBasis>> c;
    std::vector<double> spans;
    for (size_t k = m; k + m < est.size(); ++k) {
      const double t1 = est[k - m].t, t2 = est[k].t, t3 = est[k + m].t;
      // Both sides m intervals long (a lost pair makes a gap) and inside the IMU's record.
      if (std::abs(t2 - t1 - m * h) > 0.5 * h || std::abs(t3 - t2 - m * h) > 0.5 * h) continue;
      if (t1 < imu.first() || t3 > imu.last()) continue;
      a.push_back(secondDifference(t1, t2, t3, interpolate(in.truth, t1).p, interpolate(in.truth, t2).p,
                                   interpolate(in.truth, t3).p));
      b.push_back(secondDifference(t1, t2, t3, est[k - m].p, est[k].p, est[k + m].p));
      const auto p1 = imu.at(t1), p2 = imu.at(t2), p3 = imu.at(t3);
      std::array<Eigen::Vector3d, kBasis> ci;
      for (int j = 0; j < kBasis; ++j) ci[j] = secondDifference(t1, t2, t3, p1[j], p2[j], p3[j]);
      c.push_back(ci);
      spans.push_back((t3 - t1) / 2);
    }
    if (a.size() < 10) continue;
    const int n = static_cast<int>(a.size());
    Eigen::MatrixXd M(3 * n, kBasis - 1);
    Eigen::VectorXd y(3 * n);
    for (int i = 0; i < n; ++i) {
      for (int j = 1; j < kBasis; ++j) M.block<3, 1>(3 * i, j - 1) = c[i][j];
      y.segment<3>(3 * i) = 0.5 * (a[i] + b[i]) - c[i][0];
    }
    const Eigen::VectorXd x = M.colPivHouseholderQr().solve(y);
    std::vector<Eigen::Vector3d> ab, ac, bc;
    for (int i = 0; i < n; ++i) {
      Eigen::Vector3d ci = c[i][0];
      for (int j = 1; j < kBasis; ++j) ci += x(j - 1) * c[i][j];
      ab.push_back(a[i] - b[i]);
      ac.push_back(a[i] - ci);
      bc.push_back(b[i] - ci);
    }
    const double v_ab = axisVariance(ab), v_ac = axisVariance(ac), v_bc = axisVariance(bc);
    SpanNoise s;
    s.span_frames = m;
    std::nth_element(spans.begin(), spans.begin() + spans.size() / 2, spans.end());
    s.span_s = spans[spans.size() / 2];
    s.centres = a.size();
    s.truth_vs_imu = std::sqrt(v_ac);
    s.truth_vs_imu_axes = axisVariances(ac).cwiseSqrt();
    if (with_estimate) {
      s.truth_vs_estimate = std::sqrt(v_ab);
      s.estimate_vs_imu = std::sqrt(v_bc);
      s.truth = rmsOrNan((v_ab + v_ac - v_bc) / 2);
      s.estimate = rmsOrNan((v_ab + v_bc - v_ac) / 2);
      s.imu = rmsOrNan((v_ac + v_bc - v_ab) / 2);
    }
    s.accel_bias = x.head<3>();
    s.gravity_error = x(3);
    out.push_back(s);
  }
  return out;
}

}  // namespace ips::eval
