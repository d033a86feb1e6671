#include "ips/mapper/delta_chain.hpp"

namespace ips::mapper {

std::vector<Pose> DeltaChain::add(int64_t utime_prev, int64_t utime, const Eigen::Isometry3d& T_prev_now,
                                  const Eigen::Matrix<double, 6, 6>& covariance) {
  std::vector<Pose> out;
  auto bodyPose = [&](int64_t t) {
    Pose p;
    p.utime = t;
    p.T_world_body = T_world_cam0_ * T_body_cam0_.inverse();
    p.covariance = covariance_;
    return p;
  };
  if (!started_ || utime_prev != last_utime_) {
    started_ = true;
    T_world_cam0_ = T_body_cam0_;  // the body at the first image is the world
    covariance_.setZero();
    out.push_back(bodyPose(utime_prev));
  }
  const Eigen::Matrix3d R = T_world_cam0_.linear();
  covariance_.topLeftCorner<3, 3>() += R * covariance.topLeftCorner<3, 3>() * R.transpose();
  covariance_.bottomRightCorner<3, 3>() += R * covariance.bottomRightCorner<3, 3>() * R.transpose();
  T_world_cam0_ = T_world_cam0_ * T_prev_now;
  last_utime_ = utime;
  out.push_back(bodyPose(utime));
  return out;
}

}  // namespace ips::mapper
