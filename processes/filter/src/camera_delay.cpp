#include "ips/filter/camera_delay.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <vector>

#include "ips/calib/camera_imu.hpp"

namespace ips::filter {

CameraDelayEstimator::CameraDelayEstimator(const CameraDelayParams& params, const Eigen::Matrix3d& R_imu_cam,
                                           int64_t initial_latency_us)
    : params_(params), R_imu_cam_(R_imu_cam) {
  schedule_[INT64_MIN] = initial_latency_us;
}

int64_t CameraDelayEstimator::latencyAt(int64_t utime) const {
  const auto after = schedule_.upper_bound(utime);
  // Stamps older than the schedule's first entry (pruned: older than any delta held) take the oldest latency known.
  return after == schedule_.begin() ? after->second : std::prev(after)->second;
}

void CameraDelayEstimator::addGyro(int64_t utime, const Eigen::Vector3d& rate) {
  if (!params_.estimate) return;
  if (!gyro_.empty() && utime <= gyro_.back().utime)
    return;  // the stream checks keep them in order; a repeat adds nothing
  gyro_.push_back({utime, rate});
  // Samples older than the first interval held minus the search range serve no estimate. Before the first delta,
  // which may come late, kGyroBeforeDeltasUs are kept.
  const int64_t oldest_needed =
      deltas_.empty() ? utime - kGyroBeforeDeltasUs : deltas_.front().utime_prev - params_.max_us;
  while (gyro_.size() > 2 && gyro_[1].utime < oldest_needed) gyro_.pop_front();
  if (due_ && utime >= due_up_to_ + params_.max_us) estimate();
}

void CameraDelayEstimator::addDelta(int64_t utime_prev, int64_t utime, const Eigen::Quaterniond& rotation) {
  if (!params_.estimate || utime <= utime_prev) return;
  if (!deltas_.empty() && utime <= deltas_.back().utime) return;  // in stamp order only: the schedule depends on it
  deltas_.push_back({utime_prev, utime, rotation});
  // The window, and room for the deltas that come while an estimation waits for the gyro.
  while (deltas_.size() > static_cast<size_t>(params_.window_intervals + params_.every_intervals)) deltas_.pop_front();
  if (!due_ && ++since_estimate_ >= params_.every_intervals) {
    due_ = true;
    due_up_to_ = utime;
    since_estimate_ = 0;
  }
  if (due_ && !gyro_.empty() && gyro_.back().utime >= due_up_to_ + params_.max_us) estimate();
}

void CameraDelayEstimator::estimate() {
  due_ = false;
  ++figures_.estimates;
  // The window of deltas ending with the one that made the estimation due, and the gyro around them: the same sets
  // live and in a replay, whatever came since.
  std::vector<calib::TrackerRotation> deltas;
  for (const calib::TrackerRotation& d : deltas_)
    if (d.utime <= due_up_to_) deltas.push_back(d);
  if (deltas.size() > static_cast<size_t>(params_.window_intervals))
    deltas.erase(deltas.begin(), deltas.end() - params_.window_intervals);
  if (deltas.empty()) return;
  std::vector<calib::GyroSample> gyro;
  for (const calib::GyroSample& g : gyro_)
    if (g.utime >= deltas.front().utime_prev - params_.max_us && g.utime <= due_up_to_ + params_.max_us)
      gyro.push_back(g);
  calib::CameraImuConfig config;
  config.coarse.max_delay_us = params_.max_us;
  config.coarse.min_intervals = static_cast<size_t>(params_.min_intervals);
  config.coarse.min_rate = params_.min_rate;
  config.known_R_imu_cam = R_imu_cam_;
  const calib::CameraImuEstimate e = calib::calibrateCameraImu(gyro, deltas, config);
  if (!e.ok) return;
  figures_.delay_us = e.delay_us;
  figures_.sigma_us = e.delay_sigma_us;
  figures_.intervals = e.intervals;
  if (e.intervals < static_cast<size_t>(params_.min_intervals) || !(e.delay_sigma_us <= params_.max_sigma_us)) return;
  // Only a change its uncertainty cannot explain enters the schedule: a head whose latency is right keeps it exactly,
  // and a good estimate is not replaced every few seconds by its own noise.
  const int64_t in_use = std::prev(schedule_.end())->second;
  if (!(std::fabs(e.delay_us - static_cast<double>(in_use)) > kSignificantSigmas * e.delay_sigma_us)) return;
  schedule_[due_up_to_ + kApplyAfterUs] = std::llround(e.delay_us);
  figures_.applied = true;
  // Stamps older than the window are asked for no more: the entries that only they used go.
  const int64_t oldest = deltas_.front().utime_prev;
  while (schedule_.size() > 1 && std::next(schedule_.begin())->first <= oldest) schedule_.erase(schedule_.begin());
}

}  // namespace ips::filter
