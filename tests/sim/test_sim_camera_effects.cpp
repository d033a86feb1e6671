// The simulator's camera effects (camera/motion_blur, auto_exposure, vignetting, frame_loss) against references: the
// plain rendering where an effect has nothing to do, the head's motion over the exposure, the exposure loop's target,
// cos^4 of the rays from the calibration, and the configured share of lost frames.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "ips/sim/rig.hpp"
#include "sim_test_support.hpp"

using namespace ips::sim;

namespace {

Scenario quiet() { return test_support::quietScenario(); }

double meanAbsLaplacian(const cv::Mat& img) {
  cv::Mat lap;
  cv::Laplacian(img, lap, CV_32F);
  return cv::mean(cv::abs(lap))[0];
}

// A frame in the middle of the walk (the head moving), and one in the still start.
constexpr int64_t kWalkingFrame = 160;  // 20 s at 8 Hz
constexpr int64_t kStillFrame = 4;      // 0.5 s, within the 3 s at rest

}  // namespace

TEST(SimCameraEffects, WithNothingToDoTheEffectsGiveThePlainImage) {
  const Rig plain(quiet());
  Scenario sc = quiet();
  sc.camera.motion_blur = true;  // the head stands still: one sub-image
  const Rig blurred(sc);
  const StereoFrame a = plain.renderer.render(kStillFrame), b = blurred.renderer.render(kStillFrame);
  EXPECT_EQ(b.blur_samples[0], 1);
  EXPECT_EQ(cv::norm(a.left, b.left, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.right, b.right, cv::NORM_INF), 0.0);
  EXPECT_EQ(b.exposure_us[0], sc.camera.exposure_us);
}

TEST(SimCameraEffects, MotionBlurGrowsWithTheExposureAndSmoothsTheImage) {
  Scenario sc = quiet();
  const Rig plain(sc);
  sc.camera.motion_blur = true;
  int previous = 0;
  for (double exposure_us : {2000.0, 12000.0}) {
    sc.camera.exposure_us = exposure_us;
    const Rig blurred(sc);
    const StereoFrame a = plain.renderer.render(kWalkingFrame), b = blurred.renderer.render(kWalkingFrame);
    const double sharp = meanAbsLaplacian(a.left), soft = meanAbsLaplacian(b.left);
    std::printf("[ BLUR     ] %.0f us: %d sub-images, mean |Laplacian| %.3f -> %.3f\n", exposure_us, b.blur_samples[0],
                sharp, soft);
    EXPECT_EQ(b.blur_samples[0] % 2, 1);
    EXPECT_GE(b.blur_samples[0], previous);
    previous = b.blur_samples[0];
    // The mean brightness stays (the exposure's reference is the exposure itself here).
    EXPECT_NEAR(cv::mean(b.left)[0], cv::mean(a.left)[0], 0.02 * cv::mean(a.left)[0]);
  }
  // Walking at 0.75 m/s, 12 ms: streaks of several pixels near the floor, so several sub-images and a softer image.
  EXPECT_GE(previous, 3);
  sc.camera.exposure_us = 12000;
  const Rig blurred(sc);
  EXPECT_LT(meanAbsLaplacian(blurred.renderer.render(kWalkingFrame).left),
            0.95 * meanAbsLaplacian(plain.renderer.render(kWalkingFrame).left));
}

// The reference of the blur: the exposure's integral, here the mean of three times as many renderings over the
// exposure as any tile took, made with the scene renderer directly (float images). Each tile takes only the sub-images
// its own streaks need; the result must be as close to the integral as the whole image at the most sub-images.
TEST(SimCameraEffects, MotionBlurMatchesTheMeanOfRenderingsOverTheExposure) {
  Scenario sc = quiet();
  sc.camera.exposure_us = 12000;
  sc.camera.motion_blur = true;
  const Rig rig(sc);
  const StereoFrame f = rig.renderer.render(kWalkingFrame);
  const int n = f.blur_samples[0];
  ASSERT_GE(n, 3);
  const SceneRenderer scene(rig.world, sc.camera.near_m);
  const View view = View::distorted(rig.head.calibration.cam0);
  const double t = (f.utime_true - sc.start_utime) * 1e-6, exposure_s = sc.camera.exposure_us * 1e-6;
  auto renderAt = [&](double time) {
    cv::Mat radiance;
    scene.render(view, rig.head.cam0InWorld(rig.trajectory.pose(time)), &radiance, nullptr);
    return cv::Mat(radiance * rig.renderer.camera().gain(0));
  };
  auto meanOver = [&](int samples) {
    cv::Mat mean = cv::Mat::zeros(view.height, view.width, CV_32F);
    for (int j = 0; j < samples; ++j) mean += renderAt(t + exposure_s * ((j + 0.5) / samples - 0.5)) / samples;
    return cv::Mat(cv::min(mean, 255.0));  // the camera's 8 bits clip
  };
  const cv::Mat reference = meanOver(3 * n), uniform = meanOver(n), sharp = cv::min(renderAt(t), 255.0);
  cv::Mat blurred;
  f.left.convertTo(blurred, CV_32F);
  auto meanError = [&](const cv::Mat& image) { return cv::mean(cv::abs(image - reference))[0]; };
  cv::Mat uniform8;
  uniform.convertTo(uniform8, CV_8U);  // rounded as the camera rounds
  uniform8.convertTo(uniform8, CV_32F);
  const double error = meanError(blurred), error_uniform = meanError(uniform8), unblurred = meanError(sharp);
  std::printf(
      "[ BLUR     ] against the mean of %d renderings over the exposure, mean |difference| in grey levels: per tile "
      "%.3f, the whole image at %d sub-images %.3f, sharp %.3f\n",
      3 * n, error, n, error_uniform, unblurred);
  // A tile's sub-images lie up to blur_step_px apart, where the whole image at the most sub-images has them closer
  // in the slower tiles: at depth edges that shows as steps of 1/n of the edge's contrast. Measured: 0.037 grey levels
  // more on the mean; rounding to 8 bits alone gives 0.25.
  EXPECT_LT(error, error_uniform + 0.05);
  EXPECT_GT(unblurred, 2 * error);
}

TEST(SimCameraEffects, AutoExposureBringsEachCameraToTheTargetGrey) {
  Scenario sc = quiet();
  sc.camera.auto_exposure = true;
  sc.camera.ae_target_grey = 60;  // well away from what the reference exposure gives
  const Rig rig(sc);
  const Rig plain(quiet());
  for (int64_t k : {kStillFrame, kWalkingFrame, kWalkingFrame + 200}) {
    const StereoFrame f = rig.renderer.render(k), p = plain.renderer.render(k);
    const double grey = cv::mean(f.left)[0], plain_grey = cv::mean(p.left)[0];
    std::printf("[ AE       ] frame %ld: exposure %.0f / %.0f us, gain %.2f / %.2f dB, mean grey %.1f (plain %.1f)\n",
                static_cast<long>(k), f.exposure_us[0], f.exposure_us[1], f.gain_db[0], f.gain_db[1], grey, plain_grey);
    // The loop acted on the previous image (125 ms earlier): within 10 % of the target.
    EXPECT_NEAR(grey, sc.camera.ae_target_grey, 0.1 * sc.camera.ae_target_grey) << k;
    EXPECT_GT(std::abs(plain_grey - sc.camera.ae_target_grey), 0.2 * sc.camera.ae_target_grey) << k;
    // The right camera's higher fixed gain (0.4 dB) takes a shorter exposure; the two differ.
    EXPECT_LT(f.exposure_us[1], f.exposure_us[0]) << k;
    EXPECT_EQ(f.gain_db[0], sc.camera.gain_left_db) << k;  // within the exposure range: no extra gain
  }
  // With the longest exposure too short, the gain makes up for it (up to its bound).
  sc.camera.ae_target_grey = 200;
  sc.camera.ae_max_exposure_us = 2000;
  const Rig dark(sc);
  const StereoFrame f = dark.renderer.render(kWalkingFrame);
  EXPECT_EQ(f.exposure_us[0], 2000.0);
  EXPECT_GT(f.gain_db[0], sc.camera.gain_left_db + 1.0);
  EXPECT_LE(f.gain_db[0], sc.camera.gain_left_db + sc.camera.ae_max_gain_db + 1e-9);
}

TEST(SimCameraEffects, VignettingDimsEachPixelByCos4OfItsRay) {
  Scenario sc = quiet();
  const Rig plain(sc);
  sc.camera.vignetting = true;
  const Rig vignetted(sc);
  const StereoFrame a = plain.renderer.render(kWalkingFrame), b = vignetted.renderer.render(kWalkingFrame);
  // The ray of a pixel from the calibration (OpenCV undistortion), cos^2 = 1 / (1 + x^2 + y^2).
  const ips::CameraIntrinsics& cam = vignetted.head.calibration.cam0;
  int checked = 0;
  double corner_factor = 1;
  for (int y = 8; y < cam.height; y += 101)
    for (int x = 8; x < cam.width; x += 97) {
      const double value = a.left.at<uint8_t>(y, x);
      if (value < 40 || value > 250) continue;  // quantisation and clipping would dominate
      std::vector<cv::Point2f> px{cv::Point2f(x, y)}, ray;
      cv::undistortPoints(px, ray, cam.cvK(), cam.cvDistortion(), cv::noArray(), cv::noArray(),
                          cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-12));
      const double d2 = 1 + ray[0].x * ray[0].x + ray[0].y * ray[0].y, factor = 1 / (d2 * d2);
      if (x < 100 && y < 100) corner_factor = factor;
      // Both images are rounded to grey levels.
      EXPECT_NEAR(b.left.at<uint8_t>(y, x), value * factor, 1.0) << x << "," << y;
      ++checked;
    }
  EXPECT_GT(checked, 50);
  EXPECT_LT(corner_factor, 0.5);  // the 85 deg lens loses more than half the light in its corners
}

TEST(SimCameraEffects, FramesAreLostAtTheConfiguredRateAndLeaveAGap) {
  Scenario sc = Scenario::defaults();
  sc.camera.frame_loss = 0.05;
  const Rig rig(sc);
  int lost = 0;
  const int n = 4000;
  for (int64_t k = 0; k < n; ++k) lost += rig.renderer.camera().frameLost(k) ? 1 : 0;
  // Binomial: 200 expected, sigma 14.
  EXPECT_NEAR(lost, 0.05 * n, 4 * std::sqrt(n * 0.05 * 0.95));
  int64_t k = 0;
  while (!rig.renderer.camera().frameLost(k)) ++k;
  const StereoFrame f = rig.renderer.render(k);
  EXPECT_TRUE(f.lost);
  EXPECT_TRUE(f.left.empty());
  // Without losses configured none is lost, and the stamps (jitter) do not depend on the setting.
  const Rig none(Scenario::defaults());
  EXPECT_FALSE(none.renderer.camera().frameLost(k));
  EXPECT_EQ(none.renderer.render(k).utime_stamp, f.utime_stamp);
}
