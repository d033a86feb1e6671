#pragma once
// Parameters of the stereo tracker. Every number the algorithm uses lives here with its default and its
// meaning; config/tracker.yaml lists them all, and loadTrackerParams reads any subset of them.
#include <string>

#include "ips/config.hpp"

namespace ips::tracker {

enum class CornerResponse { Harris, MinEigen };

struct DetectorParams {
  CornerResponse response = CornerResponse::Harris;  // "harris" (det - k trace^2) or "min_eigen"
  double harris_k = 0.04;                            // Harris and Stephens' k
  int block_size = 3;                                // window of the autocorrelation matrix [px]
  int sobel_size = 3;                                // derivative aperture [px]
  int grid_cols = 16;                                // corners are spread over a grid of cells...
  int grid_rows = 12;
  int max_per_cell = 4;         // ...with at most this many (strongest local maxima) per cell
  double quality_level = 1e-3;  // a corner's response must reach this fraction of the image's strongest
  int border = 8;               // no corners this close to the image edge [px] (plus the NCC half window)
  // Corners are detected on the first image pyramid level (halving) no wider than this, and scaled back:
  // a 1360 px camera is searched at 680 px, which costs a quarter and still finds every textured spot;
  // the matching at full resolution gives the precise correspondence.
  int max_detection_width = 800;
};

struct MatcherParams {
  int ncc_half_window = 5;     // NCC templates are (2h+1)^2 pixels
  double min_patch_std = 3.0;  // grey-level std below which a template is too flat to match
  // Intra-matching search range on the rectified row [px]. Below zero, so that points at infinity (true disparity
  // 0, measured with the noise of two positions, sqrt(2) * motion/pixel_sigma = 0.4 px) are matched too: they
  // give the rotation from far points (FarRotationParams).
  double min_disparity = -1.0;
  double max_disparity = 128.0;
  double intra_min_ncc = 0.8;          // accept a left-right match from this correlation on
  double intra_uniqueness = 0.03;      // the second best peak (>1 px away) must be this much lower
  bool intra_left_right_check = true;  // the right template searched back must land on the left corner (+-1 px)
  double epipolar_tolerance_px = 1.0;  // |row left - row right| allowed after inter-matching refinement
  double inter_min_ncc = 0.8;          // accept a match between times from this correlation (both cameras)
  double inter_uniqueness = 0.02;      // second best candidate must be this much lower
  int window_min_px = 6;               // inter-matching search window half size with a perfect prior
  int window_max_px = 200;             // ... and its upper bound (used without any prior)
  double window_sigma_scale = 3.0;     // window half size = min + scale * predicted 1-sigma image error
  int guided_window_px = 6;            // second, guided matching pass around the first estimate
  double prior_ok_px = 3.0;            // a prediction is "right" when the match is this close to it
  double prior_ok_fraction = 0.5;      // prior_ok when at least this share of inter-matches were right
  // Intra-matching from E3D's disparity map of the same pair (StereoTracker::process with a DisparityGuide):
  // each corner's right position is read from the map and checked by NCC within this many of the map's pixels
  // either side (SGM's valid disparities are within one pixel where they are right; its subpixel step and the
  // map's reduced resolution are inside that), then refined to subpixel by the correlation peak.
  double guide_search_map_px = 1.0;
};

struct MotionParams {
  int ransac_iterations = 300;
  double pixel_sigma = 0.3;       // 1-sigma of a matched image position (left x, row, right x) [px]
  double inlier_chi2 = 11.34;     // inlier: Mahalanobis reprojection error below this (3 dof, 99 %)
  int min_inliers = 12;           // fewer: the delta is invalid
  double min_inlier_ratio = 0.2;  // of the inter-matches
  int refine_iterations = 10;     // Gauss-Newton on the stereo reprojection errors
  double max_depth = 60.0;        // points farther away than this [m] are not used
  unsigned ransac_seed = 12345;   // fixed: the same input gives the same result
};

// Rotation from far points (paper section 6: "rotation and translation can be separated easily by selecting the
// zero-disparity pixels"). Features farther than motion/max_depth (disparity below f * b / max_depth) do not enter
// the 6-DoF estimate; their bearings give the rotation between the two images on their own, with the translation's
// small parallax on them taken out using the 6-DoF estimate's translation and each point's inverse depth.
struct FarRotationParams {
  bool enabled = true;
  int min_inliers = 8;          // fewer far inliers: no far rotation for this pair
  double inlier_chi2 = 9.21;    // Mahalanobis gate of a far point's 2-D residual (2 dof, 99 %)
  int ransac_iterations = 100;  // upper bound over 2-point rotations (adaptive stop at 99.9 %)
  double fuse_chi2 = 16.27;     // fuseFarRotation's gate on the two rotations' difference (3 dof, 99.9 %)
};

// Self-calibration of the disparity's zero: the right rectified camera's principal point against the left's. A
// calibration leaves it a few tenths of a pixel off (each principal point to about 0.3 px), and such an offset
// scales every depth by d / (d + offset): little for near points, much for far ones, so the translation between two
// pairs comes out too long or too short, by the same factor on every pair. Near and far points disagree about the
// motion unless the offset is right, so each pair observes it (7 parameters instead of 6 in the refinement). The
// pairs' corrections are averaged, and the average replaces the offset in use for the following pairs once it is
// more than apply_sigmas of its sigmas from zero (so that a right calibration is kept exactly); then the average
// begins anew.
struct DisparityOffsetParams {
  bool estimate = true;
  double initial_px = 0;      // the offset known beforehand (an earlier run's estimate); 0: the calibration's
  double gate_chi2 = 10.83;   // a pair's correction against zero within prior_sigma_px (1 dof, 99.9 %)
  double apply_sigmas = 4.0;  // applied when the average is this many sigmas from zero (tested on every pair) ...
  int min_observations = 20;  // ... and has this many pairs (their points are not independent)
  // How far a calibrated head's offset can be from the one in use [px, 1 sigma]: each pair's correction is gated
  // against zero with it, not against the round's average, so that a few wild pairs (a still head observes nothing
  // and may say -60 +- 10 px) cannot become an average that refuses every pair after them.
  double prior_sigma_px = 1.0;
};

struct PriorParams {
  // Constant-velocity prior: the last delta scaled to the new interval, with this 1-sigma uncertainty
  // per second of interval (the motion changes between frames).
  double cv_rotation_sigma_per_s = 0.5;     // [rad/s]
  double cv_translation_sigma_per_s = 0.5;  // [m/s]
  // IMU prior: rotation from the gyro; translation unknown up to this speed [m/s].
  double imu_translation_sigma_per_s = 1.0;
  double imu_rotation_sigma = 0.005;  // [rad] added to the gyro's own
  double max_interval_s = 1.0;        // a constant-velocity prior older than this is not used
};

struct TrackerParams {
  double rectification_alpha = 0.0;  // as cv::stereoRectify; 0 keeps only valid pixels
  DetectorParams detector;
  MatcherParams matcher;
  MotionParams motion;
  FarRotationParams far;
  DisparityOffsetParams disparity_offset;
  PriorParams prior;
};

// Reads the keys present in `cfg` (a file or a section, keys as in config/tracker.yaml); the others keep
// their defaults. Throws ConfigError on a bad value.
TrackerParams loadTrackerParams(const Config& cfg);
TrackerParams loadTrackerParams(const std::string& path);

}  // namespace ips::tracker
