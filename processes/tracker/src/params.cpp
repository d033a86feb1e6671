#include "ips/tracker/params.hpp"

namespace ips::tracker {

namespace {

void readInt(const Config& c, const std::string& key, int& v, int min_value) {
  v = c.getInt(key, v);
  if (v < min_value) throw ConfigError(c.path() + ": key '" + key + "' must be >= " + std::to_string(min_value));
}

void readDouble(const Config& c, const std::string& key, double& v, double min_value) {
  v = c.getDouble(key, v);
  if (!(v >= min_value)) throw ConfigError(c.path() + ": key '" + key + "' must be >= " + std::to_string(min_value));
}

}  // namespace

TrackerParams loadTrackerParams(const Config& c) {
  TrackerParams p;
  readDouble(c, "rectification_alpha", p.rectification_alpha, -1.0);

  DetectorParams& d = p.detector;
  const std::string resp = c.getString("detector/response", "harris");
  if (resp == "harris")
    d.response = CornerResponse::Harris;
  else if (resp == "min_eigen")
    d.response = CornerResponse::MinEigen;
  else
    throw ConfigError(c.path() + ": key 'detector/response' must be harris or min_eigen, not '" + resp + "'");
  readDouble(c, "detector/harris_k", d.harris_k, 0.0);
  readInt(c, "detector/block_size", d.block_size, 2);
  readInt(c, "detector/sobel_size", d.sobel_size, 1);
  if (d.sobel_size % 2 == 0 || d.sobel_size > 7)
    throw ConfigError(c.path() + ": key 'detector/sobel_size' must be 1, 3, 5 or 7");
  readInt(c, "detector/grid_cols", d.grid_cols, 1);
  readInt(c, "detector/grid_rows", d.grid_rows, 1);
  readInt(c, "detector/max_per_cell", d.max_per_cell, 1);
  readDouble(c, "detector/quality_level", d.quality_level, 0.0);
  readInt(c, "detector/border", d.border, 0);
  readInt(c, "detector/max_detection_width", d.max_detection_width, 16);

  MatcherParams& m = p.matcher;
  readInt(c, "matcher/ncc_half_window", m.ncc_half_window, 1);
  if (m.ncc_half_window > 15) throw ConfigError(c.path() + ": key 'matcher/ncc_half_window' must be <= 15");
  readDouble(c, "matcher/min_patch_std", m.min_patch_std, 0.0);
  readDouble(c, "matcher/min_disparity", m.min_disparity, -16.0);
  readDouble(c, "matcher/max_disparity", m.max_disparity, m.min_disparity + 2);
  readDouble(c, "matcher/intra_min_ncc", m.intra_min_ncc, -1.0);
  readDouble(c, "matcher/intra_uniqueness", m.intra_uniqueness, 0.0);
  m.intra_left_right_check = c.getBool("matcher/intra_left_right_check", m.intra_left_right_check);
  readDouble(c, "matcher/epipolar_tolerance_px", m.epipolar_tolerance_px, 0.0);
  readDouble(c, "matcher/inter_min_ncc", m.inter_min_ncc, -1.0);
  readDouble(c, "matcher/inter_uniqueness", m.inter_uniqueness, 0.0);
  readInt(c, "matcher/window_min_px", m.window_min_px, 1);
  readInt(c, "matcher/window_max_px", m.window_max_px, m.window_min_px);
  readDouble(c, "matcher/window_sigma_scale", m.window_sigma_scale, 0.0);
  readInt(c, "matcher/guided_window_px", m.guided_window_px, 1);
  readDouble(c, "matcher/prior_ok_px", m.prior_ok_px, 0.0);
  readDouble(c, "matcher/prior_ok_fraction", m.prior_ok_fraction, 0.0);
  readDouble(c, "matcher/guide_search_map_px", m.guide_search_map_px, 0.0);

  MotionParams& mo = p.motion;
  readInt(c, "motion/ransac_iterations", mo.ransac_iterations, 1);
  readDouble(c, "motion/pixel_sigma", mo.pixel_sigma, 1e-6);
  readDouble(c, "motion/inlier_chi2", mo.inlier_chi2, 0.0);
  readInt(c, "motion/min_inliers", mo.min_inliers, 3);
  readDouble(c, "motion/min_inlier_ratio", mo.min_inlier_ratio, 0.0);
  readInt(c, "motion/refine_iterations", mo.refine_iterations, 0);
  readDouble(c, "motion/max_depth", mo.max_depth, 0.0);
  int seed = int(mo.ransac_seed);
  readInt(c, "motion/ransac_seed", seed, 0);
  mo.ransac_seed = unsigned(seed);

  FarRotationParams& fr = p.far;
  fr.enabled = c.getBool("far_rotation/enabled", fr.enabled);
  readInt(c, "far_rotation/min_inliers", fr.min_inliers, 2);
  readDouble(c, "far_rotation/inlier_chi2", fr.inlier_chi2, 0.0);
  readInt(c, "far_rotation/ransac_iterations", fr.ransac_iterations, 1);
  readDouble(c, "far_rotation/fuse_chi2", fr.fuse_chi2, 0.0);

  DisparityOffsetParams& dof = p.disparity_offset;
  dof.estimate = c.getBool("disparity_offset/estimate", dof.estimate);
  dof.initial_px = c.getDouble("disparity_offset/initial_px", dof.initial_px);
  readDouble(c, "disparity_offset/gate_chi2", dof.gate_chi2, 0.0);
  readDouble(c, "disparity_offset/apply_sigmas", dof.apply_sigmas, 0.0);
  readInt(c, "disparity_offset/min_observations", dof.min_observations, 0);
  readDouble(c, "disparity_offset/prior_sigma_px", dof.prior_sigma_px, 1e-6);

  PriorParams& pr = p.prior;
  readDouble(c, "prior/cv_rotation_sigma_per_s", pr.cv_rotation_sigma_per_s, 0.0);
  readDouble(c, "prior/cv_translation_sigma_per_s", pr.cv_translation_sigma_per_s, 0.0);
  readDouble(c, "prior/imu_translation_sigma_per_s", pr.imu_translation_sigma_per_s, 0.0);
  readDouble(c, "prior/imu_rotation_sigma", pr.imu_rotation_sigma, 0.0);
  readDouble(c, "prior/max_interval_s", pr.max_interval_s, 0.0);
  return p;
}

TrackerParams loadTrackerParams(const std::string& path) { return loadTrackerParams(Config(path)); }

}  // namespace ips::tracker
