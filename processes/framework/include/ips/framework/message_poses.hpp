#pragma once
// The body's pose in the world as the navigation messages carry it, for the processes that place data with it
// (mapper, viewer): the filter's state with its position and attitude covariance, the simulator's truth.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <ips/filter_state_t.hpp>
#include <ips/ground_truth_t.hpp>

#include "ips/framework/filter_state_layout.hpp"

namespace ips::fw {

struct BodyPose {
  Eigen::Isometry3d T_world_body = Eigen::Isometry3d::Identity();
  // Error covariance of position [m] and attitude (rotation vector in world [rad]), in that order; zero for
  // the ground truth.
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
};

// From a filter state that passed validate().
inline BodyPose bodyPose(const ips::filter_state_t& s) {
  namespace layout = filter_state_layout;
  BodyPose p;
  p.T_world_body.linear() = Eigen::Quaterniond(s.orientation[0], s.orientation[1], s.orientation[2], s.orientation[3])
                                .normalized()
                                .toRotationMatrix();
  p.T_world_body.translation() = Eigen::Vector3d(s.position[0], s.position[1], s.position[2]);
  const int index[6] = {layout::kPosition, layout::kPosition + 1, layout::kPosition + 2,
                        layout::kAttitude, layout::kAttitude + 1, layout::kAttitude + 2};
  if (s.cov_dim >= layout::kDim)
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) p.covariance(r, c) = s.covariance[index[r]][index[c]];
  return p;
}

// From a ground-truth message; false when its position or attitude is not finite or not a rotation.
inline bool bodyPose(const ips::ground_truth_t& g, BodyPose* out) {
  const Eigen::Quaterniond q(g.orientation[0], g.orientation[1], g.orientation[2], g.orientation[3]);
  const Eigen::Vector3d t(g.position[0], g.position[1], g.position[2]);
  if (!t.allFinite() || !q.coeffs().allFinite() || q.norm() < 0.5) return false;
  out->T_world_body = Eigen::Isometry3d::Identity();
  out->T_world_body.linear() = q.normalized().toRotationMatrix();
  out->T_world_body.translation() = t;
  out->covariance.setZero();
  return true;
}

}  // namespace ips::fw
