#pragma once
// The simulated building: textured planar rectangles (walls with door openings, floors, ceilings, posters,
// cabinets and boxes). Textures are procedural (rough plaster, tiles, terrazzo, weak plaster) and real
// photographs read at run time from the evaluation data (falls back to procedural with a warning).
#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "ips/sim/scenario.hpp"

namespace ips::sim {

// A texture with its mip pyramid; every level is CV_8UC1 with power-of-two sides (addressing wraps).
struct Texture {
  std::string name;
  std::vector<cv::Mat> levels;
};

// A rectangle: points origin + s * axis_s + t * axis_t for s in [0, size_s], t in [0, size_t].
struct Quad {
  Eigen::Vector3d origin;
  Eigen::Vector3d axis_s;         // unit
  Eigen::Vector3d axis_t;         // unit, orthogonal to axis_s
  double size_s = 1, size_t = 1;  // [m]
  int texture = 0;
  double texel_s = 0.004, texel_t = 0.004;  // [m] per level-0 texel
  Eigen::Vector2d texture_offset{0, 0};     // [texels]
  float brightness = 1.0f;                  // multiplies the texture (illumination, albedo)
  bool one_sided = false;                   // seen only from the side axis_s x axis_t points to
  Eigen::Vector3d normal() const { return axis_s.cross(axis_t); }
};

struct World {
  std::vector<Quad> quads;
  std::vector<Texture> textures;
  int photo_count = 0;  // textures read from photographs

  // The default building of the scenario (deterministic per seed).
  static World build(const WorldConfig& config, uint64_t seed);
  // A textured rectangle on its own (for tests): a wall at distance `distance` in front of a camera at the origin
  // looking along +x of the world is not needed; tests add quads directly.
  int addTexture(const std::string& name, const cv::Mat& grey8);
  // Distance [m] from a point to the nearest surface of the world (the ground truth of a map point).
  double distanceToSurface(const Eigen::Vector3d& p) const;
};

// Procedural textures (CV_8UC1, side a power of two), deterministic per seed.
cv::Mat makeRoughTexture(int size, uint64_t seed, double contrast);
cv::Mat makeTileTexture(int size, int tiles, uint64_t seed);
cv::Mat makeSpeckleTexture(int size, uint64_t seed);

}  // namespace ips::sim
