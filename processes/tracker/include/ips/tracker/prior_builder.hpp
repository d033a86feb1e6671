#pragma once
// The motion prior for the tracker's inter-matching from what the bus offers, best first: the filter's a-priori
// states at both image times, else the mean gyro rate over the interval, else none (the tracker then uses
// constant velocity). Plain types only; the process main converts messages.
#include <Eigen/Geometry>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <set>

#include "ips/tracker/params.hpp"
#include "ips/tracker/stereo_tracker.hpp"

namespace ips::tracker {

// The filter's a-priori state at one image time: body pose in the world, the uncertainty of the velocity
// (world) and of the angular rate (body), and the gyro bias it estimates.
struct FilterPriorState {
  int64_t utime = 0;
  Eigen::Isometry3d T_world_body = Eigen::Isometry3d::Identity();
  Eigen::Matrix3d velocity_cov = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d angular_rate_cov = Eigen::Matrix3d::Zero();
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();
};

struct PriorBuilderParams {
  double gyro_rate_sigma = 0.005;          // [rad/s] 1-sigma of a mean gyro rate over an image interval
  double filter_rotation_floor = 0.002;    // [rad] added to the filter's relative-rotation uncertainty
  double filter_translation_floor = 0.01;  // [m] likewise for the translation (the prior's own model error)
  // Filter states held: 8 s of images at 8 Hz, far more than a pair ever waits for its prior.
  int max_filter_states = 64;
  double gyro_window_s = 5.0;  // [s] gyro samples held: longer than any image interval the tracker bridges
};

// process/gyro_rate_sigma, filter_prior_rotation_floor, filter_prior_translation_floor, max_filter_priors,
// gyro_window_s over the defaults. Throws ConfigError on a value out of range.
PriorBuilderParams loadPriorBuilderParams(const Config& cfg);

class PriorBuilder {
 public:
  PriorBuilder(const Eigen::Isometry3d& T_imu_cam0, const PriorBuilderParams& params, const PriorParams& motion);

  void addFilterState(const FilterPriorState& s);
  // The filter's answer that it has no a-priori state for this image time (FILTER_PRIOR_NONE).
  void addFilterNone(int64_t utime);
  // Samples whose stamp does not increase are ignored (the filter counts bad IMU input; here it only places
  // search windows).
  void addGyro(int64_t utime, const Eigen::Vector3d& rate);

  bool filterSeen() const { return filter_seen_; }
  bool hasFilterState(int64_t utime) const { return filter_.count(utime) > 0; }
  // The filter answered for this image time: with a state, or that it has none.
  bool filterAnswered(int64_t utime) const { return hasFilterState(utime) || filter_none_.count(utime) > 0; }
  bool gyroSeen() const { return !gyro_.empty(); }
  // The gyro samples reach t: a prior from them no longer depends on when the rest arrives.
  bool gyroCovers(int64_t utime) const { return !gyro_.empty() && gyro_.back().first >= utime; }

  // Camera 0's motion from t0 to t1 from the filter's states at both times; nullopt unless both are held.
  std::optional<MotionPrior> fromFilter(int64_t t0, int64_t t1) const;
  // Rotation from the mean gyro rate over [t0, t1], corrected by the gyro bias of the newest filter state at or
  // before t1 (the bias estimate valid for the interval, chosen by stamp so that a replay chooses the same);
  // nullopt unless the samples cover the interval.
  std::optional<MotionPrior> fromGyro(int64_t t0, int64_t t1) const;

 private:
  Eigen::Isometry3d T_imu_cam0_;
  PriorBuilderParams params_;
  PriorParams motion_;
  std::map<int64_t, FilterPriorState> filter_;
  std::set<int64_t> filter_none_;
  std::deque<std::pair<int64_t, Eigen::Vector3d>> gyro_;
  bool filter_seen_ = false;
};

}  // namespace ips::tracker
