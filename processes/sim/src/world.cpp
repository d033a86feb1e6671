#include "ips/sim/world.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <stdexcept>
#include <string>

#include "ips/data_dir.hpp"
#include "ips/log.hpp"
#include "ips/sim/rng.hpp"

namespace ips::sim {

namespace {

// Side of a person's clothing texture: the texture spans the person's height (6.8 mm texels on 1.75 m).
constexpr int kClothingTexels = 256;

int floorPow2(int v) {
  int p = 1;
  while (p * 2 <= v) p *= 2;
  return p;
}

cv::Mat randomImage(int size, Rng& rng) {
  cv::Mat m(size, size, CV_32F);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) m.at<float>(y, x) = static_cast<float>(rng.uniform());
  return m;
}

// Smooth noise of `cells` cells across `size` pixels that tiles seamlessly (cubic interpolation over a wrapped grid).
cv::Mat tiledNoise(int size, int cells, Rng& rng) {
  cv::Mat small = randomImage(cells, rng), padded, big;
  cv::copyMakeBorder(small, padded, 2, 2, 2, 2, cv::BORDER_WRAP);
  const int scale = size / cells;
  cv::resize(padded, big, cv::Size(padded.cols * scale, padded.rows * scale), 0, 0, cv::INTER_CUBIC);
  return big(cv::Rect(2 * scale, 2 * scale, size, size)).clone();
}

cv::Mat toGrey8(const cv::Mat& f, double mean, double sigma) {
  cv::Scalar m, s;
  cv::meanStdDev(f, m, s);
  cv::Mat out;
  f.convertTo(out, CV_8U, sigma / std::max(1e-9, s[0]), mean - m[0] * sigma / std::max(1e-9, s[0]));
  return out;
}

std::vector<std::string> photoPaths(const std::string& dir) {
  std::vector<std::string> out;
  namespace fs = std::filesystem;
  for (const char* scene : {"tsukuba", "venus", "cones", "teddy", "motorcycle_q", "kitti2015_000046"})
    out.push_back(dir + "/stereo/" + scene + "/left.png");
  const fs::path pairs = fs::path(dir) / "euroc/V1_01_easy/moving_pairs";
  std::error_code ec;
  if (fs::is_directory(pairs, ec)) {
    std::vector<std::string> found;
    for (const auto& e : fs::directory_iterator(pairs, ec))
      if (e.path().filename().string().find("_left.png") != std::string::npos) found.push_back(e.path().string());
    std::sort(found.begin(), found.end());
    out.insert(out.end(), found.begin(), found.end());
  }
  return out;
}

struct Builder {
  World& world;
  const WorldConfig& cfg;
  Rng rng;
  int rough = 0, tiles = 0, weak = 0, floor = 0, ceiling = 0, wood = 0;
  std::vector<int> photos;

  // A textured rectangle at a random texture offset; its brightness is drawn (indoor lighting) unless given.
  Quad& add(const Eigen::Vector3d& o, const Eigen::Vector3d& s, const Eigen::Vector3d& t, double ss, double st, int tex,
            double texel, std::optional<double> brightness = std::nullopt) {
    Quad q;
    q.origin = o;
    q.axis_s = s.normalized();
    q.axis_t = t.normalized();
    q.size_s = ss;
    q.size_t = st;
    q.texture = tex;
    q.texel_s = q.texel_t = texel;
    q.texture_offset = {rng.uniform() * 4096, rng.uniform() * 4096};
    q.brightness = static_cast<float>(brightness ? *brightness : 0.8 + 0.35 * rng.uniform());
    world.quads.push_back(q);
    return world.quads.back();
  }

  int wallMaterial() { return rng.uniform() < cfg.weak_texture_share ? weak : (rng.uniform() < 0.5 ? rough : tiles); }

  bool hasWeakStretch() const { return !cfg.weak_stretch_m.isZero(); }
  bool inWeakStretch(const Eigen::Vector2d& p, double margin = 0) const {
    const Eigen::Matrix<double, 4, 1>& r = cfg.weak_stretch_m;
    return hasWeakStretch() && p.x() > r[0] - margin && p.x() < r[2] + margin && p.y() > r[1] - margin &&
           p.y() < r[3] + margin;
  }
  // The part [u0, u1] of the wall from a to b (as distances from a) inside the weak stretch; empty when u0 >= u1.
  std::pair<double, double> weakSpan(const Eigen::Vector2d& a, const Eigen::Vector2d& b) const {
    if (!hasWeakStretch()) return {0, 0};
    const Eigen::Matrix<double, 4, 1>& r = cfg.weak_stretch_m;
    const double len = (b - a).norm();
    const Eigen::Vector2d dir = (b - a) / len;
    double u0 = 0, u1 = len;
    // Clip the wall's line to the rectangle, slab by slab.
    for (int axis = 0; axis < 2; ++axis) {
      const double lo = r[axis], hi = r[axis + 2];
      if (std::abs(dir[axis]) < 1e-12) {
        if (a[axis] <= lo || a[axis] >= hi) return {0, 0};
        continue;
      }
      const double ua = (lo - a[axis]) / dir[axis], ub = (hi - a[axis]) / dir[axis];
      u0 = std::max(u0, std::min(ua, ub));
      u1 = std::min(u1, std::max(ua, ub));
    }
    return {u0, u1};
  }

  // Wall from o along sd over [c0, c1], in pieces of at most ~5 m, each with its own material, or all weak plaster.
  void wallPieces(const Eigen::Vector3d& o, const Eigen::Vector3d& sd, double c0, double c1, bool plain) {
    const Eigen::Vector3d up(0, 0, 1);
    const int pieces = std::max(1, static_cast<int>(std::ceil((c1 - c0) / 5.0)));
    const double pl = (c1 - c0) / pieces;
    for (int k = 0; k < pieces; ++k) {
      const int mat = plain ? weak : wallMaterial();
      add(o + (c0 + k * pl) * sd, sd, up, pl, cfg.wall_height_m, mat, cfg.texel_m);
    }
  }

  // A vertical wall from a to b (floor plan), with door openings given as [from, to] along the wall, split into
  // pieces of at most ~5 m, each with its own material; where it runs through the weak stretch, weak plaster.
  void wall(const Eigen::Vector2d& a, const Eigen::Vector2d& b, std::vector<std::pair<double, double>> doors = {}) {
    const double H = cfg.wall_height_m, door_h = std::min(2.1, H - 0.2);
    const double len = (b - a).norm();
    const Eigen::Vector3d s(b.x() - a.x(), b.y() - a.y(), 0), up(0, 0, 1);
    const Eigen::Vector3d o(a.x(), a.y(), 0);
    const auto [weak0, weak1] = weakSpan(a, b);
    std::vector<double> cuts{0};
    for (auto [d0, d1] : doors) {
      cuts.push_back(d0);
      cuts.push_back(d1);
    }
    cuts.push_back(len);
    for (size_t i = 0; i + 1 < cuts.size(); ++i) {
      const double c0 = cuts[i], c1 = cuts[i + 1];
      if (c1 - c0 < 1e-6) continue;
      const bool is_door = i % 2 == 1;
      const Eigen::Vector3d sd = s.normalized();
      if (is_door) {  // lintel above the opening
        const bool plain = weak0 < weak1 && c1 > weak0 && c0 < weak1;
        add(o + c0 * sd + Eigen::Vector3d(0, 0, door_h), sd, up, c1 - c0, H - door_h, plain ? weak : tiles,
            cfg.texel_m);
        continue;
      }
      if (!(weak0 < weak1) || c1 <= weak0 || c0 >= weak1) {
        wallPieces(o, sd, c0, c1, false);
        continue;
      }
      // Through the weak stretch: the part before it, the plain part, the part after it.
      const double p0 = std::max(c0, weak0), p1 = std::min(c1, weak1);
      if (p0 - c0 > 1e-6) wallPieces(o, sd, c0, p0, false);
      wallPieces(o, sd, p0, p1, true);
      if (c1 - p1 > 1e-6) wallPieces(o, sd, p1, c1, false);
    }
    posters(a, b, doors);
  }

  void posters(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
               const std::vector<std::pair<double, double>>& doors) {
    if (photos.empty()) return;
    const double len = (b - a).norm();
    const Eigen::Vector2d dir = (b - a) / len;
    for (double pos = 1.0 + rng.uniform() * cfg.poster_spacing_m * 0.5; pos + 1.2 < len; pos += cfg.poster_spacing_m) {
      bool blocked = false;
      for (auto [d0, d1] : doors) blocked |= pos + 1.2 > d0 - 0.2 && pos < d1 + 0.2;
      if (blocked) continue;
      const int tex = photos[static_cast<size_t>(rng.uniform() * photos.size())];
      const cv::Mat& img = world.textures[tex].levels[0];
      const double w = 0.8 + 0.5 * rng.uniform();
      const double h = w * img.rows / img.cols;
      const auto [weak0, weak1] = weakSpan(a, b);
      if (weak0 < weak1 && pos + w > weak0 && pos < weak1) continue;  // the weak stretch stays plain
      // Posters hang 5 mm in front of the side left of a->b. Seen from there, the viewer's right is -dir and
      // image rows run down, so the texture's s axis is -dir from the top-left corner (the far end along dir).
      const Eigen::Vector3d n(-dir.y(), dir.x(), 0), d3(dir.x(), dir.y(), 0);
      const Eigen::Vector3d o = Eigen::Vector3d(a.x(), a.y(), 1.6 + h / 2) + (pos + w) * d3 + 0.005 * n;
      Quad& q = add(o, -d3, Eigen::Vector3d(0, 0, -1), w, h, tex, w / img.cols);
      q.texel_t = h / img.rows;
      q.texture_offset = {0, 0};
      q.brightness = 1.0f;
    }
  }

  // Horizontal rectangle [x0,x1] x [y0,y1] at height z; `up` says which side faces the viewer.
  void horizontal(double x0, double y0, double x1, double y1, double z, int tex, bool up) {
    if (up)
      add({x0, y0, z}, {1, 0, 0}, {0, 1, 0}, x1 - x0, y1 - y0, tex, cfg.texel_m * 1.5);
    else
      add({x0, y1, z}, {1, 0, 0}, {0, -1, 0}, x1 - x0, y1 - y0, tex, cfg.texel_m * 2);
  }

  // A floor or ceiling: the rectangle as horizontal() draws it, except where it meets the weak stretch, which is cut
  // out of it (up to four pieces round it) and drawn in weak plaster.
  void floorOrCeiling(double x0, double y0, double x1, double y1, double z, int tex, bool up) {
    const Eigen::Matrix<double, 4, 1>& r = cfg.weak_stretch_m;
    const double wx0 = std::max(x0, r[0]), wy0 = std::max(y0, r[1]), wx1 = std::min(x1, r[2]), wy1 = std::min(y1, r[3]);
    if (!hasWeakStretch() || wx0 >= wx1 || wy0 >= wy1) {
      horizontal(x0, y0, x1, y1, z, tex, up);
      return;
    }
    if (wy0 > y0) horizontal(x0, y0, x1, wy0, z, tex, up);  // the strips below and above the stretch ...
    if (wy1 < y1) horizontal(x0, wy1, x1, y1, z, tex, up);
    if (wx0 > x0) horizontal(x0, wy0, wx0, wy1, z, tex, up);  // ... and beside it
    if (wx1 < x1) horizontal(wx1, wy0, x1, wy1, z, tex, up);
    horizontal(wx0, wy0, wx1, wy1, z, weak, up);
  }

  // The ramp's surfaces (WorldConfig::ramp): the up slope, the level top and the down slope, wall to wall.
  void ramp(const Ramp& r) {
    if (!r.any()) return;
    const double heading = r.heading_deg * M_PI / 180;
    const Eigen::Vector3d along(std::cos(heading), std::sin(heading), 0), left(-along.y(), along.x(), 0);
    const Eigen::Vector3d foot = Eigen::Vector3d(r.start_m.x(), r.start_m.y(), 0) - 0.5 * r.width_m * left;
    const Eigen::Vector3d rising = along + Eigen::Vector3d(0, 0, r.slope),
                          falling = along - Eigen::Vector3d(0, 0, r.slope);
    const double slope_length = r.run() * std::sqrt(1 + r.slope * r.slope), texel = cfg.texel_m * 1.5;
    const Eigen::Vector3d top(0, 0, r.rise_m);
    // axis_s x axis_t points up on every piece (the side the walker sees).
    add(foot, rising, left, slope_length, r.width_m, floor, texel);
    add(foot + r.run() * along + top, along, left, r.plateau_m, r.width_m, floor, texel);
    add(foot + (r.run() + r.plateau_m) * along + top, falling, left, slope_length, r.width_m, floor, texel);
  }

  // A closed box standing on the floor (one-sided faces pointing out).
  void box(const Eigen::Vector2d& c, double sx, double sy, double h, int tex) {
    const double x0 = c.x() - sx / 2, x1 = c.x() + sx / 2, y0 = c.y() - sy / 2, y1 = c.y() + sy / 2;
    const Eigen::Vector3d up(0, 0, 1);
    const double texel = cfg.texel_m * 0.75;
    add({x0, y0, 0}, {1, 0, 0}, up, sx, h, tex, texel).one_sided = true;          // south face, normal -y
    add({x1, y1, 0}, {-1, 0, 0}, up, sx, h, tex, texel).one_sided = true;         // north face, normal +y
    add({x1, y0, 0}, {0, 1, 0}, up, sy, h, tex, texel).one_sided = true;          // east face, normal +x
    add({x0, y1, 0}, {0, -1, 0}, up, sy, h, tex, texel).one_sided = true;         // west face, normal -x
    add({x0, y0, h}, {1, 0, 0}, {0, 1, 0}, sx, sy, tex, texel).one_sided = true;  // top, normal +z
  }
};

}  // namespace

int World::addTexture(const std::string& name, const cv::Mat& grey8) {
  CV_Assert(grey8.type() == CV_8UC1 && !grey8.empty());
  Texture t;
  t.name = name;
  cv::Mat level;
  cv::resize(grey8, level, cv::Size(floorPow2(grey8.cols), floorPow2(grey8.rows)), 0, 0, cv::INTER_AREA);
  t.levels.push_back(level);
  while (level.cols > 1 && level.rows > 1) {
    cv::Mat next;
    cv::resize(level, next, cv::Size(level.cols / 2, level.rows / 2), 0, 0, cv::INTER_AREA);
    t.levels.push_back(next);
    level = next;
  }
  textures.push_back(std::move(t));
  return static_cast<int>(textures.size()) - 1;
}

cv::Mat makeRoughTexture(int size, uint64_t seed, double contrast) {
  Rng rng(seed);
  cv::Mat acc = cv::Mat::zeros(size, size, CV_32F);
  double amp = 1.0;
  for (int cells = 8; cells <= size / 2; cells *= 2, amp *= 0.85) acc += amp * tiledNoise(size, cells, rng);
  return toGrey8(acc, 128, contrast);
}

cv::Mat makeTileTexture(int size, int tiles, uint64_t seed) {
  Rng rng(seed);
  // One draw per statement: the order of an operator's operands is unspecified, so a compiler may pick either. The
  // finer noise is drawn first, the order the worlds have always been drawn in.
  const cv::Mat fine = tiledNoise(size, size / 16, rng);
  const cv::Mat coarse = tiledNoise(size, size / 4, rng);
  cv::Mat acc = 0.5 * coarse + 0.3 * fine;
  const int cell = size / tiles;
  for (int ty = 0; ty < tiles; ++ty)
    for (int tx = 0; tx < tiles; ++tx) {
      const float shade = static_cast<float>(rng.uniform() * 1.5);
      acc(cv::Rect(tx * cell, ty * cell, cell, cell)) += shade;
      // Dark grout lines give corners at the tile crossings.
      acc(cv::Rect(tx * cell, ty * cell, cell, 3)) -= 1.5f;
      acc(cv::Rect(tx * cell, ty * cell, 3, cell)) -= 1.5f;
    }
  return toGrey8(acc, 120, 45);
}

cv::Mat makeSpeckleTexture(int size, uint64_t seed) {
  Rng rng(seed);
  cv::Mat acc = 0.6 * tiledNoise(size, size / 8, rng);
  for (int i = 0; i < size * size / 60; ++i) {
    const int y = static_cast<int>(rng.uniform() * size);  // y first: see makeTileTexture
    const int x = static_cast<int>(rng.uniform() * size);
    const cv::Point p(x, y);
    const double r = 1 + 3 * rng.uniform();
    cv::circle(acc, p, static_cast<int>(r), cv::Scalar(rng.uniform() * 3 - 1.5), cv::FILLED);
  }
  return toGrey8(acc, 110, 40);
}

cv::Mat makeClothingTexture(int size, uint64_t seed) {
  Rng rng(seed);
  // Heights as shares of the person, from the feet: shoes, trousers up to the waist, the shirt up to the neck, then
  // the face and the hair.
  constexpr double kShoes = 0.05, kWaist = 0.48, kNeck = 0.84, kHairline = 0.95;
  const double trousers = 40 + 50 * rng.uniform(), shirt = 80 + 120 * rng.uniform();
  const double stripe_contrast = 15 + 45 * rng.uniform();
  // Stripes (across, along the body) or checks, of a period that divides the side so that they wrap round the body.
  const int pattern = static_cast<int>(rng.uniform() * 3);
  const int period = size / (8 << static_cast<int>(rng.uniform() * 3));
  cv::Mat fabric = tiledNoise(size, size / 8, rng), out(size, size, CV_8UC1);
  for (int row = 0; row < size; ++row) {
    const double h = (row + 0.5) / size;
    for (int col = 0; col < size; ++col) {
      const double weave = 12 * (fabric.at<float>(row, col) - 0.5);  // the cloth's own texture
      double grey;
      if (h < kShoes) {
        grey = 25;
      } else if (h < kWaist) {
        grey = trousers + weave;
      } else if (h < kNeck) {
        const bool across = (row / (period / 2)) % 2 == 0, along = (col / (period / 2)) % 2 == 0;
        const bool dark = pattern == 0 ? across : pattern == 1 ? along : across != along;
        grey = shirt + (dark ? -0.5 : 0.5) * stripe_contrast + weave;
      } else if (h < kHairline) {
        grey = 160 + weave;  // the face (and the neck, seen from behind too: a box has no face)
      } else {
        grey = 45 + weave;
      }
      out.at<uint8_t>(row, col) = cv::saturate_cast<uint8_t>(grey);
    }
  }
  return out;
}

namespace {

double distanceToRoute(const Eigen::Vector2d& p, const std::vector<Eigen::Vector2d>& route) {
  double best = INFINITY;
  for (size_t i = 0; i + 1 < route.size(); ++i) {
    const Eigen::Vector2d a = route[i], ab = route[i + 1] - a;
    const double u = std::clamp((p - a).dot(ab) / std::max(1e-12, ab.squaredNorm()), 0.0, 1.0);
    best = std::min(best, (p - (a + u * ab)).norm());
  }
  return best;
}

// Outdoors: a ground plane, facades along both sides of every street (the segments of cfg.route) with gaps,
// buildings far from the streets (the far structure whose disparity the baseline cannot resolve) and a sky box
// of faint clouds. Deterministic per seed.
void buildStreet(World& world, const WorldConfig& cfg, uint64_t seed) {
  Builder builder{world, cfg, Rng(streamSeed(seed, kStreamWorld)), 0, 0, 0, 0, 0, 0, {}};
  Rng& rng = builder.rng;
  const uint64_t ts = streamSeed(seed, kStreamWorld, 1);
  // Window grids: 8 tiles of 128 texels across the texture; the texel sizes below make a tile ~2.5-3 m (a storey).
  const int facade = world.addTexture("facade", makeTileTexture(1024, 8, ts + 1));
  const int brick = world.addTexture("brick", makeRoughTexture(1024, ts + 2, 40));
  const int ground = world.addTexture("asphalt", makeSpeckleTexture(1024, ts + 3));
  const int clouds = world.addTexture("clouds", makeRoughTexture(512, ts + 4, 10));
  const std::vector<Eigen::Vector2d>& route = cfg.route;
  Eigen::Vector2d lo = route.front(), hi = route.front();
  for (const Eigen::Vector2d& p : route) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Eigen::Vector2d centre = 0.5 * (lo + hi);
  const Eigen::Vector3d up(0, 0, 1);

  // Ground out to beyond the farthest building.
  const double reach = cfg.far_distance_m.y() + 100.0;
  builder.add({lo.x() - reach, lo.y() - reach, 0}, {1, 0, 0}, {0, 1, 0}, hi.x() - lo.x() + 2 * reach,
              hi.y() - lo.y() + 2 * reach, ground, 0.012, 0.9);

  // Facades: lots of 8-25 m along each side of each street, some left open. Near an inner waypoint (a junction)
  // the frontage stops a street's width short so the facades do not cross the next street.
  const double W = cfg.street_half_width_m;
  for (size_t i = 0; i + 1 < route.size(); ++i) {
    const Eigen::Vector2d a = route[i], b = route[i + 1];
    const double len = (b - a).norm();
    if (len < 1e-6) continue;
    const Eigen::Vector2d dir = (b - a) / len, left(-dir.y(), dir.x());
    const double from = i == 0 ? -30.0 : W + 3.0;
    const double to = i + 2 == route.size() ? len + 30.0 : len - W - 3.0;
    for (int side : {-1, 1}) {
      for (double pos = from; pos < to;) {
        const double lot = std::min(8.0 + 17.0 * rng.uniform(), to - pos);
        const bool open = rng.uniform() < cfg.street_gap_share;
        if (!open && lot > 3.0) {
          const double h = cfg.street_facade_height_m.x() +
                           rng.uniform() * (cfg.street_facade_height_m.y() - cfg.street_facade_height_m.x());
          const Eigen::Vector2d p0 = a + pos * dir + side * W * left;
          const bool windows = rng.uniform() < 0.6;
          builder.add({p0.x(), p0.y(), 0}, {dir.x(), dir.y(), 0}, up, lot, h, windows ? facade : brick,
                      windows ? 0.02 : 0.008, 0.75 + 0.4 * rng.uniform());
        }
        pos += lot;
      }
    }
  }

  // Far buildings: boxes far_distance_m from the nearest street, in every direction.
  for (int k = 0; k < cfg.far_buildings; ++k) {
    for (int attempt = 0; attempt < 50; ++attempt) {
      const size_t seg = static_cast<size_t>(rng.uniform() * (route.size() - 1));
      const Eigen::Vector2d on = route[seg] + rng.uniform() * (route[seg + 1] - route[seg]);
      const double angle = 2 * M_PI * rng.uniform();
      const double dist = cfg.far_distance_m.x() + rng.uniform() * (cfg.far_distance_m.y() - cfg.far_distance_m.x());
      const Eigen::Vector2d c = on + dist * Eigen::Vector2d(std::cos(angle), std::sin(angle));
      const double sx = 15.0 + 50.0 * rng.uniform(), sy = 15.0 + 50.0 * rng.uniform();
      if (distanceToRoute(c, route) < cfg.far_distance_m.x() + 0.5 * std::hypot(sx, sy)) continue;
      const double h = cfg.far_height_m.x() + rng.uniform() * (cfg.far_height_m.y() - cfg.far_height_m.x());
      const double x0 = c.x() - sx / 2, x1 = c.x() + sx / 2, y0 = c.y() - sy / 2, y1 = c.y() + sy / 2;
      const double texel = 0.022, bright = 0.6 + 0.5 * rng.uniform();
      builder.add({x0, y0, 0}, {1, 0, 0}, up, sx, h, facade, texel, bright).one_sided = true;   // normal -y
      builder.add({x1, y1, 0}, {-1, 0, 0}, up, sx, h, facade, texel, bright).one_sided = true;  // normal +y
      builder.add({x1, y0, 0}, {0, 1, 0}, up, sy, h, facade, texel, bright).one_sided = true;   // normal +x
      builder.add({x0, y1, 0}, {0, -1, 0}, up, sy, h, facade, texel, bright).one_sided = true;  // normal -x
      break;
    }
  }

  // The sky: a box of faint, bright clouds around everything.
  const double S = cfg.sky_distance_m, sky_texel = 8.0, sky = 1.5;
  const Eigen::Vector3d o(centre.x() - S, centre.y() - S, -1.0);
  builder.add(o, {1, 0, 0}, up, 2 * S, S, clouds, sky_texel, sky);
  builder.add(o + Eigen::Vector3d(0, 2 * S, 0), {1, 0, 0}, up, 2 * S, S, clouds, sky_texel, sky);
  builder.add(o, {0, 1, 0}, up, 2 * S, S, clouds, sky_texel, sky);
  builder.add(o + Eigen::Vector3d(2 * S, 0, 0), {0, 1, 0}, up, 2 * S, S, clouds, sky_texel, sky);
  builder.add(o + Eigen::Vector3d(0, 0, S), {1, 0, 0}, {0, 1, 0}, 2 * S, 2 * S, clouds, sky_texel, sky);
}

// The calibration chart (WorldConfig::chart_*): one two-sided quad whose texture is the board with a white margin of
// one square, so that inner corner (i, j) lies exactly (2 + i, 2 + j) squares from the quad's top left corner
// along its rows and down its columns (texel edges fall on integer texture coordinates). Added after everything
// else and without the world's random stream, so a world without a chart is unchanged.
void addChart(World& world, const WorldConfig& cfg) {
  if (cfg.chart_inner_corners.isZero()) return;
  const int cols = static_cast<int>(cfg.chart_inner_corners.x()) + 3,
            rows = static_cast<int>(cfg.chart_inner_corners.y()) + 3;
  constexpr int kSquareTexels = 64;
  int side = 64;
  while (side < std::max(cols, rows) * kSquareTexels) side *= 2;
  constexpr uint8_t kWhite = 215, kBlack = 30;  // printed paper and toner under the corridor's light
  cv::Mat board(side, side, CV_8UC1, cv::Scalar(kWhite));
  for (int r = 1; r < rows - 1; ++r)
    for (int c = 1; c < cols - 1; ++c)
      if ((r + c) % 2 == 0)
        board(cv::Rect(c * kSquareTexels, r * kSquareTexels, kSquareTexels, kSquareTexels)).setTo(kBlack);
  Quad q;
  const double facing = cfg.chart_facing_deg * M_PI / 180;
  const Eigen::Vector3d normal(std::cos(facing), std::sin(facing), 0), down(0, 0, -1);
  q.axis_s = down.cross(normal);  // to the right, as seen from the front
  q.axis_t = down;
  q.size_s = cols * cfg.chart_square_m;
  q.size_t = rows * cfg.chart_square_m;
  q.origin = cfg.chart_centre_m - 0.5 * q.size_s * q.axis_s - 0.5 * q.size_t * q.axis_t;
  q.texture = world.addTexture("calibration chart", board);
  q.texel_s = q.texel_t = cfg.chart_square_m / kSquareTexels;
  q.texture_offset = {0, 0};
  q.brightness = 1.0f;
  world.quads.push_back(q);
}

// Draws of a person's phase before its lane is declared unable to keep clear of the walker.
constexpr int kMaxPhaseDraws = 1000;
// The walker's path is checked against the people every so often (a person at 1.5 m/s moves 7.5 cm in between).
constexpr double kClearanceStep_s = 0.05;
// The people's random streams: after the world's (index 0) and its textures' (1).
constexpr uint64_t kPeopleStreamIndex = 1000;

// Distance from p to the person's box on the floor plan at time t.
double distanceToPerson(const Person& person, double t, const Eigen::Vector2d& p) {
  const Eigen::Vector2d f = person.forward(), d = p - person.centre(t);
  const double along = std::max(0.0, std::abs(d.dot(f)) - 0.5 * person.size_m.y());
  const double across = std::max(0.0, std::abs(f.x() * d.y() - f.y() * d.x()) - 0.5 * person.size_m.x());
  return std::hypot(along, across);
}

// The people of cfg.people, each with its clothing, at a phase that keeps it clear of the walker (World::build).
// Added after everything else from their own streams, so that a world without people is unchanged.
void addPeople(World& world, const WorldConfig& cfg, uint64_t seed, const Trajectory* walker) {
  std::vector<Eigen::Vector2d> walk;
  std::vector<double> times;
  if (walker && !cfg.people.empty())
    for (double t = 0; t <= walker->duration(); t += kClearanceStep_s) {
      times.push_back(t);
      walk.push_back(walker->state(t).position.head<2>());
    }
  for (size_t k = 0; k < cfg.people.size(); ++k) {
    Rng rng(streamSeed(seed, kStreamWorld, kPeopleStreamIndex + k));
    Person person;
    person.lane = cfg.people[k];
    person.size_m = cfg.person_size_m;
    person.texture = world.addTexture("clothing", makeClothingTexture(kClothingTexels, rng.next()));
    bool clear = false;
    for (int draw = 0; draw < kMaxPhaseDraws && !clear; ++draw) {
      person.phase_s = rng.uniform() * person.cycle();
      clear = true;
      for (size_t i = 0; i < walk.size() && clear; ++i)
        clear = distanceToPerson(person, times[i], walk[i]) >= cfg.person_clearance_m;
    }
    if (!clear)
      throw std::invalid_argument("world/people: person " + std::to_string(k + 1) +
                                  " crosses the walk where no phase keeps it world/person_clearance_m from the head; "
                                  "give its lane a dwell at the ends or move it");
    world.people.push_back(person);
  }
}

}  // namespace

double Person::cycle() const { return 2 * ((lane.to - lane.from).norm() / lane.speed_mps + lane.dwell_s); }

Eigen::Vector2d Person::forward() const { return (lane.to - lane.from).normalized(); }

Eigen::Vector2d Person::centre(double t) const {
  const double length = (lane.to - lane.from).norm(), walk_s = length / lane.speed_mps, dwell = lane.dwell_s;
  const double period = cycle();
  double tau = std::fmod(t + phase_s, period);
  if (tau < 0) tau += period;
  // Standing at `from`, walking to `to`, standing there, walking back.
  double along = 0;
  if (tau < dwell)
    along = 0;
  else if (tau < dwell + walk_s)
    along = lane.speed_mps * (tau - dwell);
  else if (tau < 2 * dwell + walk_s)
    along = length;
  else
    along = length - lane.speed_mps * (tau - 2 * dwell - walk_s);
  return lane.from + along * forward();
}

std::array<Eigen::Vector3d, 8> Person::corners(double t, double floor_z) const {
  const Eigen::Vector2d c = centre(t), f = forward();
  const Eigen::Vector3d along = 0.5 * size_m.y() * Eigen::Vector3d(f.x(), f.y(), 0),
                        across = 0.5 * size_m.x() * Eigen::Vector3d(-f.y(), f.x(), 0), up(0, 0, size_m.z());
  std::array<Eigen::Vector3d, 8> out;
  for (int i = 0; i < 8; ++i)
    out[i] = Eigen::Vector3d(c.x(), c.y(), floor_z) + (i & 1 ? along : -along) + (i & 2 ? across : -across) +
             (i & 4 ? up : Eigen::Vector3d::Zero());
  return out;
}

void Person::addQuads(double t, double floor_z, std::vector<Quad>& out) const {
  const Eigen::Vector2d c = centre(t), f2 = forward();
  const Eigen::Vector3d f(f2.x(), f2.y(), 0), l(-f2.y(), f2.x(), 0), up(0, 0, 1);
  const Eigen::Vector3d base(c.x(), c.y(), floor_z);
  const double half_w = 0.5 * size_m.x(), half_d = 0.5 * size_m.y(), height = size_m.z();
  // The texture spans the person's height once; its columns run round the body.
  const double texel = height / kClothingTexels;
  Quad q;
  q.texture = texture;
  q.texel_s = q.texel_t = texel;
  q.one_sided = true;
  q.brightness = 1.0f;
  q.axis_t = up;
  // Round the body from the front's right corner: front, left side, back, right side. axis_s = up x normal.
  const Eigen::Vector3d corners[4] = {base + half_d * f - half_w * l, base + half_d * f + half_w * l,
                                      base - half_d * f + half_w * l, base - half_d * f - half_w * l};
  const Eigen::Vector3d sides[4] = {l, -f, -l, f};
  const double widths[4] = {size_m.x(), size_m.y(), size_m.x(), size_m.y()};
  double round = 0;
  for (int i = 0; i < 4; ++i) {
    q.origin = corners[i];
    q.axis_s = sides[i];
    q.size_s = widths[i];
    q.size_t = height;
    q.texture_offset = {round / texel, 0};
    round += widths[i];
    out.push_back(q);
  }
  // The top (hair), normal up: f x l.
  q.origin = corners[3] + height * up;
  q.axis_s = f;
  q.axis_t = l;
  q.size_s = size_m.y();
  q.size_t = size_m.x();
  q.texture_offset = {0, kClothingTexels - 1.0};  // the top rows: hair
  out.push_back(q);
}

World World::build(const WorldConfig& cfg, uint64_t seed, const Trajectory* walker) {
  World world;
  if (cfg.type == "street") {
    buildStreet(world, cfg, seed);
    return world;
  }
  Builder b{world, cfg, Rng(streamSeed(seed, kStreamWorld)), 0, 0, 0, 0, 0, 0, {}};
  const uint64_t ts = streamSeed(seed, kStreamWorld, 1);
  b.rough = world.addTexture("rough plaster", makeRoughTexture(1024, ts + 1, 40));
  b.tiles = world.addTexture("tiles", makeTileTexture(1024, 8, ts + 2));
  b.weak = world.addTexture("weak plaster", makeRoughTexture(512, ts + 3, 2.5));
  b.floor = world.addTexture("terrazzo floor", makeSpeckleTexture(1024, ts + 4));
  b.ceiling = world.addTexture("ceiling", makeRoughTexture(512, ts + 5, 6));
  if (cfg.weak_floor) b.floor = b.ceiling = b.weak;  // a painted floor and a plain ceiling
  b.wood = world.addTexture("wood", makeTileTexture(512, 2, ts + 6));

  const std::string dir = cfg.data_dir.empty() ? dataDir() : cfg.data_dir;
  for (const std::string& path : photoPaths(dir)) {
    cv::Mat img = cv::imread(path, cv::IMREAD_GRAYSCALE);
    if (img.empty()) continue;
    b.photos.push_back(world.addTexture(path, img));
  }
  world.photo_count = static_cast<int>(b.photos.size());
  if (b.photos.empty()) {
    IPS_WARN("sim: no photographs found under '" << dir << "' (stereo/*/left.png): posters get procedural texture");
    for (int i = 0; i < 4; ++i)
      b.photos.push_back(world.addTexture("poster", makeTileTexture(512, 4 + 2 * i, ts + 10 + i)));
  }

  const double X = cfg.building_size_m.x(), Y = cfg.building_size_m.y(), w = cfg.corridor_width_m;
  const double H = cfg.wall_height_m;
  // The room south of the ring: x in [rx0, rx0 + 6], y in [-6, 0], door in the ring's south wall.
  const double rx0 = std::min(10.0, X - 8.0), room_w = 6.0, room_d = 6.0;
  const double door0 = rx0 + 2.3, door1 = rx0 + 3.5;
  // Outer walls of the ring (drawn so that the inside is on their left: posters face the corridor).
  b.wall({0, 0}, {X, 0}, {{door0, door1}});
  b.wall({X, 0}, {X, Y});
  b.wall({X, Y}, {0, Y});
  b.wall({0, Y}, {0, 0});
  // Inner block, seen from the corridor (clockwise, so that the corridor is on the left).
  b.wall({w, w}, {w, Y - w});
  b.wall({w, Y - w}, {X - w, Y - w});
  b.wall({X - w, Y - w}, {X - w, w});
  b.wall({X - w, w}, {w, w});
  // The room.
  b.wall({rx0, 0}, {rx0, -room_d});
  b.wall({rx0, -room_d}, {rx0 + room_w, -room_d});
  b.wall({rx0 + room_w, -room_d}, {rx0 + room_w, 0});
  // Door reveal (the wall's thickness is not modelled: the opening is a hole in a thin wall).
  b.floorOrCeiling(0, 0, X, Y, 0, b.floor, true);
  b.floorOrCeiling(0, 0, X, Y, H, b.ceiling, false);
  b.floorOrCeiling(rx0, -room_d, rx0 + room_w, 0, 0, b.floor, true);
  b.floorOrCeiling(rx0, -room_d, rx0 + room_w, 0, H, b.ceiling, false);
  b.ramp(cfg.ramp);

  // Whether an object of this radius at c keeps off the weak stretch, the ramp (it would stand in its slope) and the
  // people's lanes (they would walk through it).
  auto keepsClear = [&](const Eigen::Vector2d& c, double radius) {
    if (b.inWeakStretch(c, radius)) return false;
    if (cfg.ramp.any()) {
      const Eigen::Vector2d q = cfg.ramp.local(c);
      if (q.x() > -radius && q.x() < cfg.ramp.length() + radius && std::abs(q.y()) < 0.5 * cfg.ramp.width_m + radius)
        return false;
    }
    for (const PersonLane& lane : cfg.people) {
      const Eigen::Vector2d ab = lane.to - lane.from;
      const double u = std::clamp((c - lane.from).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
      if ((c - (lane.from + u * ab)).norm() < radius + 0.5 * cfg.person_size_m.head<2>().norm()) return false;
    }
    return true;
  };
  // Cabinets and boxes along the outer walls, away from the corners and the door.
  auto furnish = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& c, const Eigen::Vector2d& inward) {
    const double len = (c - a).norm();
    const Eigen::Vector2d dir = (c - a) / len;
    for (double pos = 3.0 + b.rng.uniform() * 2; pos < len - 3.0;
         pos += cfg.object_spacing_m * (0.7 + 0.6 * b.rng.uniform())) {
      const Eigen::Vector2d p = a + pos * dir;
      if ((p - Eigen::Vector2d(0.5 * (door0 + door1), 0)).norm() < 2.0) continue;
      const double width = 0.6 + 0.6 * b.rng.uniform(), depth = 0.3 + 0.15 * b.rng.uniform();
      const double height = 0.7 + 1.2 * b.rng.uniform();
      const Eigen::Vector2d centre = p + inward * (depth / 2 + 0.02);
      if (!keepsClear(centre, 0.5 * std::max(width, depth))) continue;
      const bool along_x = std::abs(dir.x()) > 0.5;
      b.box(centre, along_x ? width : depth, along_x ? depth : width, height, b.rng.uniform() < 0.5 ? b.wood : b.tiles);
    }
  };
  furnish({0, 0}, {X, 0}, {0, 1});
  furnish({X, 0}, {X, Y}, {-1, 0});
  furnish({0, Y}, {X, Y}, {0, -1});
  furnish({0, 0}, {0, Y}, {1, 0});
  // Room: a table in the middle and a shelf on the back wall.
  b.box({rx0 + 2.9, -3.5}, 0.9, 0.6, 0.75, b.wood);
  b.box({rx0 + room_w / 2, -room_d + 0.25}, 2.0, 0.4, 1.8, b.wood);
  addChart(world, cfg);
  world.lighting.zones = cfg.lighting_zones;
  world.lighting.transition_m = cfg.lighting_transition_m;
  world.ramp = cfg.ramp;
  addPeople(world, cfg, seed, walker);
  return world;
}

std::vector<Quad> World::peopleAt(double t) const {
  std::vector<Quad> out;
  for (const Person& person : people) person.addQuads(t, ramp.floorHeight(person.centre(t)), out);
  return out;
}

bool Lighting::uniformOver(const Quad& q) const {
  if (zones.empty()) return true;
  const Eigen::Vector3d corners[4] = {q.origin, q.origin + q.size_s * q.axis_s, q.origin + q.size_t * q.axis_t,
                                      q.origin + q.size_s * q.axis_s + q.size_t * q.axis_t};
  Eigen::Vector2d lo = corners[0].head<2>(), hi = lo;
  for (const Eigen::Vector3d& c : corners) {
    lo = lo.cwiseMin(c.head<2>());
    hi = hi.cwiseMax(c.head<2>());
  }
  for (const LightingZone& z : zones) {
    const Eigen::Vector2d margin = Eigen::Vector2d::Constant(0.5 * transition_m);
    if ((hi.array() > (z.low - margin).array()).all() && (lo.array() < (z.high + margin).array()).all()) return false;
  }
  return true;
}

double World::distanceToSurface(const Eigen::Vector3d& p) const {
  double best = INFINITY;
  for (const Quad& q : quads) {
    // The nearest point of the rectangle: the projection onto its plane, clamped to its sides.
    const Eigen::Vector3d d = p - q.origin;
    const double s = std::clamp(d.dot(q.axis_s), 0.0, q.size_s), t = std::clamp(d.dot(q.axis_t), 0.0, q.size_t);
    best = std::min(best, (d - s * q.axis_s - t * q.axis_t).norm());
  }
  return best;
}

}  // namespace ips::sim
