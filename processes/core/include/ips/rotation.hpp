#pragma once
// Rotation vectors (axis times angle) and rotation matrices, for the calibration tools and their reports. The
// filter keeps its own quaternion-based maps (ips/filter/state.hpp), with a series near zero its numeric Jacobian
// tests need.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace ips {

// R = Exp(w): the turn by |w| about w (the identity for w = 0).
inline Eigen::Matrix3d rotationFromVector(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  return angle > 0 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
}

// w = Log(R), |w| in [0, pi].
inline Eigen::Vector3d rotationVector(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

// The same in degrees (for printing).
inline Eigen::Vector3d rotationVectorDeg(const Eigen::Matrix3d& R) { return rotationVector(R) * (180.0 / M_PI); }

// The angle between two rotations [deg].
inline double rotationAngleDeg(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B) {
  return Eigen::AngleAxisd(A.transpose() * B).angle() * (180.0 / M_PI);
}

}  // namespace ips
