#pragma once
// The scene renderer: the world as an ideal camera sees it, radiance and depth, with no camera physics. A View holds,
// for every pixel, the direction of its ray (normalised image coordinates x/z, y/z of the ideal pinhole), so a lens
// with distortion is rendered directly (no resampling of an ideal image) and ground truth is exact per pixel. Each
// quad is rasterised over the 32x32 pixel tiles its projection can touch: per pixel one ray-plane intersection, a
// depth test, and then one shading pass with trilinear mip-mapped texture lookup for the visible surface only. Both
// cores are used. What a camera makes of the radiance is the camera model's (camera_model.hpp).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "ips/calibration.hpp"
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
  // + noise (Irwin-Hall, per-row stream), rounded to 8 bit if out8 is set, else float radiance into out32. The gain
  // and the noise are the camera model's figures; they are applied in this pass, while the radiance is at hand, when
  // the camera has no effect that needs the whole radiance image first (exposure loop, vignetting, motion blur). out8
  // and out32 point at the row's first pixel.
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

}  // namespace ips::sim
