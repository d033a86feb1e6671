#pragma once
// The fixed arrays of the LCM messages to and from Eigen: quaternions as w x y z, matrices row-major (the layout every
// ips_*_t message uses for its covariances).
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ips::fw {

inline Eigen::Quaterniond quaternionFromArray(const double* wxyz) {
  return Eigen::Quaterniond(wxyz[0], wxyz[1], wxyz[2], wxyz[3]);
}

inline void quaternionToArray(const Eigen::Quaterniond& q, double* wxyz) {
  wxyz[0] = q.w();
  wxyz[1] = q.x();
  wxyz[2] = q.y();
  wxyz[3] = q.z();
}

inline Eigen::Vector3d vectorFromArray(const double* xyz) { return Eigen::Vector3d(xyz[0], xyz[1], xyz[2]); }

inline void vectorToArray(const Eigen::Vector3d& v, double* xyz) {
  for (int i = 0; i < 3; ++i) xyz[i] = v[i];
}

template <int N>
Eigen::Matrix<double, N, N> matrixFromArray(const double* row_major) {
  return Eigen::Map<const Eigen::Matrix<double, N, N, Eigen::RowMajor>>(row_major);
}

template <int N>
void matrixToArray(const Eigen::Matrix<double, N, N>& m, double* row_major) {
  Eigen::Map<Eigen::Matrix<double, N, N, Eigen::RowMajor>> out(row_major);
  out = m;
}

}  // namespace ips::fw
