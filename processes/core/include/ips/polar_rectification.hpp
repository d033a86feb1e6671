#pragma once
// Rectification of two images of one moving camera for the stereo matcher: disparity from one camera (paper,
// section 6). With the relative pose of the two exposures known (from the navigation filter), the second image is
// turned to the first one's orientation; then both share the epipole (the image of the motion direction) and every
// epipolar line is a ray from it. Polar rectification (Pollefeys, Koch, Van Gool 1999) makes each such ray a row:
// row = angle around the epipole, column = distance from it. A point appears farther from the epipole in one image
// than in the other, and that difference in columns is its disparity. Unlike planar rectification this works with
// the epipole inside the image (forward motion), where planar rectification cannot keep the view; the pixels close
// to the epipole are left out, since their disparity, and with it the depth precision, vanishes there.
//
// Frames as in calibration.hpp. Image a is the first exposure, image b the second; T_a_b maps camera b's frame
// into camera a's. The "left" image of the pair (index 0, the matcher's reference) is the one in which points
// appear farther from the epipole: b when b lies ahead of a along the optical axis, else a.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "ips/calibration.hpp"
#include "ips/config.hpp"

namespace ips {

struct PolarRectificationParams {
  // Columns are distance steps from the epipole, rows angle steps around it; the steps are chosen per pair so that
  // the image (both images' overlap with the view) fills them.
  cv::Size size{512, 2048};
  // Pixels whose ray is closer than this to the motion direction are masked: a disparity error of one step there is
  // a relative depth error of more than 1 / (distance in steps), and the angle bounds that distance.
  double min_epipole_angle_deg = 5.0;

  // Keys width, height, min_epipole_angle_deg of a config section (absent: the defaults above); throws ConfigError
  // for a size or angle out of range.
  static PolarRectificationParams fromConfig(const Config& section);
};

struct PolarRectification {
  // Maps (map0 for the left image, map1 for the right) into the raw images, -1 where a polar pixel sees nothing of
  // that image; size. f, cx, cy and baseline of a planar rectification have no meaning here and stay 0.
  StereoRectification maps;
  bool left_is_b = true;                                // which exposure the left (index 0) image is
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();      // the pinhole camera the polar geometry is built in
  Eigen::Matrix3d R_a_b = Eigen::Matrix3d::Identity();  // orientation of b in a
  Eigen::Vector3d c_b = Eigen::Vector3d::Zero();        // centre of camera b in camera a's frame [m]
  Eigen::Vector2d epipole = Eigen::Vector2d::Zero();    // in the pinhole image K (a's orientation) [px]
  double r0 = 0, dr = 1;                                // column u: distance r0 + u * dr from the epipole [px]
  double theta0 = 0, dtheta = 1;                        // row v: angle theta0 + (v + 0.5) * dtheta [rad]
  cv::Mat valid;  // CV_8U, 255 where both images see the polar pixel's ray and it is far enough from the epipole

  // Ray through polar pixel (u, v) (z = 1) in the orientation of camera a.
  Eigen::Vector3d ray(double u, double v) const;
  // Centres of the left and right exposure in camera a's frame.
  Eigen::Vector3d leftCentre() const { return left_is_b ? c_b : Eigen::Vector3d::Zero(); }
  Eigen::Vector3d rightCentre() const { return left_is_b ? Eigen::Vector3d::Zero() : c_b; }
  // Disparity (left column - right column) of a point given in camera a's frame; NaN behind either camera.
  double disparityOf(const Eigen::Vector3d& X_a) const;
  // The point seen at left pixel (u, v) with disparity d (columns), in camera a's frame (closest point of the two
  // rays); NaN for d <= 0.
  Eigen::Vector3d triangulate(double u, double v, double d) const;
};

// Throws std::invalid_argument when the two exposures share a centre (no baseline) or the size is empty.
PolarRectification polarRectification(const CameraIntrinsics& camera, const Eigen::Isometry3d& T_a_b,
                                      const PolarRectificationParams& params = {});

}  // namespace ips
