#include "ips/sim/mono_truth.hpp"

#include <cmath>
#include <vector>

namespace ips::sim {

void polarDisparityTruth(const PolarRectification& P, const sim::SceneRenderer& scene, const Eigen::Isometry3d& W_a,
                         const Eigen::Isometry3d& W_b, cv::Mat& gt_disparity, cv::Mat& gt_range) {
  const cv::Size size = P.maps.size;
  const size_t n = static_cast<size_t>(size.area());
  std::vector<float> rx(n), ry(n);
  std::vector<uint8_t> front(n);
  const Eigen::Matrix3d R_b_a = P.R_a_b.transpose();
  for (int v = 0; v < size.height; ++v)
    for (int u = 0; u < size.width; ++u) {
      const size_t i = static_cast<size_t>(v) * size.width + u;
      const Eigen::Vector3d ra = P.ray(u, v);
      const Eigen::Vector3d own = P.left_is_b ? Eigen::Vector3d(R_b_a * ra) : ra;  // as the left map samples it
      front[i] = own.z() > 0;
      rx[i] = front[i] ? static_cast<float>(own.x() / own.z()) : 0.f;
      ry[i] = front[i] ? static_cast<float>(own.y() / own.z()) : 0.f;
    }
  const View view = View::fromRays(size.width, size.height, 0.5 * (P.K(0, 0) + P.K(1, 1)), rx, ry);
  const Eigen::Isometry3d& W_left = P.left_is_b ? W_b : W_a;
  const Eigen::Isometry3d& W_right = P.left_is_b ? W_a : W_b;
  cv::Mat depth;
  scene.render(view, W_left, nullptr, &depth);
  gt_disparity.create(size, CV_32F);
  gt_range.create(size, CV_32F);
  const Eigen::Isometry3d right_from_left = W_right.inverse() * W_left;
  for (int v = 0; v < size.height; ++v)
    for (int u = 0; u < size.width; ++u) {
      const size_t i = static_cast<size_t>(v) * size.width + u;
      const float z = depth.at<float>(v, u);
      gt_disparity.at<float>(v, u) = gt_range.at<float>(v, u) = NAN;
      if (!front[i] || !(z > 0)) continue;
      const Eigen::Vector3d X_left(z * rx[i], z * ry[i], z);
      const Eigen::Vector3d X_right = right_from_left * X_left;
      // The right map samples its image along ray_a (a) or R_b_a * ray_a (b): back to a's orientation.
      const Eigen::Vector3d ray_a = P.left_is_b ? X_right : Eigen::Vector3d(P.R_a_b * X_right);
      if (ray_a.z() <= 0) continue;
      const Eigen::Vector3d p = P.K * (ray_a / ray_a.z());
      const double u_right = ((p.head<2>() - P.epipole).norm() - P.r0) / P.dr;
      gt_disparity.at<float>(v, u) = static_cast<float>(u - u_right);
      gt_range.at<float>(v, u) = static_cast<float>(X_left.norm());
    }
}

}  // namespace ips::sim
