#pragma once
// A disparity map of the rectified left image to 3D points in the world frame, kept by range and precision.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <vector>

#include "ips/mapper/params.hpp"

namespace ips::mapper {

// Where the rectified left camera sits on the body (the IMU frame), from the head's calibration.
struct HeadGeometry {
  Eigen::Matrix3d R_rect0_cam0 = Eigen::Matrix3d::Identity();  // rectified left frame from camera 0
  Eigen::Isometry3d T_body_cam0 = Eigen::Isometry3d::Identity();
};

struct DisparityImage {
  cv::Mat disparity;  // CV_32FC1 [px], NaN or <= 0 where invalid
  double focal_px = 0, cx = 0, cy = 0, baseline_m = 0;
  cv::Mat grey;  // CV_8UC1 rectified left image of the same size, or empty (intensity 0)
};

struct PointSet {
  std::vector<Eigen::Vector3d> points;  // world frame [m]
  std::vector<uint8_t> intensity;
  // With alignment_points requested: the points whose pixel has texture of its own
  // (MapperParams::alignment_min_grey_spread), for the alignment of maps; all points when the map came without its
  // grey image. Empty otherwise.
  std::vector<Eigen::Vector3d> alignment_points;
  // Depth [m] beyond which points were cut by precision (for the figures).
  double max_range_m = 0;
};

// The range at which the depth error reaches params.max_depth_sigma_m for this camera pair.
double rangeForDepthSigma(const MapperParams& params, double focal_px, double baseline_m);

// Standard deviation of the grey values in a window x window square around each pixel (CV_32FC1).
cv::Mat greySpread(const cv::Mat& grey, int window);

// `alignment_points`: also select the points for the alignment of maps (the grey spread costs a pass over the image,
// which a mapper that aligns nothing need not make).
PointSet triangulate(const DisparityImage& map, const HeadGeometry& head, const Eigen::Isometry3d& T_world_body,
                     const MapperParams& params, bool alignment_points = false);

}  // namespace ips::mapper
