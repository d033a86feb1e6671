#pragma once
// Rendering of the world into cameras. A View holds, for every pixel, the direction of its ray (normalised
// image coordinates x/z, y/z of the ideal pinhole), so a lens with distortion is rendered directly (no
// resampling of an ideal image) and ground truth is exact per pixel. Each quad is rasterised over the 32x32
// pixel tiles its projection can touch: per pixel one ray-plane intersection, a depth test, and then one
// shading pass with trilinear mip-mapped texture lookup for the visible surface only. Both cores are used.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "ips/calibration.hpp"
#include "ips/sim/scenario.hpp"
#include "ips/sim/sensors.hpp"
#include "ips/sim/trajectory.hpp"
#include "ips/sim/world.hpp"

namespace ips::sim {

struct View {
  int width = 0, height = 0;
  double focal = 1;           // [px] for the texture level of detail
  std::vector<float> rx, ry;  // per pixel: ray direction (rx, ry, 1) in the camera frame
  static constexpr int kTile = 32;
  int tiles_x = 0, tiles_y = 0;
  std::vector<cv::Vec4f> tile_bounds;  // per tile: min x, max x, min y, max y of its rays

  static View pinhole(const Eigen::Matrix3d& K, cv::Size size);
  // A real lens: each pixel's ray from undistorting its centre (OpenCV model).
  static View distorted(const CameraIntrinsics& camera);
  // Any pixel layout (a polar rectification's): rays (rx, ry, 1) per pixel, row-major, width * height of them.
  static View fromRays(int width, int height, double focal, std::vector<float> rx, std::vector<float> ry);

 private:
  void computeTiles();
};

class SceneRenderer {
 public:
  // The world must outlive the renderer and not change (textures are referenced).
  explicit SceneRenderer(const World& world, double near_m = 0.05);
  // The scene at scenario time t [s]: the world's static surfaces and its people where they are at t. Any of radiance
  // (CV_32F, grey levels before gain and noise) and depth (CV_32F, z [m] in the camera frame, 0 where nothing was hit)
  // may be null. T_world_cam: camera pose (OpenCV camera frame). With `tiles` (one entry per View tile, row-major)
  // only the tiles marked non-zero are drawn; the rest of radiance and depth is 0.
  void render(const View& view, const Eigen::Isometry3d& T_world_cam, double t, cv::Mat* radiance, cv::Mat* depth,
              const std::vector<uint8_t>* tiles = nullptr) const;
  // The static world alone (no people): what does not depend on time.
  void render(const View& view, const Eigen::Isometry3d& T_world_cam, cv::Mat* radiance, cv::Mat* depth) const;

  struct Buffers {  // per view: depth and index of the visible quad
    std::vector<float> z;
    std::vector<int32_t> id;
  };
  struct CamQuad;
  struct TexLevel {  // one mip level, for the inner loop
    const uint8_t* data;
    size_t step;
    int wmask, hmask;  // sides are powers of two
    float scale;       // 2^-level
  };
  // The world's static quads and `moving` ones (the people at some time; they must outlive the result, which points
  // at them) as the camera sees them, nearest first.
  std::vector<CamQuad> prepare(const Eigen::Isometry3d& T_world_cam, const std::vector<Quad>* moving = nullptr) const;
  const World& world() const { return world_; }
  // One row of tiles; with `tiles` (one flag per tile of the view) only the marked ones.
  void raster(const View& view, const std::vector<CamQuad>& quads, Buffers& buf, int tile_row,
              const uint8_t* tiles = nullptr) const;
  // Shades pixels [x_begin, x_end) of one row (x_end < 0: to the row's end) into `out` (grey levels): gain * radiance
  // + noise (Irwin-Hall, per-row stream), rounded to 8 bit if out8 is set, else float radiance into out32. out8 and
  // out32 point at the row's first pixel.
  void shadeRow(const View& view, const std::vector<CamQuad>& quads, const Buffers& buf, int row, float gain,
                float noise_sigma, uint64_t noise_seed, uint8_t* out8, float* out32, int x_begin = 0,
                int x_end = -1) const;

 private:
  void renderQuads(const View& view, const std::vector<CamQuad>& quads, cv::Mat* radiance, cv::Mat* depth,
                   const std::vector<uint8_t>* tiles) const;

  const World& world_;
  double near_;
  std::vector<std::vector<TexLevel>> levels_;  // per texture
};

struct SceneRenderer::CamQuad {
  float n[3], c;   // plane n . X = c in the camera frame (n unit)
  float e[3], s0;  // s = X . e - s0
  float f[3], t0;  // t = X . f - t0
  float size_s, size_t;
  float bounds[4];   // min x, max x, min y, max y of the clipped projection (normalised coordinates)
  float min_z;       // nearest depth of the clipped rectangle (quads are drawn front to back)
  const Quad* quad;  // in World::quads or among the moving quads given to prepare()
};

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

// What a camera's exposure loop chose for one image.
struct Exposure {
  double exposure_us = 0;
  double gain = 1;  // linear, on top of the camera's fixed gain
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
  float gain(int camera) const { return camera == 0 ? gain_[0] : gain_[1]; }
  // Whether frame k is lost on the way (camera/frame_loss; independent per frame, from the frame's seed).
  bool frameLost(int64_t k) const;
  // The exposure camera 0 or 1 uses for frame k: the configured one, or with auto exposure the one that brings the
  // camera's image k-1 to the target grey (a function of k alone, so frames still render in any order).
  Exposure exposureFor(int64_t k, int camera) const;
  // Mean grey level camera 0 or 1 would see at time t [s] (relative to the scenario start) with the reference
  // exposure and no gain (vignetting and the lighting zones included), from every fourth pixel's ray.
  double meanGrey(double t, int camera) const;

 private:
  // The camera's pose in world at time t [s].
  Eigen::Isometry3d cameraInWorld(double t, int camera) const;
  // Renders camera c's image of frame k with the effects on: radiance integrated over the exposure, vignetting,
  // exposure and gain, then noise, into out (CV_8UC1).
  void renderWithEffects(int64_t k, int c, double t, const Exposure& e, cv::Mat& out, int* samples) const;
  // The sub-images motion blur needs in each tile of camera c's view (row-major, View::kTile): 3^k for the least k
  // that keeps neighbouring sub-images at most blur_step_px apart, at most max_blur_samples. The image motion over the
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
  View raw_[2];
  StereoRectification rect_;
  View rect_view_;
  float gain_[2];
  bool effects_ = false;  // any of motion blur, auto exposure, vignetting
  View ae_view_[2];       // every fourth pixel of each camera: what the exposure loop measures
  std::vector<float> vignette_[2], ae_vignette_[2];  // per pixel illumination factor (1 without vignetting)
};

}  // namespace ips::sim
