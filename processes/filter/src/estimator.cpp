#include "ips/filter/estimator.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <type_traits>

#include "ips/filter/motion_start.hpp"
#include "ips/filter/optional_states.hpp"
#include "ips/log.hpp"

namespace ips::filter {

namespace {

// A measurement covariance made symmetric, its standard deviations floored at min_sigma (a tracker's covariance from
// many points can claim more than its model errors allow).
template <int N>
Eigen::Matrix<double, N, N> symmetrisedWithFloor(const Eigen::Matrix<double, N, N>& c,
                                                 const Eigen::Matrix<double, N, 1>& min_sigma) {
  Eigen::Matrix<double, N, N> out = 0.5 * (c + c.transpose());
  for (int k = 0; k < N; ++k) out(k, k) = std::max(out(k, k), min_sigma(k) * min_sigma(k));
  return out;
}

constexpr double kInf = std::numeric_limits<double>::infinity();

}  // namespace

Matrix21d initialCovariance(const InitParams& ip) {
  Vector21d sd;
  sd << Eigen::Vector3d::Constant(ip.sigma_position), Eigen::Vector3d::Constant(ip.sigma_velocity),
      Eigen::Vector3d::Constant(ip.sigma_acceleration), Eigen::Vector3d::Constant(ip.sigma_accel_bias),
      Eigen::Vector3d::Constant(ip.sigma_angular_rate), Eigen::Vector3d::Constant(ip.sigma_gyro_bias),
      ip.sigma_roll_pitch, ip.sigma_roll_pitch, ip.sigma_heading;
  return sd.cwiseAbs2().asDiagonal();
}

Estimator::Estimator(const FilterParams& params, const StereoCalibration& calib)
    : params_(withHeadSensors(params, calib)),
      T_imu_cam0_(calib.T_imu_cam0),
      camera_delay_(params.camera_delay, calib.T_imu_cam0.linear(), params.camera_latency_us),
      R_body_tilt_(calib.T_imu_cam0.linear() * calib.R_tilt_cam0.transpose()) {
  run_.kf = makeKalmanFilter(params_);
  run_.counts = true;
  run_.motion = MotionNoise(params_.process, params_.imu);
  gyro_sigma_ = params_.imu.gyro_noise_density * std::sqrt(params_.imu.rate_hz);
  accel_sigma_ = params_.imu.accel_noise_density * std::sqrt(params_.imu.rate_hz);
  gate2_ = chiSquareQuantile(params_.gate_probability, 2);
  gate6_ = chiSquareQuantile(params_.gate_probability, 6);
  const char* names[kNumSensors] = {"imu", "tilt", "tracker", "image", "far_rotation", "cloud"};
  for (int i = 0; i < kNumSensors; ++i) counters_[i].name = names[i];
}

void Estimator::initialize(const NavState& state, const Matrix21d& covariance) {
  FullState x;
  x.nav = state;
  Eigen::MatrixXd P = covariance;
  // The states of the head's calibration (lever arm, the tracker's scale, the tilt sensor's offsets, the camera's
  // alignment) keep over a restart what they have learnt: they do not change with the navigation state.
  const KalmanFilter& kf = *run_.kf;
  // One state of `dim` error dimensions: its value and covariance block from the running filter where it has one,
  // else `start` with sigma on each dimension; appended to P in the error state's order.
  auto keep = [&](auto& value, const auto& learnt_value, const auto& start, int learnt_offset, int dim, double sigma) {
    const bool learnt = initialized_ && learnt_value.has_value();
    value = learnt ? *learnt_value : start;
    const int n = int(P.rows());
    P.conservativeResizeLike(Eigen::MatrixXd::Zero(n + dim, n + dim));
    P.bottomRightCorner(dim, dim) = learnt
                                        ? Eigen::MatrixXd(kf.covariance().block(learnt_offset, learnt_offset, dim, dim))
                                        : Eigen::MatrixXd(Eigen::MatrixXd::Identity(dim, dim) * sigma * sigma);
  };
  const FullState& was = kf.state();
  forEachOptionalState([&](const auto& spec) {
    if (params_.*spec.estimate)
      keep(x.*spec.value, was.*spec.value, spec.start(T_imu_cam0_), was.offset(spec.id), spec.kDim,
           params_.*spec.prior_sigma);
  });
  run_.kf->reset(x, P);
  anchor_utime_ = INT64_MIN;  // a new start: its first image anchors the start frame again
  run_.last_imu_time = state.utime;
  run_.consecutive_rejects.fill(0);
  run_.in_gap = false;
  initialized_ = true;
  processed_time_ = std::max(processed_time_, state.utime);
  // Anything buffered from before the start is dropped silently.
  buffer_.erase(buffer_.begin(), buffer_.upper_bound(state.utime));
  init_events_.clear();
  init_imu_.clear();
  init_tilt_.clear();
}

void Estimator::addImu(const ImuSample& s) {
  if (!s.angular_rate.allFinite() || !s.specific_force.allFinite()) {
    ++counters_[kSensorImu].rejected;
    return;
  }
  Event e;
  e.sensor = kSensorImu;
  e.imu = s;
  e.time = s.utime - params_.imu_latency_us;
  e.imu.utime = e.time;
  camera_delay_.addGyro(e.time, s.angular_rate);
  insert(std::move(e));
}

void Estimator::addTilt(const TiltSample& s) {
  if (!params_.use_tilt || !std::isfinite(s.angle_x) || !std::isfinite(s.angle_y)) {
    ++counters_[kSensorTilt].rejected;
    return;
  }
  Event e;
  e.sensor = kSensorTilt;
  e.tilt = s;
  e.time = s.utime - params_.tilt_latency_us;
  e.tilt.utime = e.time;
  insert(std::move(e));
}

void Estimator::addTrackerDelta(const TrackerDelta& d) { addDelta(d, kSensorTracker); }

void Estimator::addCloudDelta(const TrackerDelta& d) {
  if (!params_.cloud) return;
  TrackerDelta pose_only = d;
  pose_only.far_valid = false;
  addDelta(pose_only, kSensorCloud);
}

void Estimator::addKeyframe(int64_t utime) {
  if (!params_.cloud) return;
  keyframe_times_.insert(utime - camera_delay_.latencyAt(utime));
  // Only the newest announcements can still pin a clone (the older ones are pinned or gone already).
  const size_t keep = static_cast<size_t>(params_.max_keyframe_clones + params_.max_clones);
  while (keyframe_times_.size() > keep) keyframe_times_.erase(keyframe_times_.begin());
}

void Estimator::addDelta(const TrackerDelta& d, Sensor sensor) {
  TrackerDelta checked = d;
  if (checked.valid && (!d.translation.allFinite() || !d.rotation.coeffs().allFinite() || !d.covariance.allFinite() ||
                        std::abs(d.rotation.norm() - 1.0) > 1e-3)) {
    ++counters_[sensor].rejected;
    checked.valid = false;
  }
  if (checked.far_valid && (!d.far_rotation.coeffs().allFinite() || !d.far_covariance.allFinite() ||
                            std::abs(d.far_rotation.norm() - 1.0) > 1e-3)) {
    ++counters_[kSensorFarRotation].rejected;
    checked.far_valid = false;
  }
  if (!params_.far_rotation) checked.far_valid = false;
  if (!checked.valid && !checked.far_valid) return;  // no motion found: nothing to fuse
  Event e;
  e.sensor = sensor;
  e.delta = checked;
  if (sensor == kSensorTracker && checked.valid) camera_delay_.addDelta(d.utime_prev, d.utime, d.rotation);
  e.delta.utime = d.utime - camera_delay_.latencyAt(d.utime);
  e.delta.utime_prev = d.utime_prev - camera_delay_.latencyAt(d.utime_prev);
  // A map's alignment waits until the filter's time is cloud_apply_delay_us past the map's, so that it is applied at
  // the same point live and in a replay.
  e.time = e.delta.utime + (sensor == kSensorCloud ? params_.cloud_apply_delay_us : 0);
  if (e.time <= processed_time_) {
    // Deltas come late by nature (after the tracker or the mapper ran): they act on the clones, which are kept.
    if (sensor == kSensorCloud) ++cloud_applied_late_;
    if (initialized_) {
      process(e);
    } else if (sensor == kSensorTracker) {
      // Before the start: kept in time order for the start from the tracker's deltas.
      const auto at = std::upper_bound(init_events_.begin(), init_events_.end(), e.time,
                                       [](int64_t t, const Event& x) { return t < x.time; });
      init_events_.insert(at, e);
      tracker_seen_ = tracker_seen_ || e.delta.valid;
      tryMotionStart();
    }
    return;
  }
  insert(std::move(e));
}

void Estimator::pruneClones(KalmanFilter& kf) {
  // From the newest clone back: the first max_clones are kept (consecutive image times, for the tracker), of the
  // older ones the keyframes until max_keyframe_clones keyframes are held in all, and those the tracker's next delta
  // still needs while they are within clone_wait_us of the newest.
  if (kf.state().clones.empty()) return;
  const int64_t newest = kf.state().clones.back().utime;
  int images = 0, keyframes = 0;
  for (int i = static_cast<int>(kf.state().clones.size()) - 1; i >= 0; --i) {
    const int64_t t = kf.state().clones[i].utime;
    const bool keyframe = keyframe_times_.count(t) > 0;
    const bool recent = ++images <= params_.max_clones;
    const bool pinned = keyframe && keyframes < params_.max_keyframe_clones;
    const bool awaited = earlier_images_fused_.count(t) == 0 && newest - t <= params_.clone_wait_us;
    const bool anchor = t == anchor_utime_;
    if (keyframe) ++keyframes;
    if (!recent && !pinned && !awaited && !anchor) kf.removeClone(i);
  }
  // Marks of clones that are gone can no longer matter.
  const int64_t oldest = kf.state().clones.front().utime;
  earlier_images_fused_.erase(earlier_images_fused_.begin(), earlier_images_fused_.lower_bound(oldest));
}

std::optional<FilterOutput> Estimator::addImageTime(int64_t utime) {
  Event e;
  e.sensor = kSensorImage;
  e.time = utime - camera_delay_.latencyAt(utime);
  const int64_t t = e.time;
  if (t < processed_time_) {
    if (initialized_) ++counters_[kSensorImage].too_late;
    return std::nullopt;
  }
  if (!insert(std::move(e)) || !initialized_ || t < run_.kf->state().nav.utime) return std::nullopt;
  // A-priori state at the image time: a copy of the filter (its clones left out: no IMU or tilt measurement involves
  // them) takes the buffered IMU and tilt samples up to then.
  Runner ahead;
  ahead.kf = run_.kf->copyWithoutClones(run_.kf->state().findClone(anchor_utime_));
  ahead.last_imu_time = run_.last_imu_time;
  ahead.consecutive_rejects = run_.consecutive_rejects;
  ahead.in_gap = run_.in_gap;
  ahead.motion = run_.motion;
  for (auto it = buffer_.begin(); it != buffer_.end() && it->first <= t; ++it)
    if (it->second.sensor == kSensorImu || it->second.sensor == kSensorTilt)
      applyMeasurement(ahead, it->second, nullptr);
  predictTo(ahead, t);
  // The state at the exposure (the pair's stamp less the camera delay), stamped with the pair's own stamp: the
  // tracker looks its prior up by the stamp it received.
  FilterOutput prior = makeOutput(*ahead.kf, true);
  prior.state.utime = utime;
  return prior;
}

void Estimator::flush() {
  // Everything the window holds, but nothing beyond what the IMU's time line allows: a forged stamp far ahead that
  // came before the IMU's first sample waits in the buffer, and is not applied here either.
  release(newest_imu_time_ == INT64_MIN ? INT64_MIN : newest_imu_time_ + params_.imu_silence_release_us);
}

std::vector<FilterOutput> Estimator::takeOutputs() {
  std::vector<FilterOutput> out;
  out.swap(outputs_);
  return out;
}

FilterOutput Estimator::current() const { return makeOutput(*run_.kf, false); }

bool Estimator::insert(Event&& e) {
  if (e.time < processed_time_) {
    ++counters_[e.sensor].too_late;
    return false;
  }
  const Sensor sensor = e.sensor;
  const int64_t t = e.time;
  if (sensor == kSensorImu) {
    non_imu_in_a_row_ = 0;
  } else {
    ++non_imu_in_a_row_;
    // The IMU's stamps are the filter's clock. Another sensor's stamp further ahead of them than
    // imu_silence_release_us while the IMU still sends is a corrupt or forged one (a stream's very first stamp
    // included, which no check of its own stream can judge): refused, so that it cannot release the buffer early
    // and make every real measurement late. Once the IMU has fallen silent (kImuSilentMessages in a row from the
    // others) the others carry the time on.
    if (newest_imu_time_ != INT64_MIN && t > newest_imu_time_ + params_.imu_silence_release_us &&
        non_imu_in_a_row_ < kImuSilentMessages) {
      ++counters_[sensor].rejected;
      ++ahead_of_imu_;
      return false;
    }
  }
  const bool first_imu = sensor == kSensorImu && newest_imu_time_ == INT64_MIN;
  buffer_.emplace(t, std::move(e));  // equal times keep arrival order
  newest_time_ = std::max(newest_time_, t);
  if (sensor == kSensorImu) newest_imu_time_ = std::max(newest_imu_time_, t);
  if (first_imu) {
    // What waited for the IMU's first sample is judged against it now, as it would have been had the IMU come
    // first: a stamp further ahead than imu_silence_release_us is refused and counted, and the time line is the
    // remaining ones'.
    newest_time_ = t;
    for (auto it = buffer_.begin(); it != buffer_.end();) {
      if (it->second.sensor != kSensorImu && it->first > t + params_.imu_silence_release_us) {
        ++counters_[it->second.sensor].rejected;
        ++ahead_of_imu_;
        it = buffer_.erase(it);
      } else {
        newest_time_ = std::max(newest_time_, it->first);
        ++it;
      }
    }
  }
  if (newest_imu_time_ == INT64_MIN) {
    // Before the IMU's first sample nothing can start the filter and nothing may pass: the others wait (the oldest
    // go beyond a bound), so that no stamp of theirs is taken for the time.
    while (buffer_.size() > kMaxEventsBeforeImu) buffer_.erase(buffer_.begin());
    return true;
  }
  const int64_t horizon = non_imu_in_a_row_ >= kImuSilentMessages
                              ? std::max(newest_imu_time_, newest_time_ - params_.imu_silence_release_us)
                              : newest_imu_time_;
  release(horizon - params_.reorder_window_us);
  return true;
}

void Estimator::release(int64_t up_to) {
  while (!buffer_.empty() && buffer_.begin()->first <= up_to) {
    const Event e = std::move(buffer_.begin()->second);
    buffer_.erase(buffer_.begin());
    processed_time_ = std::max(processed_time_, e.time);
    if (initialized_)
      process(e);
    else
      processInit(e);
  }
}

void Estimator::predictTo(Runner& run, int64_t t) {
  KalmanFilter& kf = *run.kf;
  const int64_t now = kf.state().nav.utime;
  if (t <= now) return;
  const int64_t gap_us = static_cast<int64_t>(params_.imu_gap_s * 1e6);
  if (!run.in_gap && run.last_imu_time != INT64_MIN && t - run.last_imu_time >= gap_us) {
    // The held acceleration and rate are stale: fall back to "no motion" with wide uncertainty.
    run.in_gap = true;
    NavState& n = kf.mutableNav();
    n.acceleration.setZero();
    n.angular_rate.setZero();
    kf.resetErrorBlock(kErrA, 3, params_.gap_sigma_acceleration * params_.gap_sigma_acceleration);
    kf.resetErrorBlock(kErrW, 3, params_.gap_sigma_angular_rate * params_.gap_sigma_angular_rate);
    if (run.counts) {
      ++imu_gaps_;
      IPS_WARN("filter: no IMU data since t=" << run.last_imu_time << " us: rates reset, covariance inflated");
    }
  }
  if (run.in_gap)
    kf.predict(static_cast<double>(t - now) * 1e-6, params_.gap_process);
  else
    kf.predict(static_cast<double>(t - now) * 1e-6, run.motion.current());
}

double Estimator::gateFor(Runner& run, Sensor s, int dof, bool enabled) const {
  if (!enabled || run.consecutive_rejects[s] >= params_.max_consecutive_rejects) return kInf;
  return dof == 2 ? gate2_ : dof == 6 ? gate6_ : chiSquareQuantile(params_.gate_probability, dof);
}

bool Estimator::applyMeasurement(Runner& run, const Event& e, std::array<SensorCounters, kNumSensors>* counters) {
  KalmanFilter& kf = *run.kf;
  UpdateResult r;
  if (e.time < kf.state().nav.utime) {
    if (counters) ++(*counters)[e.sensor].too_late;
    return false;
  }
  if (e.sensor == kSensorImu) {
    predictTo(run, e.time);
    run.in_gap = false;
    const ImuMeasurement m(e.imu.angular_rate, e.imu.specific_force, params_.gravity, gyro_sigma_, accel_sigma_);
    r = kf.update(m, gateFor(run, kSensorImu, 6, params_.gate_imu));
    run.last_imu_time = e.time;
    run.motion.add(e.time, e.imu.angular_rate, e.imu.specific_force);
  } else if (e.sensor == kSensorTilt) {
    predictTo(run, e.time);
    if (kf.state().nav.acceleration.norm() > params_.tilt_max_acceleration) {
      if (counters) ++(*counters)[kSensorTilt].rejected;
      return false;
    }
    const bool offset = kf.state().tilt_offset.has_value();
    const TiltMeasurement m(e.tilt.angle_x, e.tilt.angle_y, R_body_tilt_,
                            offset ? params_.tilt_offset_noise_sigma : params_.tilt_sigma, params_.gravity,
                            params_.tilt_specific_force, offset);
    r = kf.update(m, gateFor(run, kSensorTilt, 2, params_.gate_tilt));
  } else {
    return false;
  }
  countUpdate(run, e.sensor, r.applied, counters);
  return r.applied;
}

void Estimator::countUpdate(Runner& run, Sensor s, bool applied, std::array<SensorCounters, kNumSensors>* counters) {
  if (applied) {
    run.consecutive_rejects[s] = 0;
    if (counters) ++(*counters)[s].accepted;
  } else {
    ++run.consecutive_rejects[s];
    if (counters) ++(*counters)[s].rejected;
  }
}

void Estimator::process(const Event& e) {
  KalmanFilter& kf = *run_.kf;
  switch (e.sensor) {
    case kSensorImu:
    case kSensorTilt:
      applyMeasurement(run_, e, &counters_);
      if (e.sensor == kSensorImu && ++imu_since_output_ >= params_.output_decimation) {
        imu_since_output_ = 0;
        outputs_.push_back(makeOutput(kf, false));
      }
      break;
    case kSensorImage: {
      if (e.time < kf.state().nav.utime || kf.state().findClone(e.time) >= 0) {
        ++counters_[kSensorImage].too_late;
        break;
      }
      predictTo(run_, e.time);
      const int clone = kf.addClone();
      if (params_.output_frame == OutputFrame::Start && anchor_utime_ == INT64_MIN) {
        anchor_utime_ = e.time;
        start_pose_ = kf.state().clones[clone];
      }
      ++counters_[kSensorImage].accepted;
      pruneClones(kf);
      break;
    }
    case kSensorCloud:
    case kSensorTracker: {
      const int i0 = kf.state().findClone(e.delta.utime_prev);
      const int i1 = kf.state().findClone(e.delta.utime);
      if (i0 < 0 || i1 < 0 || i0 == i1) {
        if (e.delta.valid) ++counters_[e.sensor].too_late;
        if (e.delta.far_valid) ++counters_[kSensorFarRotation].too_late;
        break;
      }
      if (e.sensor == kSensorTracker) earlier_images_fused_.insert(e.delta.utime_prev);
      if (e.delta.far_valid) {
        // The rotation from far points first: it is the sharper rotation where the scene is open, and the gate of
        // the 6-DoF delta then judges it against a state that already knows the rotation.
        const Eigen::Matrix3d cov = symmetrisedWithFloor(
            e.delta.far_covariance, Eigen::Vector3d(Eigen::Vector3d::Constant(params_.far_rotation_min_sigma)));
        const RotationMeasurement m(i0, i1, e.delta.far_rotation.normalized().toRotationMatrix(), cov, T_imu_cam0_);
        const UpdateResult r = kf.update(m, gateFor(run_, kSensorFarRotation, 3, params_.gate_far_rotation));
        countUpdate(run_, kSensorFarRotation, r.applied, &counters_);
      }
      if (!e.delta.valid) break;
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.linear() = e.delta.rotation.normalized().toRotationMatrix();
      T.translation() = e.delta.translation;
      const bool cloud = e.sensor == kSensorCloud;
      Eigen::Matrix<double, 6, 1> min_sigma;
      min_sigma << Eigen::Vector3d::Constant(cloud ? params_.cloud_min_sigma_t : params_.tracker_min_sigma_t),
          Eigen::Vector3d::Constant(cloud ? params_.cloud_min_sigma_r : params_.tracker_min_sigma_r);
      const DeltaMeasurement m(i0, i1, T, symmetrisedWithFloor(e.delta.covariance, min_sigma), T_imu_cam0_, !cloud);
      const UpdateResult r =
          kf.update(m, gateFor(run_, e.sensor, 6, cloud ? params_.gate_cloud : params_.gate_tracker));
      countUpdate(run_, e.sensor, r.applied, &counters_);
      break;
    }
    default:
      break;
  }
}

void Estimator::processInit(const Event& e) {
  if (e.sensor == kSensorImu || e.sensor == kSensorTilt || e.sensor == kSensorImage || e.sensor == kSensorTracker) {
    init_events_.push_back(e);
    // What the starts can still use: the static window, the motion window and a second of slack.
    const int64_t keep_us =
        static_cast<int64_t>((std::max(params_.init.duration_s, params_.init.motion_window_s) + 1.0) * 1e6);
    const auto old_end = std::lower_bound(init_events_.begin(), init_events_.end(), e.time - keep_us,
                                          [](const Event& x, int64_t t) { return x.time < t; });
    init_events_.erase(init_events_.begin(), old_end);
    if (e.sensor == kSensorTracker) {
      tracker_seen_ = tracker_seen_ || e.delta.valid;
      if (tryMotionStart()) return;
    }
  }
  if (e.sensor == kSensorTilt) {
    init_tilt_.push_back(e.tilt);
    return;
  }
  if (e.sensor != kSensorImu) return;
  init_imu_.push_back(e.imu);
  const double span = (init_imu_.back().utime - init_imu_.front().utime) * 1e-6;
  if (span < params_.init.duration_s) return;

  const double n = static_cast<double>(init_imu_.size());
  Eigen::Vector3d mean_f = Eigen::Vector3d::Zero(), mean_w = Eigen::Vector3d::Zero();
  for (const ImuSample& s : init_imu_) {
    mean_f += s.specific_force / n;
    mean_w += s.angular_rate / n;
  }
  double var_f = 0, var_w = 0;
  for (const ImuSample& s : init_imu_) {
    var_f += (s.specific_force - mean_f).squaredNorm() / n;
    var_w += (s.angular_rate - mean_w).squaredNorm() / n;
  }
  // Per-axis standard deviation (the sums run over three axes).
  if (std::sqrt(var_f / 3.0) > params_.init.max_accel_std || std::sqrt(var_w / 3.0) > params_.init.max_gyro_std ||
      mean_f.norm() < 0.5 * params_.gravity) {
    // With a tracker the start comes from its deltas (tryMotionStart); without one, from the mean specific force.
    if (params_.init.in_motion && !tracker_seen_) {
      initializeInMotion();
    } else {
      IPS_INFO("filter: not at rest yet (accel std " << std::sqrt(var_f / 3.0) << " m/s^2, gyro std "
                                                     << std::sqrt(var_w / 3.0) << " rad/s), waiting");
    }
    init_imu_.clear();
    init_tilt_.clear();
    return;
  }
  // At rest the accelerometer measures R^T (0, 0, g): roll and pitch; heading is a convention from config.
  double roll = 0, pitch = 0;
  NavState s = startState(mean_f, &roll, &pitch);
  s.gyro_bias = mean_w;
  InitParams ip = params_.init;
  ip.sigma_gyro_bias = std::max(ip.sigma_gyro_bias, std::sqrt(var_w / 3.0 / n));
  initialize(s, initialCovariance(ip));
  // The tilt sensor's mean over the same time refines roll and pitch (and, against the accelerometer, its bias).
  if (!init_tilt_.empty()) {
    Eigen::Vector2d mean_tilt = Eigen::Vector2d::Zero();
    for (const TiltSample& t : init_tilt_) mean_tilt += Eigen::Vector2d(t.angle_x, t.angle_y);
    mean_tilt /= static_cast<double>(init_tilt_.size());
    // At rest both models agree; the acceleration state is zero.
    // With the offsets as states the mean carries the samples' white noise alone (averaged: far below their
    // sigma, but held at it, as the sensing element's lag and the head's sway are not white).
    const bool offset = run_.kf->state().tilt_offset.has_value();
    const TiltMeasurement m(mean_tilt.x(), mean_tilt.y(), R_body_tilt_,
                            offset ? params_.tilt_offset_noise_sigma : params_.tilt_sigma, params_.gravity,
                            params_.tilt_specific_force, offset);
    run_.kf->update(m, kInf);
  }
  IPS_INFO("filter: initialised at rest at t=" << s.utime << " us from " << init_imu_.size() << " IMU and "
                                               << init_tilt_.size() << " tilt samples, roll " << roll << " pitch "
                                               << pitch << " rad");
  init_imu_.clear();
  init_tilt_.clear();
}

NavState Estimator::startState(const Eigen::Vector3d& specific_force_up, double* roll, double* pitch) const {
  // The specific force of gravity points up in the body frame: roll and pitch. Position and heading are the
  // configured convention (neither is observable from the IMU).
  const Eigen::Vector3d f = specific_force_up.normalized();
  *roll = std::atan2(f.y(), f.z());
  *pitch = std::atan2(-f.x(), std::sqrt(f.y() * f.y() + f.z() * f.z()));
  NavState s;
  s.utime = init_imu_.empty() ? 0 : init_imu_.back().utime;
  s.position = params_.init.position;
  s.orientation = Eigen::AngleAxisd(params_.init.heading_rad, Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(*pitch, Eigen::Vector3d::UnitY()) *
                  Eigen::AngleAxisd(*roll, Eigen::Vector3d::UnitX());
  return s;
}

bool Estimator::tryMotionStart() {
  if (initialized_ || !params_.init.in_motion) return false;
  // The newest chain of consecutive valid deltas.
  std::vector<const Event*> chain;
  for (auto it = init_events_.rbegin(); it != init_events_.rend(); ++it) {
    if (it->sensor != kSensorTracker) continue;
    if (!it->delta.valid) break;
    if (!chain.empty() && it->delta.utime != chain.back()->delta.utime_prev) break;
    chain.push_back(&*it);
  }
  const InitParams& ip = params_.init;
  if (static_cast<int>(chain.size()) < ip.motion_min_deltas) return false;
  std::reverse(chain.begin(), chain.end());
  const int64_t t0 = chain.front()->delta.utime_prev, t1 = chain.back()->delta.utime;
  if ((t1 - t0) * 1e-6 < ip.motion_window_s) return false;
  // The IMU up to the newest delta, from the sample holding at its first image.
  MotionStartInput in;
  in.T_imu_cam0 = T_imu_cam0_;
  in.gyro_noise_density = params_.imu.gyro_noise_density;
  in.accel_noise_density = params_.imu.accel_noise_density;
  in.gravity = params_.gravity;
  in.max_gravity_error = ip.motion_max_gravity_error;
  for (const Event& e : init_events_)
    if (e.sensor == kSensorImu) {
      if (e.time <= t0 && !in.imu.empty()) in.imu.clear();
      in.imu.push_back(e.imu);
    }
  if (in.imu.empty() || in.imu.back().utime < t1) return false;  // the IMU has not reached the newest delta yet
  // At rest the mean over duration_s gives a better start (and the gyro bias from thousands of samples).
  double accel_var = 0, gyro_var = 0;
  Eigen::Vector3d mean_f = Eigen::Vector3d::Zero(), mean_w = Eigen::Vector3d::Zero();
  for (const ImuSample& m : in.imu) mean_f += m.specific_force, mean_w += m.angular_rate;
  mean_f /= static_cast<double>(in.imu.size());
  mean_w /= static_cast<double>(in.imu.size());
  for (const ImuSample& m : in.imu)
    accel_var += (m.specific_force - mean_f).squaredNorm(), gyro_var += (m.angular_rate - mean_w).squaredNorm();
  const double n_imu = static_cast<double>(in.imu.size());
  if (std::sqrt(accel_var / n_imu / 3.0) <= ip.max_accel_std && std::sqrt(gyro_var / n_imu / 3.0) <= ip.max_gyro_std)
    return false;
  const Eigen::Matrix<double, 6, 1> min_sigma =
      (Eigen::Matrix<double, 6, 1>() << Eigen::Vector3d::Constant(params_.tracker_min_sigma_t),
       Eigen::Vector3d::Constant(params_.tracker_min_sigma_r))
          .finished();
  for (const Event* e : chain) {
    TrackerDelta d = e->delta;
    d.covariance = symmetrisedWithFloor(d.covariance, min_sigma);
    in.deltas.push_back(d);
  }
  std::string why;
  const std::optional<MotionStart> start = estimateMotionStart(in, &why);
  if (!start) {
    IPS_INFO("filter: no start from the tracker's deltas yet: " << why);
    return false;
  }
  // The state at the chain's first image: level from gravity, the configured position and heading.
  const Eigen::Vector3d up = -start->gravity_body.normalized();
  double roll = 0, pitch = 0;
  NavState s = startState(up, &roll, &pitch);
  s.utime = t0;
  const Eigen::Matrix3d R_wb = s.orientation.toRotationMatrix();
  const ImuSample& first = in.imu.front();
  s.velocity = R_wb * start->velocity_body;
  s.acceleration = R_wb * first.specific_force - Eigen::Vector3d(0, 0, params_.gravity);
  s.gyro_bias = start->gyro_bias;
  s.angular_rate = first.angular_rate - start->gyro_bias;
  InitParams cov_ip = ip;
  cov_ip.sigma_acceleration = ip.moving_sigma_acceleration;
  cov_ip.sigma_angular_rate = ip.moving_sigma_angular_rate;
  // Gravity's direction: the fit's uncertainty across it, and no better than an accelerometer bias of
  // sigma_accel_bias allows (a bias and a tilt look alike until the head turns).
  const Eigen::Matrix3d P_g = start->covariance.bottomRightCorner<3, 3>();
  const Eigen::Matrix3d across = Eigen::Matrix3d::Identity() - up * up.transpose();
  const Eigen::Matrix3d P_tilt = across * P_g * across;
  cov_ip.sigma_roll_pitch = std::max(
      std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(P_tilt).eigenvalues().maxCoeff()) / params_.gravity,
      ip.sigma_accel_bias / params_.gravity);
  Matrix21d P = initialCovariance(cov_ip);
  P.block<3, 3>(kErrV, kErrV) = R_wb * start->covariance.topLeftCorner<3, 3>() * R_wb.transpose();
  P.block<3, 3>(kErrBg, kErrBg) = start->gyro_bias_covariance;
  const std::vector<Event> since = std::move(init_events_);
  initialize(s, P);
  ++starts_in_motion_;
  IPS_WARN("filter: started in motion at t="
           << t0 << " us from " << chain.size() << " tracker deltas over " << (t1 - t0) * 1e-6 << " s: gyro bias "
           << start->gyro_bias.transpose() << " rad/s (sigma "
           << start->gyro_bias_covariance.diagonal().cwiseSqrt().transpose() << ", the fit's variance factor "
           << start->gyro_bias_variance_factor << "), speed " << start->velocity_body.norm() << " m/s, gravity misfit "
           << start->gravity_error * 100 << " %, roll " << roll << " pitch " << pitch << " rad");
  // The events since the first image, again, now with the filter running.
  for (const Event& e : since)
    if (e.time >= t0) process(e);
  return true;
}

void Estimator::initializeInMotion() {
  // Rotate every sample's specific force into the body frame of the window's last sample, integrating the
  // gyro backwards (C maps frame k into the last frame: C_{k-1} = C_k Exp(w_k dt)^T). Over the window the
  // linear acceleration of a walk or a drive averages out far better than gravity does, so the mean points
  // up in the last body frame.
  Eigen::Matrix3d C = Eigen::Matrix3d::Identity();
  Eigen::Vector3d sum_f = Eigen::Vector3d::Zero();
  for (size_t k = init_imu_.size(); k-- > 0;) {
    sum_f += C * init_imu_[k].specific_force;
    if (k == 0) break;
    const double dt = (init_imu_[k].utime - init_imu_[k - 1].utime) * 1e-6;
    const Eigen::Vector3d angle = init_imu_[k].angular_rate * dt;
    const double a = angle.norm();
    if (a > 0) C = C * Eigen::AngleAxisd(a, angle / a).toRotationMatrix().transpose();
  }
  double roll = 0, pitch = 0;
  NavState s = startState(sum_f, &roll, &pitch);
  s.angular_rate = init_imu_.back().angular_rate;
  InitParams ip = params_.init;
  ip.sigma_velocity = ip.moving_sigma_velocity;
  ip.sigma_acceleration = ip.moving_sigma_acceleration;
  ip.sigma_angular_rate = ip.moving_sigma_angular_rate;
  ip.sigma_roll_pitch = ip.moving_sigma_roll_pitch;
  ip.sigma_gyro_bias = ip.moving_sigma_gyro_bias;
  initialize(s, initialCovariance(ip));
  ++starts_in_motion_;
  IPS_WARN("filter: initialised in motion at t=" << s.utime << " us from " << init_imu_.size() << " IMU samples, roll "
                                                 << roll << " pitch " << pitch
                                                 << " rad; velocity from the tracker's deltas");
}

FilterOutput Estimator::makeOutput(const KalmanFilter& kf, bool a_priori) const {
  FilterOutput o;
  o.state = kf.state().nav;
  o.covariance = kf.covariance().topLeftCorner<kCoreErrorDim, kCoreErrorDim>();
  // In the start frame once its anchor exists (before, the two frames are the same).
  const int anchor = kf.state().findClone(anchor_utime_);
  o.frame = params_.output_frame;
  if (anchor >= 0) {
    const PoseClone& a = kf.state().clones[static_cast<size_t>(anchor)];
    o.up = start_pose_.orientation * (a.orientation.conjugate() * Eigen::Vector3d::UnitZ());
    o.state = toStartFrame(o.state, a, start_pose_);
    const Eigen::MatrixXd j = startFrameJacobian(kf.state(), anchor, start_pose_);
    o.covariance = j * kf.covariance() * j.transpose();
  }
  const FullState& x = kf.state();
  forEachOptionalState([&](const auto& spec) {
    using Value = typename std::decay_t<decltype(spec)>::Value;
    if (!(x.*spec.value)) return;
    const int offset = x.offset(spec.id);
    o.calibration[spec.id] = CalibrationEstimate{spec.name, spec.unit, Value::value(*(x.*spec.value)),
                                                 kf.covariance().block(offset, offset, spec.kDim, spec.kDim)};
  });
  o.type = kf.type();
  o.a_priori = a_priori;
  o.sensors = counters_;
  return o;
}

}  // namespace ips::filter
