#pragma once
// Rotations for the whole project: the exponential and logarithm maps of SO(3) on rotation vectors (axis times
// angle), as matrices and as unit quaternions, the skew matrix and the right Jacobian. The filter, the tracker, the
// calibration tools and the evaluation all use these; the maps are smooth at zero (a series there), which the
// filter's numeric Jacobian tests rely on.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace ips {

// [v]x: skew(v) * u = v x u.
Eigen::Matrix3d skew(const Eigen::Vector3d& v);
// Exp(phi): the turn by |phi| about phi (the identity for phi = 0).
Eigen::Quaterniond expQuat(const Eigen::Vector3d& phi);
Eigen::Matrix3d expSO3(const Eigen::Vector3d& phi);
// Log(q), Log(R): the rotation vector, |phi| in [0, pi] (the shorter of q and -q).
Eigen::Vector3d logQuat(const Eigen::Quaterniond& q);
Eigen::Vector3d logSO3(const Eigen::Matrix3d& R);
// Right Jacobian of SO(3): Exp(phi + d) ~= Exp(phi) Exp(Jr(phi) d).
Eigen::Matrix3d rightJacobianSO3(const Eigen::Vector3d& phi);

// Log(R) in degrees (for printing).
inline Eigen::Vector3d rotationVectorDeg(const Eigen::Matrix3d& R) { return logSO3(R) * (180.0 / M_PI); }

// The angle between two rotations [deg].
inline double rotationAngleDeg(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B) {
  return Eigen::AngleAxisd(A.transpose() * B).angle() * (180.0 / M_PI);
}

}  // namespace ips
