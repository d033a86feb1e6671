#pragma once
// The navigation states of the last seconds, interpolated at an image time.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <deque>
#include <optional>

namespace ips {

struct Pose {
  int64_t utime = 0;
  Eigen::Isometry3d T_world_body = Eigen::Isometry3d::Identity();
  // Error covariance of position [m] and attitude (rotation vector in world [rad]), in that order.
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
};

class PoseBuffer {
 public:
  // max_gap_s: states further apart are not interpolated between; keep_s: how much history is kept.
  PoseBuffer(double max_gap_s, double keep_s) : max_gap_us_(max_gap_s * 1e6), keep_us_(keep_s * 1e6) {}

  // States must come in time order; an older one than the newest clears the buffer (a restarted filter or a
  // replay from the start) and returns false.
  bool add(const Pose& pose);

  enum class Lookup { kFound, kNotYet, kTooOld, kGap };
  // The pose at `utime`: position linear, attitude slerp, covariance of the nearer state. kNotYet when no
  // state is at or after utime yet (wait for it), kTooOld before the buffer, kGap when the neighbours are
  // further apart than max_gap_s.
  Lookup at(int64_t utime, Pose* out) const;

  int64_t newestUtime() const { return poses_.empty() ? INT64_MIN : poses_.back().utime; }

 private:
  double max_gap_us_, keep_us_;
  std::deque<Pose> poses_;
};

}  // namespace ips
