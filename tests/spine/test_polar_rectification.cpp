// Polar rectification of two exposures of one camera against the camera model itself: a point triangulated from a
// left pixel and a disparity must be seen where the left map samples that pixel and where the right map samples the
// pixel one disparity to its left, in the raw images, through the real lens.
#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "ips/polar_rectification.hpp"

namespace ips {
namespace {

// The simulated head's left camera (config/sim_walk.yaml): 1360 x 1024, f 744 px, radial-tangential distortion.
CameraIntrinsics walkCamera() {
  CameraIntrinsics cam;
  cam.width = 1360;
  cam.height = 1024;
  cam.K << 744.19, 0, 683.5, 0, 744.19, 508.5, 0, 0, 1;
  cam.distortion << -0.11, 0.045, 2.0e-4, -1.0e-4, -0.008;
  return cam;
}

Eigen::Isometry3d pose(const Eigen::Vector3d& rotation_deg, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const Eigen::Vector3d w = rotation_deg * M_PI / 180;
  if (w.norm() > 0) T.linear() = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix();
  T.translation() = t;
  return T;
}

cv::Point2d rawPixel(const CameraIntrinsics& cam, const Eigen::Vector3d& X) {
  std::vector<cv::Point3d> in{{X.x(), X.y(), X.z()}};
  std::vector<cv::Point2d> out;
  const cv::Mat zero = cv::Mat::zeros(3, 1, CV_64F);
  cv::projectPoints(in, zero, zero, cam.cvK(), cam.cvDistortion(), out);
  return out[0];
}

float bilinear(const cv::Mat& map, double u, double v) {
  cv::Mat one;
  cv::getRectSubPix(map, cv::Size(1, 1), cv::Point2f(static_cast<float>(u), static_cast<float>(v)), one);
  return one.at<float>(0, 0);
}

// Checks, over a grid of valid left pixels and disparities, that triangulate and disparityOf agree and that the
// maps sample the raw images where the camera sees the triangulated point.
void expectMapsSeeTriangulatedPoints(const CameraIntrinsics& cam, const Eigen::Isometry3d& T_a_b) {
  PolarRectificationParams params;
  params.size = cv::Size(256, 1024);
  const PolarRectification P = polarRectification(cam, T_a_b, params);
  const Eigen::Isometry3d T_b_a = T_a_b.inverse();
  int checked = 0;
  for (int v = 8; v < params.size.height; v += 37)
    for (int u = 40; u < params.size.width; u += 23)
      for (double d : {2.25, 7.5, 20.0}) {
        if (!P.valid.at<uint8_t>(v, u) || u - d < 1 || !P.valid.at<uint8_t>(v, static_cast<int>(u - d))) continue;
        const Eigen::Vector3d X = P.triangulate(u, v, d);
        ASSERT_TRUE(X.allFinite());
        // Distances from an epipole near "infinity" (1e9 px for motion across the axis) keep fewer digits.
        EXPECT_NEAR(P.disparityOf(X), d, 1e-4) << "u " << u << " v " << v;
        const Eigen::Vector3d in_b = T_b_a * X;
        if (X.z() <= 0 || in_b.z() <= 0) continue;
        const cv::Point2d left = rawPixel(cam, P.left_is_b ? in_b : X);
        const cv::Point2d right = rawPixel(cam, P.left_is_b ? X : in_b);
        EXPECT_NEAR(P.maps.map0x.at<float>(v, u), left.x, 0.02);
        EXPECT_NEAR(P.maps.map0y.at<float>(v, u), left.y, 0.02);
        // The right map between columns: bilinear, off by the curvature of the sampled curve (hundredths of a px).
        EXPECT_NEAR(bilinear(P.maps.map1x, u - d, v), right.x, 0.05);
        EXPECT_NEAR(bilinear(P.maps.map1y, u - d, v), right.y, 0.05);
        ++checked;
      }
  EXPECT_GT(checked, 100);
}

TEST(PolarRectification, ForwardMotionKeepsTheViewAroundTheEpipole) {
  const CameraIntrinsics cam = walkCamera();
  const Eigen::Isometry3d T_a_b = pose({0.4, -1.5, 0.3}, {0.03, -0.01, 0.35});
  expectMapsSeeTriangulatedPoints(cam, T_a_b);
  const PolarRectification P = polarRectification(cam, T_a_b);
  EXPECT_TRUE(P.left_is_b);  // moving ahead: points spread out from the epipole in the later image
  // The epipole is in the image: all angles around it, the masked disk of 5 deg about it left out.
  EXPECT_NEAR(P.dtheta * P.maps.size.height, 2 * M_PI, 1e-9);
  EXPECT_NEAR(P.r0, 744.19 * std::tan(5 * M_PI / 180), 1e-6);
  const Eigen::Vector3d motion = T_a_b.translation().normalized();
  int masked = 0;
  for (int v = 0; v < P.maps.size.height; v += 7)
    for (int u = 0; u < P.maps.size.width; u += 5) {
      const double angle = std::acos(std::abs(P.ray(u, v).normalized().dot(motion))) * 180 / M_PI;
      if (P.valid.at<uint8_t>(v, u)) {
        EXPECT_GE(angle, 5.0 - 1e-9);
      }
      masked += !P.valid.at<uint8_t>(v, u);
    }
  EXPECT_GT(masked, 0);
  // Most of the polar image sees both exposures (the corners of the image lie beyond the inscribed circle).
  EXPECT_GT(cv::countNonZero(P.valid), 0.6 * P.maps.size.area());
}

TEST(PolarRectification, SidewaysAndBackwardMotion) {
  const CameraIntrinsics cam = walkCamera();
  // Sideways: the epipole far outside, the rows nearly parallel, spanning the image.
  const Eigen::Isometry3d right = pose({0.2, 0.5, -0.2}, {0.5, 0.01, 0.002});
  expectMapsSeeTriangulatedPoints(cam, right);
  const PolarRectification P = polarRectification(cam, right);
  EXPECT_GT(P.epipole.x(), 1e4);
  EXPECT_GT(cv::countNonZero(P.valid), 0.8 * P.maps.size.area());
  // Exactly perpendicular to the axis: the epipole at "infinity" still gives finite maps.
  expectMapsSeeTriangulatedPoints(cam, pose({0, 0, 0}, {-0.3, 0, 0}));
  // Backward: the earlier image is the one whose points lie farther from the epipole.
  const Eigen::Isometry3d back = pose({-0.3, 0.8, 0.1}, {0.02, 0.01, -0.4});
  expectMapsSeeTriangulatedPoints(cam, back);
  EXPECT_FALSE(polarRectification(cam, back).left_is_b);
}

TEST(PolarRectification, NoBaselineAndBadParamsAreErrors) {
  const CameraIntrinsics cam = walkCamera();
  EXPECT_THROW(polarRectification(cam, pose({1, 0, 0}, {0, 0, 0})), std::invalid_argument);
  PolarRectificationParams empty;
  empty.size = cv::Size(0, 10);
  EXPECT_THROW(polarRectification(cam, pose({0, 0, 0}, {0, 0, 1}), empty), std::invalid_argument);
}

}  // namespace
}  // namespace ips
