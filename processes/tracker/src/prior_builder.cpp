#include "ips/tracker/prior_builder.hpp"

namespace ips::tracker {

PriorBuilderParams loadPriorBuilderParams(const Config& cfg) {
  PriorBuilderParams p;
  p.gyro_rate_sigma = cfg.getDouble("process/gyro_rate_sigma", p.gyro_rate_sigma);
  p.filter_rotation_floor = cfg.getDouble("process/filter_prior_rotation_floor", p.filter_rotation_floor);
  p.filter_translation_floor = cfg.getDouble("process/filter_prior_translation_floor", p.filter_translation_floor);
  p.max_filter_states = cfg.getInt("process/max_filter_priors", p.max_filter_states);
  p.gyro_window_s = cfg.getDouble("process/gyro_window_s", p.gyro_window_s);
  if (!(p.gyro_rate_sigma > 0 && p.filter_rotation_floor >= 0 && p.filter_translation_floor >= 0 &&
        p.max_filter_states >= 2 && p.gyro_window_s > 0))
    throw ConfigError(cfg.path() +
                      ": process/ prior keys out of range (sigmas and floors >= 0, "
                      "max_filter_priors >= 2, gyro_window_s > 0)");
  return p;
}

PriorBuilder::PriorBuilder(const Eigen::Isometry3d& T_imu_cam0, const PriorBuilderParams& params,
                           const PriorParams& motion)
    : T_imu_cam0_(T_imu_cam0), params_(params), motion_(motion) {}

void PriorBuilder::addFilterState(const FilterPriorState& s) {
  filter_seen_ = true;
  filter_[s.utime] = s;
  while (static_cast<int>(filter_.size()) > params_.max_filter_states) filter_.erase(filter_.begin());
}

void PriorBuilder::addFilterNone(int64_t utime) {
  filter_seen_ = true;
  filter_none_.insert(utime);
  while (static_cast<int>(filter_none_.size()) > params_.max_filter_states) filter_none_.erase(filter_none_.begin());
}

void PriorBuilder::addGyro(int64_t utime, const Eigen::Vector3d& rate) {
  if (!gyro_.empty() && utime <= gyro_.back().first) return;
  gyro_.emplace_back(utime, rate);
  const auto window = static_cast<int64_t>(params_.gyro_window_s * 1e6);
  while (gyro_.size() > 2 && gyro_.back().first - gyro_.front().first > window) gyro_.pop_front();
}

std::optional<MotionPrior> PriorBuilder::fromFilter(int64_t t0, int64_t t1) const {
  auto a = filter_.find(t0), b = filter_.find(t1);
  if (a == filter_.end() || b == filter_.end()) return std::nullopt;
  const Eigen::Isometry3d T_w_c0 = a->second.T_world_body * T_imu_cam0_;
  const Eigen::Isometry3d T_w_c1 = b->second.T_world_body * T_imu_cam0_;
  const Eigen::Isometry3d T_c0_c1 = T_w_c0.inverse() * T_w_c1;
  const double dt = (t1 - t0) * 1e-6;
  // The relative motion's uncertainty grows with the velocity and rate uncertainty over the interval.
  const Eigen::Matrix3d R_c_w = T_w_c0.linear().transpose();
  const Eigen::Matrix3d R_c_b = T_imu_cam0_.linear().transpose();
  const double fm = params_.filter_translation_floor, fr = params_.filter_rotation_floor;
  Matrix6d cov = Matrix6d::Zero();
  cov.topLeftCorner<3, 3>() =
      R_c_w * b->second.velocity_cov * R_c_w.transpose() * dt * dt + Eigen::Matrix3d::Identity() * fm * fm;
  cov.bottomRightCorner<3, 3>() =
      R_c_b * b->second.angular_rate_cov * R_c_b.transpose() * dt * dt + Eigen::Matrix3d::Identity() * fr * fr;
  return MotionPrior::fromFilter(T_c0_c1.linear(), T_c0_c1.translation(), cov);
}

std::optional<MotionPrior> PriorBuilder::fromGyro(int64_t t0, int64_t t1) const {
  if (gyro_.empty() || gyro_.front().first > t0 || gyro_.back().first < t1) return std::nullopt;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int n = 0;
  for (const auto& [t, rate] : gyro_) {
    if (t < t0 || t > t1) continue;
    sum += rate;
    ++n;
  }
  if (n == 0) return std::nullopt;
  Eigen::Vector3d bias = Eigen::Vector3d::Zero();
  auto newest = filter_.upper_bound(t1);
  if (newest != filter_.begin()) bias = std::prev(newest)->second.gyro_bias;
  return MotionPrior::fromImuRates(sum / n - bias, T_imu_cam0_.linear(), (t1 - t0) * 1e-6, params_.gyro_rate_sigma,
                                   motion_);
}

}  // namespace ips::tracker
