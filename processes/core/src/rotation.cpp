#include "ips/rotation.hpp"

namespace ips {

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

Eigen::Quaterniond expQuat(const Eigen::Vector3d& phi) {
  const double angle = phi.norm();
  if (angle < 1e-8) {
    // Second-order series keeps the map smooth at zero (numeric Jacobian tests rely on it).
    Eigen::Quaterniond q(1.0 - angle * angle / 8.0, 0.5 * phi.x(), 0.5 * phi.y(), 0.5 * phi.z());
    return q.normalized();
  }
  const double s = std::sin(0.5 * angle) / angle;
  return Eigen::Quaterniond(std::cos(0.5 * angle), s * phi.x(), s * phi.y(), s * phi.z());
}

Eigen::Vector3d logQuat(const Eigen::Quaterniond& q_in) {
  Eigen::Quaterniond q = q_in;
  if (q.w() < 0) q.coeffs() = -q.coeffs();  // shortest rotation
  const Eigen::Vector3d v = q.vec();
  const double sn = v.norm();
  if (sn < 1e-10) return 2.0 * v / q.w();
  const double angle = 2.0 * std::atan2(sn, q.w());
  return angle / sn * v;
}

Eigen::Matrix3d expSO3(const Eigen::Vector3d& phi) { return expQuat(phi).toRotationMatrix(); }

Eigen::Vector3d logSO3(const Eigen::Matrix3d& R) { return logQuat(Eigen::Quaterniond(R)); }

Eigen::Matrix3d rightJacobianSO3(const Eigen::Vector3d& phi) {
  const double a = phi.norm();
  const Eigen::Matrix3d K = skew(phi);
  if (a < 1e-6) return Eigen::Matrix3d::Identity() - 0.5 * K + K * K / 6.0;
  const double a2 = a * a;
  return Eigen::Matrix3d::Identity() - (1.0 - std::cos(a)) / a2 * K + (a - std::sin(a)) / (a2 * a) * K * K;
}

}  // namespace ips
