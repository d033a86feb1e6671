#pragma once
// The body's pose in the world as the navigation messages carry it, for the processes that place data with it
// (mapper, viewer, e3d): the filter's state with its position and attitude covariance, the simulator's truth; and
// the point clouds placed with it.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <ips/filter_state_t.hpp>
#include <ips/ground_truth_t.hpp>
#include <ips/point_cloud_t.hpp>
#include <string>
#include <vector>

#include "ips/framework/filter_state_layout.hpp"
#include "ips/framework/message_arrays.hpp"
#include "ips/kinematic_state.hpp"
#include "ips/pose_buffer.hpp"

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
  p.T_world_body.linear() = quaternionFromArray(s.orientation).normalized().toRotationMatrix();
  p.T_world_body.translation() = vectorFromArray(s.position);
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

// The ground-truth message of a truth (one to one).
inline ips::ground_truth_t groundTruthMessage(const InertialState& g) {
  ips::ground_truth_t m{};
  m.utime = g.utime;
  vectorToArray(g.position, m.position);
  quaternionToArray(g.orientation, m.orientation);
  vectorToArray(g.velocity, m.velocity);
  vectorToArray(g.acceleration, m.acceleration);
  vectorToArray(g.angular_rate, m.angular_rate);
  vectorToArray(g.gyro_bias, m.gyro_bias);
  vectorToArray(g.accel_bias, m.accel_bias);
  return m;
}

// As the pose buffers (ips/pose_buffer.hpp) keep it.
inline ips::Pose stampedPose(int64_t utime, const BodyPose& b) { return {utime, b.T_world_body, b.covariance}; }

// Points in `frame` placed with the body pose `body` (its pose and covariance go into the message), with their grey
// values.
inline ips::point_cloud_t pointCloudMessage(int64_t utime, int64_t seq, const std::string& frame, const ips::Pose& body,
                                            const std::vector<Eigen::Vector3d>& points,
                                            const std::vector<uint8_t>& intensity) {
  ips::point_cloud_t out{};
  out.utime = utime;
  out.seq = seq;
  out.frame = frame;
  const Eigen::Vector3d t = body.T_world_body.translation();
  for (int i = 0; i < 3; ++i) out.position[i] = t[i];
  quaternionToArray(Eigen::Quaterniond(body.T_world_body.linear()), out.orientation);
  matrixToArray<6>(body.covariance, out.pose_covariance);
  out.num_points = static_cast<int32_t>(points.size());
  out.points.resize(points.size());
  for (size_t i = 0; i < points.size(); ++i)
    out.points[i] = {static_cast<float>(points[i].x()), static_cast<float>(points[i].y()),
                     static_cast<float>(points[i].z())};
  out.intensity = intensity;
  return out;
}

}  // namespace ips::fw
