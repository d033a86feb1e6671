// Tracker parameters from YAML: config/tracker.yaml holds exactly the built-in defaults, and bad values are
// reported with file and key.
#include <gtest/gtest.h>

#include "ips/test_support/temp_yaml.hpp"
#include "ips/tracker/params.hpp"

using ips::test_support::writeTempYaml;

using namespace ips::tracker;

TEST(Params, ConfigFileWritesOutTheDefaults) {
  const TrackerParams file = loadTrackerParams(std::string(IPS_SOURCE_DIR) + "/config/tracker.yaml");
  const TrackerParams def;
  EXPECT_EQ(file.detector.response, def.detector.response);
  EXPECT_EQ(file.detector.grid_cols, def.detector.grid_cols);
  EXPECT_EQ(file.detector.max_per_cell, def.detector.max_per_cell);
  EXPECT_EQ(file.detector.max_detection_width, def.detector.max_detection_width);
  EXPECT_DOUBLE_EQ(file.detector.quality_level, def.detector.quality_level);
  EXPECT_EQ(file.matcher.ncc_half_window, def.matcher.ncc_half_window);
  EXPECT_DOUBLE_EQ(file.matcher.max_disparity, def.matcher.max_disparity);
  EXPECT_DOUBLE_EQ(file.matcher.inter_min_ncc, def.matcher.inter_min_ncc);
  EXPECT_EQ(file.matcher.intra_left_right_check, def.matcher.intra_left_right_check);
  EXPECT_EQ(file.matcher.window_max_px, def.matcher.window_max_px);
  EXPECT_DOUBLE_EQ(file.motion.pixel_sigma, def.motion.pixel_sigma);
  EXPECT_DOUBLE_EQ(file.motion.inlier_chi2, def.motion.inlier_chi2);
  EXPECT_EQ(file.motion.min_inliers, def.motion.min_inliers);
  EXPECT_DOUBLE_EQ(file.prior.cv_rotation_sigma_per_s, def.prior.cv_rotation_sigma_per_s);
  EXPECT_DOUBLE_EQ(file.prior.imu_translation_sigma_per_s, def.prior.imu_translation_sigma_per_s);
  EXPECT_EQ(file.disparity_offset.estimate, def.disparity_offset.estimate);
  EXPECT_DOUBLE_EQ(file.disparity_offset.initial_px, def.disparity_offset.initial_px);
  EXPECT_DOUBLE_EQ(file.disparity_offset.gate_chi2, def.disparity_offset.gate_chi2);
  EXPECT_DOUBLE_EQ(file.disparity_offset.apply_sigmas, def.disparity_offset.apply_sigmas);
  EXPECT_EQ(file.disparity_offset.min_observations, def.disparity_offset.min_observations);
  EXPECT_DOUBLE_EQ(file.disparity_offset.prior_sigma_px, def.disparity_offset.prior_sigma_px);
}

TEST(Params, PartialFileOverridesOnlyItsKeys) {
  const TrackerParams p = loadTrackerParams(writeTempYaml("partial.yaml",
                                                          "detector:\n  response: min_eigen\n"
                                                          "matcher:\n  ncc_half_window: 7\n"));
  EXPECT_EQ(p.detector.response, CornerResponse::MinEigen);
  EXPECT_EQ(p.matcher.ncc_half_window, 7);
  EXPECT_EQ(p.detector.grid_cols, TrackerParams().detector.grid_cols);
}

TEST(Params, BadValuesNameFileAndKey) {
  for (const std::string& text :
       {std::string("detector:\n  response: fast\n"), std::string("matcher:\n  ncc_half_window: 0\n"),
        std::string("detector:\n  sobel_size: 4\n"), std::string("motion:\n  min_inliers: 2\n"),
        std::string("matcher:\n  max_disparity: 0.5\n"), std::string("disparity_offset:\n  apply_sigmas: -1\n")}) {
    const std::string path = writeTempYaml("bad.yaml", text);
    try {
      loadTrackerParams(path);
      FAIL() << "accepted: " << text;
    } catch (const ips::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("bad.yaml"), std::string::npos) << e.what();
      const std::string key = text.substr(text.find("  ") + 2, text.find(':', text.find("  ")) - text.find("  ") - 2);
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  }
}
