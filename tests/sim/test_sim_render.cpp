// Rendered stereo pairs against the ground truth: after rectification with the written calibration, the right
// image warped by the ground-truth disparity matches the left one to about the noise level; the rectified left
// image matches a direct pinhole rendering; ground-truth depth put through the calibration and the ground-truth
// pose lands on the floor and ceiling of the building.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "ips/calibration.hpp"
#include "ips/shared_data_test.hpp"
#include "ips/sim/stereo_renderer.hpp"

using namespace ips::sim;

namespace {

struct Fixture {
  Scenario sc = Scenario::defaults();
  World world;
  SensorHead head;
  Trajectory traj;
  std::unique_ptr<StereoRenderer> renderer;
  Fixture() : world(World::build(sc.world, sc.seed)), head(SensorHead::make(sc)), traj(sc.trajectory, sc.gravity) {
    renderer = std::make_unique<StereoRenderer>(sc, world, head, traj);
  }
};

Fixture& fixture() {
  static Fixture f;
  return f;
}

float bilinear(const cv::Mat& img, float x, float y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const float a = x - x0, b = y - y0;
  const float p00 = img.at<uint8_t>(y0, x0), p01 = img.at<uint8_t>(y0, x0 + 1);
  const float p10 = img.at<uint8_t>(y0 + 1, x0), p11 = img.at<uint8_t>(y0 + 1, x0 + 1);
  return (1 - b) * ((1 - a) * p00 + a * p01) + b * ((1 - a) * p10 + a * p11);
}

struct Residual {
  double median_abs = 0, rms = 0;
  size_t count = 0;
};

// Left minus right-warped-by-(disparity + shift), gain corrected, over pixels seen by both cameras.
Residual photometric(const cv::Mat& rl, const cv::Mat& rr, const cv::Mat& dl, const cv::Mat& dr, float gain_ratio,
                     float shift) {
  std::vector<double> err;
  const int border = 24;
  for (int y = border; y < rl.rows - border; ++y)
    for (int x = border; x < rl.cols - border; ++x) {
      const float d = dl.at<float>(y, x);
      if (!(d > 0)) continue;
      const float xr = x - d - shift;
      if (xr < border || xr > rl.cols - border) continue;
      const float d_right = dr.at<float>(y, static_cast<int>(std::lround(xr)));
      if (std::abs(d_right - d) > 0.5f) continue;  // occluded in the right view
      err.push_back(rl.at<uint8_t>(y, x) - gain_ratio * bilinear(rr, xr, static_cast<float>(y)));
    }
  Residual r;
  r.count = err.size();
  if (err.empty()) return r;
  double sq = 0;
  for (double e : err) sq += e * e;
  r.rms = std::sqrt(sq / err.size());
  for (double& e : err) e = std::abs(e);
  std::nth_element(err.begin(), err.begin() + err.size() / 2, err.end());
  r.median_abs = err[err.size() / 2];
  return r;
}

}  // namespace

TEST(SimRender, RectifiedPairAgreesWithGroundTruthDisparity) {
  Fixture& f = fixture();
  const float gain_ratio = f.renderer->camera().gain(0) / f.renderer->camera().gain(1);
  // Noise of the difference of two pixels: sqrt(2) sigma; |N(0, s)| has median 0.674 s.
  const double noise_median = 0.674 * std::sqrt(2.0) * f.sc.camera.noise_sigma;
  for (int64_t k : {40, 112}) {  // in the corridor; turning into the room
    const StereoFrame frame = f.renderer->render(k, true);
    cv::Mat rl, rr;
    ips::rectifyPair(f.renderer->rectification(), frame.left, frame.right, rl, rr);
    const double t = (frame.utime_true - f.sc.start_utime) * 1e-6;
    const cv::Mat dl = frame.gt_disparity;
    const cv::Mat dr = f.renderer->disparityFromDepth(f.renderer->rectifiedDepth(t, 1));
    const Residual good = photometric(rl, rr, dl, dr, gain_ratio, 0);
    const Residual off = photometric(rl, rr, dl, dr, gain_ratio, 1.0f);
    std::cout << "frame " << k << ": " << good.count << " pixels, |error| median " << good.median_abs
              << " (noise alone " << noise_median << "), rms " << good.rms << "; with disparity off by 1 px: median "
              << off.median_abs << ", rms " << off.rms << "\n";
    EXPECT_GT(good.count, static_cast<size_t>(0.6 * rl.total()));
    EXPECT_LT(good.median_abs, 1.5 * noise_median);
    EXPECT_LT(good.rms, 3.0 * f.sc.camera.noise_sigma);
    EXPECT_GT(off.median_abs, 1.3 * good.median_abs);  // the check can tell a 1 px error
  }
}

TEST(SimRender, RectifiedLeftMatchesPinholeRendering) {
  Fixture& f = fixture();
  const ips::StereoRectification& rect = f.renderer->rectification();
  Eigen::Matrix3d K;
  K << rect.f, 0, rect.cx, 0, rect.f, rect.cy, 0, 0, 1;
  const View pinhole = View::pinhole(K, rect.size);
  const int64_t k = 40;
  const StereoFrame frame = f.renderer->render(k);
  cv::Mat rl, rr;
  ips::rectifyPair(rect, frame.left, frame.right, rl, rr);
  const double t = (frame.utime_true - f.sc.start_utime) * 1e-6;
  Eigen::Isometry3d T_cam0_rect0 = Eigen::Isometry3d::Identity();
  T_cam0_rect0.linear() = rect.R_rect0_cam0.transpose();
  cv::Mat radiance;
  SceneRenderer(f.world).render(pinhole, f.head.cam0InWorld(f.traj.pose(t)) * T_cam0_rect0, &radiance, nullptr);
  cv::Mat diff;
  cv::Mat rl32;
  rl.convertTo(rl32, CV_32F);
  cv::absdiff(rl32, radiance * f.renderer->camera().gain(0), diff);
  const cv::Rect inner(24, 24, diff.cols - 48, diff.rows - 48);
  const cv::Mat roi = diff(inner).clone();
  std::vector<float> v(roi.begin<float>(), roi.end<float>());
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  const double median = v[v.size() / 2];
  std::cout << "rectified left vs pinhole rendering: median |difference| " << median << "\n";
  EXPECT_LT(median, 0.674 * f.sc.camera.noise_sigma * 1.5);
}

// Depth from the rectified left view, back through R_rect0_cam0, T_imu_cam0 of the saved calibration and the
// ground-truth pose: the bottom centre sees the floor (z = 0), the top centre the ceiling.
TEST(SimRender, GroundTruthFramesAreConsistent) {
  Fixture& f = fixture();
  const std::string path = testing::TempDir() + "/sim_calib.yaml";
  ips::saveCalibration(path, f.head.calibration);
  const ips::StereoCalibration cal = ips::loadCalibration(path);
  EXPECT_NEAR(cal.baseline(), f.sc.camera.baseline_m, 0.01);
  const ips::StereoRectification& rect = f.renderer->rectification();
  for (double t : {5.0, 20.0, 70.0}) {
    const cv::Mat depth = f.renderer->rectifiedDepth(t, 0);
    const Eigen::Isometry3d T_world_imu = f.traj.pose(t);
    auto worldPoint = [&](int x, int y) {
      const double z = depth.at<float>(y, x);
      const Eigen::Vector3d X_rect(z * (x - rect.cx) / rect.f, z * (y - rect.cy) / rect.f, z);
      return T_world_imu * (cal.T_imu_cam0 * (rect.R_rect0_cam0.transpose() * X_rect));
    };
    const int cx = static_cast<int>(rect.cx);
    EXPECT_NEAR(worldPoint(cx, depth.rows - 1).z(), 0.0, 0.003) << "t=" << t;
    EXPECT_NEAR(worldPoint(cx, 0).z(), f.sc.world.wall_height_m, 0.003) << "t=" << t;
  }
}

TEST(SimRender, WorldUsesPhotographsAndFallsBack) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  Scenario sc = Scenario::defaults();
  const World world = World::build(sc.world, sc.seed);
  EXPECT_GT(world.photo_count, 0) << "no photographs under " << ips::dataDir();
  sc.world.data_dir = "/nonexistent";
  const World fallback = World::build(sc.world, sc.seed);
  EXPECT_EQ(fallback.photo_count, 0);
  EXPECT_EQ(fallback.quads.size(), world.quads.size());
}
