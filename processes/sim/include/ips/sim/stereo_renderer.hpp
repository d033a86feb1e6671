#pragma once
// The simulated stereo head's images: the scene renderer (scene_renderer.hpp) draws the world where each camera is
// at the frame's times, the camera model (camera_model.hpp) turns the radiance into the images the cameras deliver,
// and the ground truth (the rectified left camera's depth and disparity) is rendered from the same scene.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "ips/calibration.hpp"
#include "ips/sim/camera_model.hpp"
#include "ips/sim/scenario.hpp"
#include "ips/sim/scene_renderer.hpp"
#include "ips/sim/sensors.hpp"
#include "ips/sim/trajectory.hpp"
#include "ips/sim/world.hpp"

namespace ips::sim {

struct StereoFrame {
  int64_t seq = 0;
  int64_t utime_true = 0;          // exposure mid-time
  int64_t utime_stamp = 0;         // with the camera's stamp offset and jitter
  int64_t utime_arrival = 0;       // delivered after the camera's latency
  cv::Mat left, right;             // raw CV_8UC1, as the cameras deliver them
  cv::Mat gt_disparity;            // CV_32F of the rectified left image, when asked for; 0 = nothing seen
  bool lost = false;               // dropped on the way (camera/frame_loss): no images
  double exposure_us[2] = {0, 0};  // left, right: the exposure each camera used
  double gain_db[2] = {0, 0};      // and its gain (the fixed one plus the auto exposure's)
  int blur_samples[2] = {1, 1};    // the most sub-images any tile integrated over the exposure (1: no motion blur)
};

class StereoRenderer {
 public:
  StereoRenderer(const Scenario& scenario, const World& world, const SensorHead& head, const Trajectory& trajectory);

  // Frame k (at sampleUtime(start, k, camera rate)).
  StereoFrame render(int64_t k, bool with_gt_disparity = false) const;
  // Depth (z [m]) of the rectified camera 0 or 1 at time t [s] (for evaluation).
  cv::Mat rectifiedDepth(double t, int camera) const;
  // Disparity of the rectified left image from its depth: f * baseline / z (0 where z == 0).
  cv::Mat disparityFromDepth(const cv::Mat& depth) const;

  const StereoRectification& rectification() const { return rect_; }
  const CameraModel& camera() const { return camera_; }
  // The exposure camera 0 or 1 uses for frame k: the configured one, or with auto exposure the one that brings the
  // camera's image k-1 to the target grey (a function of k alone, so frames still render in any order).
  Exposure exposureFor(int64_t k, int camera) const;
  // Mean grey level camera 0 or 1 would see at time t [s] (relative to the scenario start) with the reference
  // exposure and no gain (vignetting and the lighting zones included), from every fourth pixel's ray.
  double meanGrey(double t, int camera) const;

 private:
  // The camera's pose in world at time t [s].
  Eigen::Isometry3d cameraInWorld(double t, int camera) const;
  // Renders camera c's image of frame k with the effects on: radiance integrated over the exposure, then the camera
  // model's image formation into out (CV_8UC1).
  void renderWithEffects(int64_t k, int c, double t, const Exposure& e, cv::Mat& out, int* samples) const;
  // The sub-images motion blur needs in each tile of camera c's view (row-major, View::kTile): the camera model's
  // CameraModel::blurSamples for the longest streak that reaches the tile. The image motion over the
  // exposure is measured on the points seen in depth (z [m] at the exposure's middle, 0 where nothing is seen) on a
  // 16-pixel grid, those on a person moving with it; a streak counts in every tile it reaches. The cameras at the
  // exposure's start (time t_a), middle and end (t_b) in world.
  std::vector<int> blurSamplesPerTile(const cv::Mat& depth, int c, const Eigen::Isometry3d& T_world_a,
                                      const Eigen::Isometry3d& T_world_mid, const Eigen::Isometry3d& T_world_b,
                                      double t_a, double t_b) const;

  const Scenario& scenario_;
  const World& world_;
  const SensorHead& head_;
  const Trajectory& trajectory_;
  SceneRenderer scene_;
  CameraModel camera_;
  StereoRectification rect_;
  View rect_view_;
};

}  // namespace ips::sim
