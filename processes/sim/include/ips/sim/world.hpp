#pragma once
// The simulated building: textured planar rectangles (walls with door openings, floors, ceilings, posters,
// cabinets and boxes, a ramp), its lighting zones and the people walking through it (boxes that move). Textures are
// procedural (rough plaster, tiles, terrazzo, weak plaster, clothing) and real photographs read at run time from the
// evaluation data (falls back to procedural with a warning).
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "ips/sim/scenario.hpp"
#include "ips/sim/trajectory.hpp"

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

// A person walking its lane (WorldConfig::people) as a box facing along it: where it is, is a function of time alone,
// so any image and any sub-time of an exposure sees it where it is at that time.
struct Person {
  PersonLane lane;
  double phase_s = 0;                       // [s] into its cycle at t = 0
  Eigen::Vector3d size_m{0.45, 0.3, 1.75};  // across the lane, along it, height
  int texture = 0;

  double cycle() const;                    // [s] there and back, with the dwells
  Eigen::Vector2d forward() const;         // unit, from lane.from to lane.to (the box keeps facing it)
  Eigen::Vector2d centre(double t) const;  // [m] on the floor plan at scenario time t [s]
  // The eight corners of its box at time t standing on the floor at height floor_z.
  std::array<Eigen::Vector3d, 8> corners(double t, double floor_z) const;
  // Its box at time t standing on the floor at height floor_z: four sides (round the body, the texture's columns
  // running on from one to the next, its rows from the feet up) and the top, one-sided, facing out.
  void addQuads(double t, double floor_z, std::vector<Quad>& out) const;
};

// The building's light over the floor plan (WorldConfig::lighting_zones): a factor on every surface's brightness.
struct Lighting {
  std::vector<LightingZone> zones;
  double transition_m = 1.5;

  // The factor at floor-plan point (x, y): 1 + the sum over the zones of (ratio - 1) w, w = 1 inside a zone and 0
  // outside, a smoothstep across transition_m centred on its edges (in x times in y).
  float at(float x, float y) const {
    float light = 1.0f;
    const float inv = static_cast<float>(1.0 / transition_m);
    for (const LightingZone& z : zones) {
      const float wx =
          edge((x - static_cast<float>(z.low.x())) * inv) * edge((static_cast<float>(z.high.x()) - x) * inv);
      const float wy =
          edge((y - static_cast<float>(z.low.y())) * inv) * edge((static_cast<float>(z.high.y()) - y) * inv);
      light += static_cast<float>(z.ratio - 1.0) * wx * wy;
    }
    return light;
  }
  // Whether the factor is 1 all over q (its floor-plan bounds clear every zone with its transition).
  bool uniformOver(const Quad& q) const;

 private:
  // 0 at u <= -1/2, 1 at u >= 1/2, smoothstep in between.
  static float edge(float u) {
    const float w = std::clamp(u + 0.5f, 0.0f, 1.0f);
    return w * w * (3.0f - 2.0f * w);
  }
};

struct World {
  std::vector<Quad> quads;  // the static surfaces
  std::vector<Texture> textures;
  int photo_count = 0;  // textures read from photographs
  Lighting lighting;
  Ramp ramp;                   // its surfaces are among the quads; people stand on it
  std::vector<Person> people;  // not among the quads: they move (peopleAt)

  // The default building of the scenario (deterministic per seed). With `walker`, each person's phase is drawn
  // (from the seed) until the person keeps WorldConfig::person_clearance_m from the walker's position all through its
  // walk (checked every 50 ms), so that no one walks into the head; without it, the first draw.
  static World build(const WorldConfig& config, uint64_t seed, const Trajectory* walker = nullptr);
  // A textured rectangle on its own (for tests): a wall at distance `distance` in front of a camera at the origin
  // looking along +x of the world is not needed; tests add quads directly.
  int addTexture(const std::string& name, const cv::Mat& grey8);
  // Distance [m] from a point to the nearest static surface of the world (the ground truth of a map point; the people
  // are not in it).
  double distanceToSurface(const Eigen::Vector3d& p) const;
  // The people's boxes at scenario time t [s] (empty without people).
  std::vector<Quad> peopleAt(double t) const;
};

// Procedural textures (CV_8UC1, side a power of two), deterministic per seed.
cv::Mat makeRoughTexture(int size, uint64_t seed, double contrast);
cv::Mat makeTileTexture(int size, int tiles, uint64_t seed);
cv::Mat makeSpeckleTexture(int size, uint64_t seed);
// Clothes round a person, rows from the feet up: trousers, a shirt with stripes or checks, skin and hair.
cv::Mat makeClothingTexture(int size, uint64_t seed);

}  // namespace ips::sim
