#include "ips/tracker/stereo_tracker.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "ips/log.hpp"
#include "ips/tracker/corners.hpp"

namespace ips::tracker {

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

Eigen::Matrix<double, 6, 6> blockRotation(const Eigen::Matrix3d& R) {
  Eigen::Matrix<double, 6, 6> b = Eigen::Matrix<double, 6, 6>::Zero();
  b.topLeftCorner<3, 3>() = R;
  b.bottomRightCorner<3, 3>() = R;
  return b;
}

cv::Mat toGray(const cv::Mat& img, const cv::Size& size, const char* which) {
  if (img.empty()) throw std::invalid_argument(std::string("StereoTracker: empty ") + which + " image");
  if (img.size() != size)
    throw std::invalid_argument(std::string("StereoTracker: ") + which + " image is " + std::to_string(img.cols) + "x" +
                                std::to_string(img.rows) + ", calibration says " + std::to_string(size.width) + "x" +
                                std::to_string(size.height));
  if (img.type() == CV_8UC1) return img;
  cv::Mat gray;
  if (img.type() == CV_8UC3)
    cv::cvtColor(img, gray, cv::COLOR_BGR2GRAY);
  else if (img.type() == CV_8UC4)
    cv::cvtColor(img, gray, cv::COLOR_BGRA2GRAY);
  else
    throw std::invalid_argument(std::string("StereoTracker: ") + which + " image must be 8-bit grey or colour");
  return gray;
}

}  // namespace

Eigen::Vector3d TrackResult::rotationVector() const { return logSO3(rotation.toRotationMatrix()); }

FusedIncrement fuseFarRotation(const TrackResult& r, double gate_chi2) {
  FusedIncrement out;
  out.rotation = r.rotation;
  out.translation = r.translation;
  out.covariance = r.covariance;
  if (!r.valid || !r.far_valid) return out;
  // Measurement z = far rotation of the state [t, r] (r: right perturbation of the increment's rotation):
  // residual Log(R^T R_far), H = [0 I].
  const Eigen::Vector3d residual =
      logSO3(r.rotation.toRotationMatrix().transpose() * r.far_rotation.toRotationMatrix());
  const Eigen::Matrix3d S = r.covariance.bottomRightCorner<3, 3>() + r.far_covariance;
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(S);
  if (ldlt.info() != Eigen::Success) return out;
  if (!(residual.dot(ldlt.solve(residual)) < gate_chi2)) return out;
  const Eigen::Matrix<double, 6, 3> K = r.covariance.rightCols<3>() * ldlt.solve(Eigen::Matrix3d::Identity());
  const Eigen::Matrix<double, 6, 1> dx = K * residual;
  out.translation = r.translation + dx.head<3>();
  out.rotation = Eigen::Quaterniond(r.rotation.toRotationMatrix() * expSO3(dx.tail<3>())).normalized();
  out.covariance = r.covariance - K * r.covariance.bottomRows<3>();
  out.covariance = 0.5 * (out.covariance + out.covariance.transpose()).eval();
  out.far_used = true;
  return out;
}

MotionPrior MotionPrior::fromFilter(const Eigen::Matrix3d& R, const Eigen::Vector3d& t, const Matrix6d& cov) {
  MotionPrior p;
  p.source = Source::Filter;
  p.R = R;
  p.t = t;
  p.covariance = cov;
  return p;
}

MotionPrior MotionPrior::fromImuRates(const Eigen::Vector3d& omega_imu, const Eigen::Matrix3d& R_imu_cam0, double dt_s,
                                      double omega_sigma, const PriorParams& params) {
  MotionPrior p;
  p.source = Source::Imu;
  const Eigen::Vector3d omega_cam = R_imu_cam0.transpose() * omega_imu;
  p.R = expSO3(omega_cam * dt_s);
  p.t.setZero();
  p.covariance.setZero();
  const double st = params.imu_translation_sigma_per_s * dt_s;
  const double sr = std::hypot(omega_sigma * dt_s, params.imu_rotation_sigma);
  p.covariance.diagonal() << st * st, st * st, st * st, sr * sr, sr * sr, sr * sr;
  return p;
}

StereoTracker::StereoTracker(const StereoCalibration& calib, const TrackerParams& params)
    : params_(params), calib_(calib), offset_(params.disparity_offset) {
  if (calib.cam0.width <= 0 || calib.cam0.height <= 0 || calib.cam0.width != calib.cam1.width ||
      calib.cam0.height != calib.cam1.height)
    throw std::invalid_argument("StereoTracker: both cameras need the same positive image size");
  if (!(calib.baseline() > 0)) throw std::invalid_argument("StereoTracker: zero baseline");
  if (params.matcher.ncc_half_window < 1 || params.matcher.ncc_half_window > 15)
    throw std::invalid_argument("StereoTracker: ncc_half_window must be in 1..15");
  rect_ = computeRectification(calib, params.rectification_alpha);
  stereo_.f = rect_.f;
  stereo_.cx = rect_.cx;
  stereo_.cy = rect_.cy;
  stereo_.baseline = rect_.baseline;
  stereo_.disparity_offset = offset_.inUse();
  if (!(stereo_.f > 0) || !(stereo_.baseline > 0))
    throw std::invalid_argument("StereoTracker: rectification failed (check R_cam1_cam0, t_cam1_cam0)");
  // Fixed-point tables remap several times faster than float maps, at 1/32 px interpolation steps.
  cv::convertMaps(rect_.map0x, rect_.map0y, map0a_, map0b_, CV_16SC2);
  cv::convertMaps(rect_.map1x, rect_.map1y, map1a_, map1b_, CV_16SC2);
}

void StereoTracker::setRightCorrection(const RightCameraCorrection& correction) {
  const StereoRectification rect = computeRectification(calib_, params_.rectification_alpha, correction);
  rect_.R_rect1_cam1 = rect.R_rect1_cam1;
  rect_.map1x = rect.map1x;
  rect_.map1y = rect.map1y;
  cv::convertMaps(rect_.map1x, rect_.map1y, map1a_, map1b_, CV_16SC2);
  right_correction_ = correction;
}

void StereoTracker::reset() {
  ref_.reset();
  cur_ = std::make_shared<Frame>();
  have_velocity_ = false;
  stats_ = PredictionStats();
}

std::vector<Prediction> StereoTracker::predict(const RigidMotion& m, const Matrix6d& cov, bool have_prior) const {
  const MatcherParams& mp = params_.matcher;
  std::vector<Prediction> out(ref_->features.size());
  // Image-space 1-sigma of the prediction: rotation moves every point by about f * angle, translation by
  // f * shift / depth.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> rot_eig(cov.bottomRightCorner<3, 3>(), Eigen::EigenvaluesOnly);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> tr_eig(cov.topLeftCorner<3, 3>(), Eigen::EigenvaluesOnly);
  const double sigma_rot = std::sqrt(std::max(0.0, rot_eig.eigenvalues().maxCoeff()));
  const double sigma_tr = std::sqrt(std::max(0.0, tr_eig.eigenvalues().maxCoeff()));
  // In inverse depth, so that points at infinity (disparity 0 or, by noise, below) are predicted too: a point
  // X = a / rho (a = ((xl - cx) / f, (y - cy) / f, 1)) is seen at the newer time along v = R^T (a - rho t), with
  // inverse depth rho / v_z.
  const double fb = stereo_.f * stereo_.baseline;
  const StereoFeatures& fs = ref_->features;
  for (size_t i = 0; i < out.size(); ++i) {
    const Eigen::Vector3d a = stereo_.ray(fs.xl[i], fs.y[i]);
    const double rho = stereo_.inverseDepth(fs.xl[i], fs.xr[i]);
    const Eigen::Vector3d v = m.R.transpose() * (a - rho * m.t);
    Prediction& q = out[i];
    // Behind the camera or nearer than 5 cm (v_z / rho is the depth): nothing to search.
    if (v.z() <= 1e-3 || (rho > 0 && v.z() <= 0.05 * rho)) {
      q.radius = 0;
      continue;
    }
    const double rho_now = rho / v.z();
    q.xl = stereo_.f * v.x() / v.z() + stereo_.cx;
    q.y = stereo_.f * v.y() / v.z() + stereo_.cy;
    q.xr = q.xl - fb * rho_now + stereo_.disparity_offset;
    if (!have_prior) {
      q.radius = mp.window_max_px;
    } else {
      const double sigma_px = stereo_.f * (sigma_rot + sigma_tr * std::max(0.0, rho_now));
      q.radius = std::clamp(mp.window_min_px + mp.window_sigma_scale * sigma_px, double(mp.window_min_px),
                            double(mp.window_max_px));
    }
  }
  return out;
}

std::vector<Correspondence> StereoTracker::correspondences(const std::vector<InterMatch>& matches,
                                                           std::vector<Correspondence>* far) const {
  std::vector<Correspondence> out;
  out.reserve(matches.size());
  if (far) far->clear();
  // Depth within max_depth <=> disparity at least f b / max_depth.
  const double near_disparity = stereo_.f * stereo_.baseline / params_.motion.max_depth;
  for (const InterMatch& m : matches) {
    Correspondence c;
    c.prev = m.prev_obs;
    c.now = m.now_obs;
    c.id = m.prev;
    const double off = stereo_.disparity_offset;
    const bool near = c.prev.xl - c.prev.xr + off >= near_disparity && c.now.xl - c.now.xr + off >= near_disparity;
    if (!near) {
      if (far) far->push_back(c);
      continue;
    }
    // Triangulated again rather than taken from the reference pair: the disparity offset may have changed since.
    c.p_prev = stereo_.triangulate(c.prev.xl, c.prev.y, c.prev.xr);
    c.p_now = stereo_.triangulate(c.now.xl, c.now.y, c.now.xr);
    out.push_back(c);
  }
  return out;
}

void StereoTracker::updateDisparityOffset(const std::vector<Correspondence>& corr, const MotionEstimate& est,
                                          TrackResult& res) {
  res.disparity_offset_used_px = stereo_.disparity_offset;
  if (!params_.disparity_offset.estimate) return;
  const DisparityOffsetObservation obs = observeDisparityOffset(stereo_, corr, est.inliers, est.motion, params_.motion);
  if (!obs.valid) return;
  const DisparityOffsetEstimator::Outcome o = offset_.add(obs.correction_px, obs.variance_px2);
  res.disparity_offset_observed = o.observed;
  res.disparity_offset_rejected = o.refused;
  res.disparity_offset_applied = o.applied;
  if (o.applied) offset_applied_utime_ = res.utime;
  stereo_.disparity_offset = offset_.inUse();
}

TrackResult StereoTracker::process(int64_t utime, const cv::Mat& left_raw, const cv::Mat& right_raw,
                                   const MotionPrior* prior, const DisparityGuide* guide) {
  const auto t_start = Clock::now();
  const cv::Size size(calib_.cam0.width, calib_.cam0.height);
  const cv::Mat left = toGray(left_raw, size, "left"), right = toGray(right_raw, size, "right");
  TrackResult res;
  res.utime = utime;

  cur_ = std::make_shared<Frame>();
  cur_->utime = utime;
  auto t0 = Clock::now();
  cv::remap(left, cur_->left, map0a_, map0b_, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::remap(right, cur_->right, map1a_, map1b_, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
  res.times.rectify = msSince(t0);

  t0 = Clock::now();
  const int margin = params_.detector.border + params_.matcher.ncc_half_window + 1;
  cur_->corners = detectCorners(cur_->left, params_.detector, margin);
  const std::vector<Corner>& corners = cur_->corners;
  res.num_features = int(corners.size());
  res.times.detect = msSince(t0);

  t0 = Clock::now();
  if (guide) {
    std::vector<Corner> unguided;
    cur_->features =
        matchWithDisparity(cur_->left, cur_->right, corners, *guide, params_.matcher, &unguided, &res.guided_intra);
    appendFeatures(cur_->features, matchAlongRows(cur_->left, cur_->right, unguided, params_.matcher));
    res.intra_guided = true;
  } else {
    cur_->features = matchAlongRows(cur_->left, cur_->right, corners, params_.matcher);
  }
  cur_->valid = true;
  res.num_intra_matches = int(cur_->features.size());
  res.times.intra = msSince(t0);

  // A pair with too few stereo features (blur, a blank wall, a dropped exposure) cannot be a reference:
  // the previous reference stays, and the next good pair is measured against it (utime_prev says so).
  const bool usable = int(cur_->features.size()) >= params_.motion.min_inliers;
  if (!ref_ || utime <= ref_->utime) {
    if (ref_) IPS_WARN("tracker: image time " << utime << " does not follow " << ref_->utime << "; restarting");
    have_velocity_ = false;
    res.utime_prev = ref_ ? ref_->utime : 0;
    if (usable || (ref_ && utime <= ref_->utime)) ref_ = usable ? cur_ : nullptr;
    res.times.total = msSince(t_start);
    return res;
  }
  if (!usable) {
    res.utime_prev = ref_->utime;
    res.times.total = msSince(t_start);
    return res;
  }
  res.utime_prev = ref_->utime;
  const double dt_s = double(utime - ref_->utime) * 1e-6;

  // The prior, in the rectified frame: the one given (the filter's, the gyro's), else the tracker's own last motion.
  MotionPrior own_motion;
  if (have_velocity_ && dt_s <= params_.prior.max_interval_s && last_dt_s_ > 0) {
    const double scale = dt_s / last_dt_s_;
    own_motion.source = MotionPrior::Source::ConstantVelocity;
    own_motion.R = expSO3(scale * logSO3(last_delta_.R));
    own_motion.t = scale * last_delta_.t;
    own_motion.covariance.setZero();
    const double st = params_.prior.cv_translation_sigma_per_s * dt_s;
    const double sr = params_.prior.cv_rotation_sigma_per_s * dt_s;
    own_motion.covariance.diagonal() << st * st, st * st, st * st, sr * sr, sr * sr, sr * sr;
  }
  const MotionPrior used = prior ? *prior : own_motion;
  const bool have_prior = used.source != MotionPrior::Source::None;
  res.prior_source = used.source;
  const Eigen::Matrix3d& Rr = rect_.R_rect0_cam0;
  RigidMotion prior_rect;
  prior_rect.R = Rr * used.R * Rr.transpose();
  prior_rect.t = Rr * used.t;
  const Matrix6d cov_rect = blockRotation(Rr) * used.covariance * blockRotation(Rr).transpose();

  t0 = Clock::now();
  std::vector<Prediction> pred = predict(prior_rect, cov_rect, have_prior);
  std::vector<InterMatch> matches =
      matchBetweenTimes(ref_->features, cur_->features, pred, cur_->left, cur_->right, params_.matcher);
  res.times.inter = msSince(t0);

  t0 = Clock::now();
  std::vector<Correspondence> far;
  std::vector<Correspondence> corr = correspondences(matches, &far);
  MotionEstimate est = estimateMotion(stereo_, corr, params_.motion);
  res.num_inter_matches = int(matches.size());
  res.times.motion = msSince(t0);

  // A prior that was confidently wrong (a filter gone astray, a jolt the IMU rates did not foresee) leaves
  // the small windows empty: search again with the widest windows. Around the tracker's own last motion when the
  // prior came from outside: a filter that has lost its velocity (IMU messages lost on a starved host) predicts
  // where nothing is, and its next prior would be as wrong; without the images' own evidence the filter never
  // gets a delta to recover from.
  const std::vector<Prediction> pred_prior = pred;
  if (!est.valid && have_prior) {
    t0 = Clock::now();
    const bool around_own_motion = prior && own_motion.source == MotionPrior::Source::ConstantVelocity;
    const RigidMotion retry_rect =
        around_own_motion ? RigidMotion{Rr * own_motion.R * Rr.transpose(), Rr * own_motion.t} : prior_rect;
    pred = predict(retry_rect, cov_rect, false);
    res.retry_around_own_motion = around_own_motion;
    matches = matchBetweenTimes(ref_->features, cur_->features, pred, cur_->left, cur_->right, params_.matcher);
    res.times.inter += msSince(t0);
    t0 = Clock::now();
    corr = correspondences(matches, &far);
    est = estimateMotion(stereo_, corr, params_.motion);
    res.num_inter_matches = int(matches.size());
    res.times.motion += msSince(t0);
    res.wide_retry = true;
  }

  // A wide first window admits look-alikes and misses features that did not make the first pass's
  // uniqueness test; matching again tightly around the first estimate recovers them.
  std::vector<Correspondence> corr2;
  bool est_from_guided = false;
  double max_radius = 0;
  for (const Prediction& q : pred) max_radius = std::max(max_radius, q.radius);
  if (est.valid && max_radius > 2.0 * params_.matcher.guided_window_px) {
    t0 = Clock::now();
    Matrix6d tight = Matrix6d::Zero();
    std::vector<Prediction> pred2 = predict(est.motion, tight, true);
    for (Prediction& q : pred2)
      if (q.radius > 0) q.radius = params_.matcher.guided_window_px;
    std::vector<InterMatch> matches2 =
        matchBetweenTimes(ref_->features, cur_->features, pred2, cur_->left, cur_->right, params_.matcher);
    res.times.inter += msSince(t0);
    t0 = Clock::now();
    std::vector<Correspondence> far2;
    corr2 = correspondences(matches2, &far2);
    MotionEstimate est2 = estimateMotion(stereo_, corr2, params_.motion);
    res.times.motion += msSince(t0);
    res.guided_pass = true;
    if (est2.valid && est2.inliers.size() >= est.inliers.size()) {
      est = est2;
      est_from_guided = true;
      res.num_inter_matches = int(matches2.size());
      far = std::move(far2);
    }
  }

  res.valid = est.valid;
  res.num_inliers = int(est.inliers.size());
  // The prediction was right where the final inliers lie within prior_ok_px of where the prior put them
  // (matches inside a wrongly placed window are look-alikes that RANSAC throws out).
  if (est.valid) {
    const std::vector<Correspondence>& used_corr = res.guided_pass && est_from_guided ? corr2 : corr;
    for (int i : est.inliers) {
      const Correspondence& c = used_corr[i];
      const Prediction& q = pred_prior[c.id];
      res.num_predictions_ok += std::abs(c.now.xl - q.xl) <= params_.matcher.prior_ok_px &&
                                std::abs(c.now.y - q.y) <= params_.matcher.prior_ok_px;
    }
    res.prediction_ok_ratio = double(res.num_predictions_ok) / double(est.inliers.size());
    updateDisparityOffset(used_corr, est, res);
  }
  res.disparity_offset_px = offset_.estimate();
  res.disparity_offset_sigma_px = offset_.sigma();
  res.prior_ok = have_prior && est.valid && res.prediction_ok_ratio >= params_.matcher.prior_ok_fraction;
  if (have_prior) {
    stats_.frames_with_prior++;
    stats_.frames_prior_ok += res.prior_ok ? 1 : 0;
    stats_.matches += res.num_inliers;
    stats_.matches_ok += res.num_predictions_ok;
  }
  if (est.valid) {
    const Eigen::Matrix3d R_cam = Rr.transpose() * est.motion.R * Rr;
    res.translation = Rr.transpose() * est.motion.t;
    res.rotation = Eigen::Quaterniond(R_cam).normalized();
    res.covariance = blockRotation(Rr.transpose()) * est.covariance * blockRotation(Rr);
    res.residual_rms = est.residual_rms_m;
    res.residual_rms_px = est.residual_rms_px;
    have_velocity_ = true;
    last_delta_.R = R_cam;
    last_delta_.t = res.translation;
    last_dt_s_ = dt_s;
  } else {
    have_velocity_ = false;
  }
  // The rotation from far points, with the translation's parallax on them taken out by the 6-DoF estimate's
  // translation (else the prior's, else none with the prior's own translation uncertainty per second).
  res.num_far_matches = int(far.size());
  if (params_.far.enabled && !far.empty()) {
    t0 = Clock::now();
    Eigen::Vector3d t_far = Eigen::Vector3d::Zero();
    Eigen::Matrix3d t_far_cov =
        Eigen::Matrix3d::Identity() * std::pow(params_.prior.imu_translation_sigma_per_s * dt_s, 2);
    if (est.valid) {
      t_far = est.motion.t;
      t_far_cov = est.covariance.topLeftCorner<3, 3>();
    } else if (have_prior) {
      t_far = prior_rect.t;
      t_far_cov = cov_rect.topLeftCorner<3, 3>();
    }
    const FarRotationEstimate fr = estimateFarRotation(stereo_, far, t_far, t_far_cov, params_.motion, params_.far);
    res.far_valid = fr.valid;
    res.num_far_inliers = int(fr.inliers.size());
    if (fr.valid) {
      res.far_rotation = Eigen::Quaterniond(Rr.transpose() * fr.R * Rr).normalized();
      res.far_covariance = Rr.transpose() * fr.covariance * Rr;
      res.far_residual_rms_px = fr.residual_rms_px;
    }
    res.times.motion += msSince(t0);
  }
  ref_ = cur_;  // the new pair is the reference for the next, also after a failed match: it recovers there
  res.times.total = msSince(t_start);
  return res;
}

}  // namespace ips::tracker
