// Disparity from one camera on the simulated walk: two exposures of the left camera, rectified for their relative
// pose (polar rectification) and matched by E3D's SGM on Vulkan (lavapipe without a GPU), against the simulator's
// truth; and the same pair rectified with a pose one degree off, which the truth must find far worse.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "ips/config.hpp"
#include "ips/e3d/mono_depth.hpp"
#include "ips/e3d/stereo_matcher.hpp"
#include "ips/e3d/vulkan_context.hpp"
#include "ips/eval/disparity.hpp"
#include "ips/polar_rectification.hpp"
#include "ips/sim/mono_truth.hpp"
#include "ips/sim/rig.hpp"

namespace ips {
namespace {

struct Figures {
  double bad2 = 0, density = 0;
};

// bad 2.0 (radially, in full-resolution px: a polar disparity step is P.dr of them) and density inside the mask,
// as mono_disparity_eval scores them.
Figures score(const PolarRectification& P, const cv::Mat& disparity, const cv::Mat& truth) {
  const eval::DisparityErrors e = eval::disparityErrors(
      eval::disparityPixels(disparity, e3d::kInvalidDisparity, e3d::kSubpixelScale), truth, {2.0}, P.valid, P.dr);
  EXPECT_GT(e.evaluated, e.pixels / 2);
  return {e.badPct(0), e.densityPct()};
}

// The simulated walk and the deployed E3D configuration.
struct Walk : sim::Rig {
  Walk() : Rig(sim::Scenario::defaults()) {}
  sim::SceneRenderer scene{world, scenario.camera.near_m};
  Config cfg{std::string(IPS_SOURCE_DIR) + "/config/e3d_sim.yaml"};
  Eigen::Isometry3d pose(const sim::StereoFrame& f) const {
    return head.cam0InWorld(trajectory.pose((f.utime_true - scenario.start_utime) * 1e-6));
  }
};

TEST(MonoDisparity, TwoExposuresOfTheLeftCameraAgainstTheTruth) {
  const Walk w;
  const sim::SensorHead& head = w.head;
  const sim::StereoRenderer& renderer = w.renderer;
  const sim::SceneRenderer& scene = w.scene;
  const Config& cfg = w.cfg;
  PolarRectificationParams polar = PolarRectificationParams::fromConfig(cfg.section("mono"));
  polar.size = cv::Size(256, 1024);  // a quarter of the deployed polar image: same geometry, coarser steps
  e3d::VulkanContext ctx;
  e3d::StereoMatcher matcher(ctx, polar.size, e3d::SgmParams::fromConfig(cfg.section("sgm")));
  const cv::Size raw(head.calibration.cam0.width, head.calibration.cam0.height);

  // 25 s into the walk, walking ahead: frames two apart (0.19 m), the epipole inside the image.
  const int64_t k = 200, gap = 2;
  const sim::StereoFrame fa = renderer.render(k), fb = renderer.render(k + gap);
  const Eigen::Isometry3d W_a = w.pose(fa), W_b = w.pose(fb);
  const Eigen::Isometry3d T_a_b = W_a.inverse() * W_b;
  ASSERT_GT(T_a_b.translation().norm(), 0.1);

  const auto run = [&](const Eigen::Isometry3d& pose) {
    const PolarRectification P = polarRectification(head.calibration.cam0, pose, polar);
    matcher.setRectification(P.maps, raw);
    const cv::Mat d = matcher.matchRaw(P.left_is_b ? fb.left : fa.left, P.left_is_b ? fa.left : fb.left).disparity;
    cv::Mat truth, range;
    sim::polarDisparityTruth(P, scene, W_a, W_b, truth, range);
    return score(P, d, truth);
  };
  const Figures good = run(T_a_b);
  std::printf("true pose: bad2 %.2f %% density %.2f %%\n", good.bad2, good.density);
  EXPECT_LT(good.bad2, 8.0);
  EXPECT_GT(good.density, 90.0);

  // One degree of pitch error moves every epipolar line: rows no longer match.
  Eigen::Isometry3d off = T_a_b;
  off.linear() = T_a_b.linear() * Eigen::AngleAxisd(M_PI / 180, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Figures wrong = run(off);
  std::printf("pose 1 deg off: bad2 %.2f %% density %.2f %%\n", wrong.bad2, wrong.density);
  EXPECT_GT(wrong.bad2, good.bad2 + 10.0);
}

// MonoDepth, as the E3D process runs it with config/e3d_sim.yaml's section mono: its points lie at the true range
// of the rays they were seen on, and a head that has hardly moved gives no map.
TEST(MonoDisparity, MonoDepthPointsLieAtTheTrueRange) {
  const Walk w;
  const e3d::MonoDepthParams params = e3d::MonoDepthParams::fromConfig(w.cfg.section("mono"));
  e3d::VulkanContext ctx;
  e3d::MonoDepth mono(ctx, w.head.calibration.cam0, e3d::SgmParams::fromConfig(w.cfg.section("sgm")), params);
  const int64_t k = 480;
  const sim::StereoFrame fa = w.renderer.render(k), fb = w.renderer.render(k + params.gap_pairs);
  const Eigen::Isometry3d W_a = w.pose(fa), W_b = w.pose(fb);
  const e3d::MonoDepthResult r = mono.compute(fa.left, fb.left, W_a.inverse() * W_b);
  ASSERT_TRUE(r.matched);
  cv::Mat truth, range;
  sim::polarDisparityTruth(mono.rectification(), w.scene, W_a, W_b, truth, range);
  std::vector<double> errors;
  const Eigen::Vector3d centre = mono.rectification().leftCentre();
  for (size_t i = 0; i < r.points.size(); ++i) {
    const float g = range.at<float>(r.pixels[i]);
    if (std::isfinite(g)) errors.push_back(std::abs((r.points[i].cast<double>() - centre).norm() - g) / g);
  }
  ASSERT_GT(errors.size(), 10000u);  // of 128 x 512 sampled pixels, those the precision rule keeps
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  std::printf("%zu points, median range error %.2f %%, density %.1f %%\n", r.points.size(),
              100 * errors[errors.size() / 2], 100.0 * r.valid / r.masked);
  EXPECT_LT(errors[errors.size() / 2], 0.02);
  EXPECT_GT(double(r.valid) / r.masked, 0.9);

  Eigen::Isometry3d still = Eigen::Isometry3d::Identity();
  still.translation() = Eigen::Vector3d(0, 0, 0.5 * params.min_baseline_m);
  EXPECT_FALSE(mono.compute(fa.left, fa.left, still).matched);
}

}  // namespace
}  // namespace ips
