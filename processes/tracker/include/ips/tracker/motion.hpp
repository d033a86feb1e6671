#pragma once
// Stereo geometry and relative motion: triangulation in the rectified pair, the closed-form alignment of
// two point clouds (Umeyama / Horn), RANSAC over it, Gauss-Newton refinement on the stereo reprojection
// errors and the 6x6 covariance from the residuals.
//
// Motion semantic everywhere (as ips_tracker_delta_t): X_prev = R * X_now + t, i.e. the pose of the camera
// at the newer time expressed in the camera at the older time. Covariance order [tx ty tz rx ry rz] where
// the rotation part is the right perturbation R = R_hat * exp([r]x).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "ips/rotation.hpp"
#include "ips/tracker/params.hpp"

namespace ips::tracker {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

// The rectified stereo pinhole: both cameras share f, cx, cy; the right one sits `baseline` metres along +x.
struct RectifiedStereo {
  double f = 0, cx = 0, cy = 0, baseline = 0;
  // The right camera's principal point minus the left's [px] (DisparityOffsetParams): a right column is
  // xr = cx + disparity_offset + f (X - b) / Z, so the disparity of a point is xl - xr + disparity_offset.
  double disparity_offset = 0;

  // Point in the rectified left camera from a left pixel (xl, y) and the right column xr (same row).
  Eigen::Vector3d triangulate(double xl, double y, double xr) const;
  // The same point in inverse depth, defined also at infinity (disparity 0) and beyond (noise): X = ray / rho with
  // ray = ((xl - cx) / f, (y - cy) / f, 1) and rho = (xl - xr) / (f b).
  Eigen::Vector3d ray(double xl, double y) const { return {(xl - cx) / f, (y - cy) / f, 1.0}; }
  double inverseDepth(double xl, double xr) const { return (xl - xr + disparity_offset) / (f * baseline); }
  // Projection into left (x, y) and right (x) of a point in the rectified left camera.
  Eigen::Vector3d project(const Eigen::Vector3d& p) const;
  // d project / d point at p.
  Eigen::Matrix3d projectJacobian(const Eigen::Vector3d& p) const;
  // Covariance of the triangulated point when xl, y and xr each carry independent noise of sigma [px].
  Eigen::Matrix3d triangulationCovariance(double xl, double y, double xr, double sigma) const;
};

// One stereo observation: left column, row, right column in the rectified pair [px].
struct StereoObservation {
  double xl = 0, y = 0, xr = 0;
};

// The same scene point seen by the stereo pair at the older (prev) and newer (now) time.
struct Correspondence {
  StereoObservation prev, now;
  Eigen::Vector3d p_prev = Eigen::Vector3d::Zero();  // triangulated, rectified left camera at prev
  Eigen::Vector3d p_now = Eigen::Vector3d::Zero();
  int id = -1;  // the caller's tag (the tracker: index of the older feature)
};

struct RigidMotion {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
};

// Least-squares R, t with prev_i ~ R * now_i + t (Umeyama 1991, no scale). Needs >= 3 non-collinear points;
// returns false when the configuration is degenerate.
bool alignPointClouds(const std::vector<Eigen::Vector3d>& prev, const std::vector<Eigen::Vector3d>& now,
                      RigidMotion& out);

// Squared reprojection error [px^2] of correspondence c under the motion: p_prev moved into the newer
// camera and projected into the newer pair, against c.now (left x, row, right x).
double forwardReprojectionError2(const RectifiedStereo& cam, const Correspondence& c, const RigidMotion& m);
// The same error as a squared Mahalanobis distance: its covariance is the older point's triangulation
// covariance carried into the newer image plus the newer observation's pixel noise (sigma on each of the
// three coordinates). Far points, whose depth is uncertain, are thereby judged fairly.
double forwardMahalanobis2(const RectifiedStereo& cam, const Correspondence& c, const RigidMotion& m,
                           const Eigen::Matrix3d& cov_prev, double sigma);

struct MotionEstimate {
  bool valid = false;
  RigidMotion motion;
  Matrix6d covariance = Matrix6d::Identity();
  std::vector<int> inliers;    // indices into the correspondences
  double residual_rms_m = 0;   // 3D: |p_prev - (R p_now + t)| over the inliers [m]
  double residual_rms_px = 0;  // image: stereo reprojection errors over the inliers [px]
};

// RANSAC over minimal 3-point alignments, scored by forwardMahalanobis2, then alignment of all
// inliers, Gauss-Newton refinement and covariance. valid=false with too few inliers.
MotionEstimate estimateMotion(const RectifiedStereo& cam, const std::vector<Correspondence>& corr,
                              const MotionParams& params);

// Gauss-Newton on the whitened forward stereo reprojection errors (see forwardMahalanobis2) of the
// correspondences `use`, starting at `initial`. Writes the covariance, (J^T W J)^-1 scaled by the variance
// factor of the residuals (chi^2 / degrees of freedom), and the plain image rms [px].
RigidMotion refineMotion(const RectifiedStereo& cam, const std::vector<Correspondence>& corr,
                         const std::vector<int>& use, const RigidMotion& initial, int iterations, double sigma,
                         Matrix6d* covariance, double* rms_px);

// Rotation from far correspondences (FarRotationParams): each point's bearing at the newer time a = ((xl-cx)/f,
// (y-cy)/f, 1) and inverse depth rho = (xl - xr) / (f b) predict its older left position as the projection of
// R a + rho t; rho t is the translation's parallax, ~0 for far points, taken out with the given translation
// (whose covariance t_cov enters each point's weight, as do the pixel noise of both positions and of rho).
// RANSAC over 2-point rotations, Gauss-Newton on the whitened 2-D residuals, covariance (J^T W J)^-1 scaled by
// the residuals' variance factor when above 1. Correspondences need only their observations (prev, now).
struct FarRotationEstimate {
  bool valid = false;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();           // X_prev direction = R X_now direction (+ parallax)
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();  // right perturbation R = R_hat exp([r]x) [rad^2]
  std::vector<int> inliers;
  double residual_rms_px = 0;
};
FarRotationEstimate estimateFarRotation(const RectifiedStereo& cam, const std::vector<Correspondence>& far,
                                        const Eigen::Vector3d& t, const Eigen::Matrix3d& t_cov,
                                        const MotionParams& motion, const FarRotationParams& params);

// What one pair says about the disparity offset: the correction to add to cam.disparity_offset that minimises the
// whitened reprojection errors of the inliers jointly with the motion (Gauss-Newton on 7 parameters from the 6-DoF
// estimate; the inliers gated again at the result), and its variance [px^2], scaled by the residuals' variance factor
// (at least 1). Inliers all at about one depth do not tell the offset from the motion's
// length: the variance is then large. valid = false with fewer than three inliers or a singular system.
struct DisparityOffsetObservation {
  bool valid = false;
  double correction_px = 0;
  double variance_px2 = 0;
};
DisparityOffsetObservation observeDisparityOffset(const RectifiedStereo& cam, const std::vector<Correspondence>& corr,
                                                  const std::vector<int>& inliers, const RigidMotion& motion,
                                                  const MotionParams& params);

using ips::expSO3;  // the project's SO(3) maps (ips/rotation.hpp)
using ips::logSO3;

}  // namespace ips::tracker
