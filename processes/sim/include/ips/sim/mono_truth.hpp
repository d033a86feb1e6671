#pragma once
// Ground truth for disparity from one camera (ips/polar_rectification.hpp) on the simulated head.
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "ips/polar_rectification.hpp"
#include "ips/sim/stereo_renderer.hpp"

namespace ips::sim {

// The true disparity (CV_32F, polar columns) of every left polar pixel of P (built from a pose that may be an
// estimate), from the depth the simulator renders along the ray that pixel really samples: the point it sees, found in
// the right image, gives the column the right image has it in (its row may differ when the pose is off). Also the true
// range [m] (CV_32F) of the point from the left camera. NaN where nothing is seen. W_a, W_b: the true poses of the two
// exposures (camera frames in the world).
void polarDisparityTruth(const PolarRectification& P, const sim::SceneRenderer& scene, const Eigen::Isometry3d& W_a,
                         const Eigen::Isometry3d& W_b, cv::Mat& gt_disparity, cv::Mat& gt_range);

}  // namespace ips::sim
