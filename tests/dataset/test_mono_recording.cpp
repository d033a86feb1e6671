// Depth from one camera on a real recording: KITTI 06, the left images of two frames 1.2 m apart along the street,
// rectified with the recording's ground-truth poses and matched by E3D on Vulkan (lavapipe without a GPU), against
// E3D's stereo map of the first frame (0.54 m baseline). With the baseline 20 % too long, the depths from one camera
// are 20 % too far, and the comparison must see it.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include "ips/config.hpp"
#include "ips/dataset/dataset.hpp"
#include "ips/e3d/mono_depth.hpp"
#include "ips/e3d/stereo_matcher.hpp"
#include "ips/e3d/vulkan_context.hpp"
#include "ips/shared_data_test.hpp"

namespace ips {
namespace {

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

TEST(MonoRecording, KittiDepthFromOneCameraAgreesWithTheStereoMap) {
  const std::string dir = ips::dataDir() + "/kitti_odometry/06_first51";
  if (!std::filesystem::exists(dir)) GTEST_SKIP() << dir << " is not here";
  const dataset::Recording rec = dataset::readRecording("kitti", dir, {});
  ASSERT_GE(rec.ground_truth.size(), 27u);
  const Config cfg(std::string(IPS_SOURCE_DIR) + "/config/e3d_recording.yaml");
  const e3d::SgmParams sgm = e3d::SgmParams::fromConfig(cfg.section("sgm"));
  const StereoRectification rect = scaledRectification(rec.calib, cfg.getDouble("process/output_scale", 1.0));
  const cv::Size raw(rec.calib.cam0.width, rec.calib.cam0.height);
  e3d::VulkanContext ctx;
  e3d::StereoMatcher stereo(ctx, rect.size, sgm);
  stereo.setRectification(rect, raw);
  e3d::MonoDepthParams params;  // the defaults, as config/e3d_recording.yaml leaves them
  params.point_step = 1;
  e3d::MonoDepth mono(ctx, rec.calib.cam0, sgm, params);

  // KITTI's poses are of the left camera, one per frame.
  const size_t a = 25, b = 26;
  const Eigen::Isometry3d W_a = dataset::cameraPose(rec.ground_truth[a], rec.calib);
  const Eigen::Isometry3d W_b = dataset::cameraPose(rec.ground_truth[b], rec.calib);
  const cv::Mat left_a = dataset::loadImage(rec.frames[a].left_path, raw.width, raw.height);
  const cv::Mat right_a = dataset::loadImage(rec.frames[a].right_path, raw.width, raw.height);
  const cv::Mat left_b = dataset::loadImage(rec.frames[b].left_path, raw.width, raw.height);
  const cv::Mat stereo_map = stereo.matchRaw(left_a, right_a).disparity;

  const Eigen::Isometry3d T_a_b = W_a.inverse() * W_b;
  ASSERT_GT(T_a_b.translation().norm(), 1.0);
  const e3d::MonoDepthResult r = mono.compute(left_a, left_b, T_a_b);
  ASSERT_TRUE(r.matched);
  const std::vector<double> diff = e3d::depthDifferences(r, rect, stereo_map);
  ASSERT_GT(diff.size(), 10000u);
  const double within =
      double(std::count_if(diff.begin(), diff.end(), [](double x) { return x < 0.05; })) / diff.size();
  std::printf("%zu points beside the stereo map: median difference %.2f %%, within 5 %%: %.1f %%\n", diff.size(),
              100 * median(diff), 100 * within);
  EXPECT_LT(median(diff), 0.03);
  EXPECT_GT(within, 0.85);

  Eigen::Isometry3d too_long = T_a_b;
  too_long.translation() *= 1.2;
  const std::vector<double> off = e3d::depthDifferences(mono.compute(left_a, left_b, too_long), rect, stereo_map);
  ASSERT_GT(off.size(), 10000u);
  std::printf("baseline 20 %% too long: median difference %.2f %%\n", 100 * median(off));
  EXPECT_GT(median(off), 0.12);
}

}  // namespace
}  // namespace ips
