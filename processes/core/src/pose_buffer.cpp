#include "ips/pose_buffer.hpp"

#include <algorithm>

namespace ips {

bool PoseBuffer::add(const Pose& pose) {
  if (!poses_.empty() && pose.utime < poses_.back().utime) {
    poses_.clear();
    poses_.push_back(pose);
    return false;
  }
  poses_.push_back(pose);
  while (poses_.size() > 2 && poses_.back().utime - poses_.front().utime > keep_us_) poses_.pop_front();
  return true;
}

PoseBuffer::Lookup PoseBuffer::at(int64_t utime, Pose* out) const {
  if (poses_.empty() || poses_.back().utime < utime) return Lookup::kNotYet;
  if (utime < poses_.front().utime) return Lookup::kTooOld;
  const auto after =
      std::lower_bound(poses_.begin(), poses_.end(), utime, [](const Pose& p, int64_t t) { return p.utime < t; });
  if (after->utime == utime) {
    *out = *after;
    return Lookup::kFound;
  }
  const Pose& b = *after;
  const Pose& a = *(after - 1);
  if (b.utime - a.utime > max_gap_us_) return Lookup::kGap;
  const double s = static_cast<double>(utime - a.utime) / static_cast<double>(b.utime - a.utime);
  out->utime = utime;
  out->T_world_body.translation() = (1 - s) * a.T_world_body.translation() + s * b.T_world_body.translation();
  out->T_world_body.linear() = Eigen::Quaterniond(a.T_world_body.linear())
                                   .slerp(s, Eigen::Quaterniond(b.T_world_body.linear()))
                                   .toRotationMatrix();
  out->covariance = s < 0.5 ? a.covariance : b.covariance;
  return Lookup::kFound;
}

}  // namespace ips
