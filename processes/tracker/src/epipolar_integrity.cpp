#include "ips/tracker/epipolar_integrity.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ips::tracker {

namespace {

constexpr double kDeg = M_PI / 180;

void readPositive(const Config& c, const std::string& key, double& v) {
  v = c.getDouble(key, v);
  if (!(v > 0)) throw ConfigError(c.path() + ": key '" + key + "' must be positive");
}

void readAtLeast(const Config& c, const std::string& key, int& v, int min_value) {
  v = c.getInt(key, v);
  if (v < min_value) throw ConfigError(c.path() + ": key '" + key + "' must be >= " + std::to_string(min_value));
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  return v[mid];
}

}  // namespace

IntegrityParams loadIntegrityParams(const Config& c) {
  IntegrityParams p;
  p.enabled = c.getBool("integrity/enabled", p.enabled);
  readAtLeast(c, "integrity/max_probes", p.max_probes, 1);
  readPositive(c, "integrity/max_rate_hz", p.max_rate_hz);
  readAtLeast(c, "integrity/search_rows", p.search_rows, 1);
  p.min_ncc = c.getDouble("integrity/min_ncc", p.min_ncc);
  p.uniqueness = c.getDouble("integrity/uniqueness", p.uniqueness);
  readAtLeast(c, "integrity/min_points", p.min_points, 8);
  readPositive(c, "integrity/outlier_sigmas", p.outlier_sigmas);
  readPositive(c, "integrity/point_sigma_floor_px", p.point_sigma_floor_px);
  readPositive(c, "integrity/initial_rotation_sigma_deg", p.initial_rotation_sigma_deg);
  readPositive(c, "integrity/initial_focal_sigma", p.initial_focal_sigma);
  readPositive(c, "integrity/rotation_walk_deg_sqrt_s", p.rotation_walk_deg_sqrt_s);
  readPositive(c, "integrity/focal_walk_sqrt_s", p.focal_walk_sqrt_s);
  readPositive(c, "integrity/pair_sigma_floor_deg", p.pair_sigma_floor_deg);
  readPositive(c, "integrity/gate_chi2", p.gate_chi2);
  readAtLeast(c, "integrity/step_pairs", p.step_pairs, 1);
  readPositive(c, "integrity/alarm_px", p.alarm_px);
  readAtLeast(c, "integrity/alarm_pairs", p.alarm_pairs, 1);
  readPositive(c, "integrity/certain_px", p.certain_px);
  readPositive(c, "integrity/apply_px", p.apply_px);
  if (!(p.min_ncc > -1 && p.min_ncc < 1) || p.uniqueness < 0)
    throw ConfigError(c.path() + ": integrity/min_ncc must be in (-1, 1), integrity/uniqueness >= 0");
  return p;
}

Eigen::Vector4d toVector(const RightCameraCorrection& c) {
  return {c.rotation.x(), c.rotation.y(), c.rotation.z(), c.focal_scale};
}

RightCameraCorrection toCorrection(const Eigen::Vector4d& v) {
  RightCameraCorrection c;
  c.rotation = v.head<3>();
  c.focal_scale = v[3];
  return c;
}

EpipolarMonitor::EpipolarMonitor(const StereoRectification& rect, const IntegrityParams& params) : params_(params) {
  if (!(rect.f > 0) || rect.size.width < 2 || rect.size.height < 2)
    throw std::invalid_argument("EpipolarMonitor: rectification without a focal length or size");
  if (params.min_points < 8 || !(params.alarm_px > 0) || !(params.apply_px > 0) || !(params.certain_px > 0))
    throw std::invalid_argument("EpipolarMonitor: bad parameters");
  rect_.size = rect.size;
  rect_.f = rect.f;
  rect_.cx = rect.cx;
  rect_.cy = rect.cy;
  rect_.baseline = rect.baseline;
  const double W = rect.size.width - 1, H = rect.size.height - 1;
  for (double fx : {0.0, 0.5, 1.0})
    for (double fy : {0.0, 0.5, 1.0})
      if (fx != 0.5 || fy != 0.5) border_.emplace_back(fx * W, fy * H);
  const double sr = params.initial_rotation_sigma_deg * kDeg;
  P_ = Eigen::Vector4d(sr * sr, sr * sr, sr * sr, params.initial_focal_sigma * params.initial_focal_sigma).asDiagonal();
  status_.covariance = P_;
}

Eigen::Matrix<double, 1, 4> EpipolarMonitor::row(double x, double y) const {
  const double u = (x - rect_.cx) / rect_.f, v = (y - rect_.cy) / rect_.f;
  return rect_.f * Eigen::Matrix<double, 1, 4>(1 + v * v, -u * v, -u, v);
}

double EpipolarMonitor::rowOffset(const Eigen::Vector4d& c, double x, double y) const { return row(x, y) * c; }

double EpipolarMonitor::largestOffset(const Eigen::Vector4d& c) const {
  double m = 0;
  for (const Eigen::Vector2d& b : border_) m = std::max(m, std::abs(rowOffset(c, b.x(), b.y())));
  return m;
}

double EpipolarMonitor::largestSigma(const Eigen::Matrix4d& P) const {
  double m = 0;
  for (const Eigen::Vector2d& b : border_) {
    const Eigen::Matrix<double, 1, 4> h = row(b.x(), b.y());
    m = std::max(m, std::sqrt(std::max(0.0, double(h * P * h.transpose()))));
  }
  return m;
}

Eigen::Matrix<double, 2, 4> EpipolarMonitor::rowAndColumn(double x, double y) const {
  const double u = (x - rect_.cx) / rect_.f, v = (y - rect_.cy) / rect_.f;
  Eigen::Matrix<double, 2, 4> h;
  h.row(0) = row(x, y);
  // The yaw moves rows only (RightCameraCorrection), so it has no column term.
  h.row(1) = rect_.f * Eigen::Matrix<double, 1, 4>(u * v, 0.0, v, u);
  return h;
}

double EpipolarMonitor::largestImageOffset(const Eigen::Vector4d& c) const {
  double m = 0;
  for (const Eigen::Vector2d& b : border_) m = std::max(m, (rowAndColumn(b.x(), b.y()) * c).cwiseAbs().maxCoeff());
  return m;
}

double EpipolarMonitor::largestImageSigma(const Eigen::Matrix4d& P) const {
  double m = 0;
  for (const Eigen::Vector2d& b : border_) {
    const Eigen::Matrix<double, 2, 4> h = rowAndColumn(b.x(), b.y());
    m = std::max(m, (h * P * h.transpose()).diagonal().cwiseMax(0.0).cwiseSqrt().maxCoeff());
  }
  return m;
}

const IntegrityStatus& EpipolarMonitor::update(int64_t utime, const std::vector<VerticalMatch>& matches,
                                               int num_probes) {
  if (utime <= last_utime_) return status_;
  const double dt = last_utime_ > 0 ? (utime - last_utime_) * 1e-6 : 0.0;
  last_utime_ = utime;
  IntegrityStatus& s = status_;
  s.utime = utime;
  s.applied_now = false;
  s.num_probes = num_probes;
  s.num_points = s.num_outliers = 0;
  s.pair_valid = false;
  s.pair_nis = s.pair_chi2 = 0;
  s.dy_median_px = s.dy_rms_px = s.pair_offset_px = 0;

  // The random walk of the correction over dt.
  const double qr = params_.rotation_walk_deg_sqrt_s * kDeg, qs = params_.focal_walk_sqrt_s;
  P_ += Eigen::Vector4d(qr * qr, qr * qr, qr * qr, qs * qs).asDiagonal() * dt;

  // The pair's own estimate of the residual correction (relative to the one in use): robust least squares.
  const int n = int(matches.size());
  std::vector<bool> inlier(n, true);
  Eigen::Vector4d delta = Eigen::Vector4d::Zero();
  Eigen::Matrix4d info = Eigen::Matrix4d::Zero();
  double sigma = params_.point_sigma_floor_px;
  int used = 0;
  for (int iteration = 0; iteration < 3 && n >= params_.min_points; ++iteration) {
    Eigen::Matrix4d A = Eigen::Matrix4d::Zero();
    Eigen::Vector4d b = Eigen::Vector4d::Zero();
    used = 0;
    for (int i = 0; i < n; ++i) {
      if (!inlier[i]) continue;
      const Eigen::Matrix<double, 1, 4> h = row(matches[i].xr, matches[i].y);
      A += h.transpose() * h;
      b += h.transpose() * double(matches[i].dy);
      ++used;
    }
    if (used < params_.min_points) break;
    const Eigen::LDLT<Eigen::Matrix4d> ldlt(A);
    if (ldlt.info() != Eigen::Success || ldlt.rcond() < 1e-9) {
      used = 0;
      break;
    }
    delta = ldlt.solve(b);
    info = A;
    std::vector<double> abs_res;
    abs_res.reserve(n);
    for (int i = 0; i < n; ++i)
      if (inlier[i]) abs_res.push_back(std::abs(matches[i].dy - rowOffset(delta, matches[i].xr, matches[i].y)));
    sigma = std::max(params_.point_sigma_floor_px, 1.4826 * median(abs_res));
    for (int i = 0; i < n; ++i)
      inlier[i] =
          std::abs(matches[i].dy - rowOffset(delta, matches[i].xr, matches[i].y)) <= params_.outlier_sigmas * sigma;
  }
  const Eigen::Vector4d applied = toVector(s.applied);
  if (used >= params_.min_points) {
    std::vector<double> dys;
    double sq = 0;
    for (int i = 0; i < n; ++i)
      if (inlier[i]) {
        dys.push_back(matches[i].dy);
        sq += double(matches[i].dy) * matches[i].dy;
      }
    s.num_points = int(dys.size());
    s.num_outliers = n - s.num_points;
    s.dy_median_px = median(dys);
    s.dy_rms_px = dys.empty() ? 0 : std::sqrt(sq / dys.size());
    s.pair_offset_px = largestOffset(delta);
    s.pair_valid = true;

    // The pair's estimate of the whole correction and its covariance (point scatter, floored per pair).
    const Eigen::Vector4d z = applied + delta;
    const double fr = params_.pair_sigma_floor_deg * kDeg;
    const Eigen::Matrix4d S = sigma * sigma * info.inverse() +
                              Eigen::Vector4d(fr * fr, fr * fr, fr * fr, fr * fr).asDiagonal().toDenseMatrix();
    s.pair_chi2 = delta.dot(S.ldlt().solve(delta));
    recent_.push_back({z, S});
    if (recent_.size() > size_t(std::max(params_.step_pairs, params_.alarm_pairs))) recent_.pop_front();

    // Single pairs scatter with heavier tails than their point noise says (a few points far out in the image's
    // corners carry the u v and v terms), so the decisions below take the mean of the last pairs: a step or a turn is
    // in all of them, a stray pair is diluted. Consecutive pairs see much the same scene, so their errors are
    // taken as correlated: the mean keeps a single pair's covariance.
    const Eigen::Vector4d innovation = z - x_;
    const Eigen::Matrix4d C = P_ + S;
    s.pair_nis = innovation.dot(C.ldlt().solve(innovation));
    if (s.pair_nis <= params_.gate_chi2) {
      outside_run_ = 0;
      kalmanUpdate(z, S);
    } else {
      ++s.pairs_outside_gate;
      if (++outside_run_ >= params_.step_pairs) {
        outside_run_ = 0;
        Eigen::Vector4d zm;
        Eigen::Matrix4d Sm;
        recentMean(params_.step_pairs, zm, Sm);
        const Eigen::Vector4d nu = zm - x_;
        if (nu.dot((P_ + Sm).ldlt().solve(nu)) > params_.gate_chi2) {
          // The head has changed in a step (a knock): start again from these pairs.
          ++s.steps;
          x_ = zm;
          P_ = Sm;
        } else {
          kalmanUpdate(zm, Sm);  // stray pairs whose mean agrees with the estimate
        }
      }
    }

    // Alarm: the rectification in use leaves rows apart beyond alarm_px, and beyond the noise of the recent pairs.
    if (recent_.size() >= size_t(params_.alarm_pairs)) {
      Eigen::Vector4d zm;
      Eigen::Matrix4d Sm;
      recentMean(params_.alarm_pairs, zm, Sm);
      const Eigen::Vector4d dm = zm - applied;
      if (largestOffset(dm) > params_.alarm_px && dm.dot(Sm.ldlt().solve(dm)) > params_.gate_chi2) {
        if (s.state != IntegrityStatus::State::Alarm) {
          s.state = IntegrityStatus::State::Alarm;
          ++s.alarms;
        }
      } else {
        s.state = IntegrityStatus::State::Ok;
      }
    } else if (s.state == IntegrityStatus::State::NoData) {
      s.state = IntegrityStatus::State::Ok;
    }
  } else {
    ++s.pairs_without_measurement;
  }

  s.estimate = toCorrection(x_);
  s.covariance = P_;
  s.estimate_offset_px = largestOffset(x_ - applied);
  // A correction moves the right image's columns as well as its rows (the yaw excepted, RightCameraCorrection), and a
  // column is a disparity: the estimate is certain when its effect on both is known to certain_px everywhere.
  s.estimate_sigma_px = largestImageSigma(P_);
  s.certain = s.estimate_sigma_px < params_.certain_px && outside_run_ == 0;
  if (s.certain && largestImageOffset(x_ - applied) > params_.apply_px) {
    s.applied = s.estimate;
    s.applied_utime = utime;
    s.applied_now = true;
    ++s.corrections;
    s.estimate_offset_px = 0;
  }
  return s;
}

void EpipolarMonitor::kalmanUpdate(const Eigen::Vector4d& z, const Eigen::Matrix4d& S) {
  const Eigen::Matrix4d K = P_ * (P_ + S).inverse();
  x_ += K * (z - x_);
  P_ = (Eigen::Matrix4d::Identity() - K) * P_;
  P_ = 0.5 * (P_ + P_.transpose()).eval();
}

void EpipolarMonitor::recentMean(int pairs, Eigen::Vector4d& z, Eigen::Matrix4d& S) const {
  z.setZero();
  S.setZero();
  const size_t first = recent_.size() - std::min(recent_.size(), size_t(pairs));
  for (size_t i = first; i < recent_.size(); ++i) {
    z += recent_[i].first;
    S += recent_[i].second;
  }
  const double n = double(recent_.size() - first);
  z /= n;
  S /= n;
}

const IntegrityStatus& monitorPair(EpipolarMonitor& monitor, StereoTracker& tracker, int64_t utime) {
  const IntegrityParams& p = monitor.params();
  if (!monitor.due(utime) || tracker.rectifiedLeft().empty()) return monitor.status();
  const std::vector<Corner>& all = tracker.corners();
  std::vector<Corner> probes;
  const size_t n = std::min(all.size(), size_t(p.max_probes));
  probes.reserve(n);
  for (size_t i = 0; i < n; ++i) probes.push_back(all[i * all.size() / n]);
  const std::vector<VerticalMatch> matches =
      matchAcrossRows(tracker.rectifiedLeft(), tracker.rectifiedRight(), probes, tracker.params().matcher, p);
  const IntegrityStatus& s = monitor.update(utime, matches, int(probes.size()));
  if (s.applied_now) tracker.setRightCorrection(s.applied);
  return s;
}

}  // namespace ips::tracker
