#include "ips/sim/scene_renderer.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <stdexcept>
#include <utility>

#include "ips/sim/rng.hpp"

namespace ips::sim {

// ---------------------------------------------------------------- View

View View::pinhole(const Eigen::Matrix3d& K, cv::Size size) {
  View v;
  v.width = size.width;
  v.height = size.height;
  v.focal = 0.5 * (K(0, 0) + K(1, 1));
  v.rx.resize(static_cast<size_t>(v.width) * v.height);
  v.ry.resize(v.rx.size());
  for (int y = 0; y < v.height; ++y)
    for (int x = 0; x < v.width; ++x) {
      const size_t i = static_cast<size_t>(y) * v.width + x;
      const double yn = (y - K(1, 2)) / K(1, 1);
      v.rx[i] = static_cast<float>((x - K(0, 2) - K(0, 1) * yn) / K(0, 0));
      v.ry[i] = static_cast<float>(yn);
    }
  v.computeTiles();
  return v;
}

View View::fromRays(int width, int height, double focal, std::vector<float> rx, std::vector<float> ry) {
  if (width <= 0 || height <= 0 || rx.size() != static_cast<size_t>(width) * height || ry.size() != rx.size())
    throw std::invalid_argument("View::fromRays: need width * height rays");
  View v;
  v.width = width;
  v.height = height;
  v.focal = focal;
  v.rx = std::move(rx);
  v.ry = std::move(ry);
  v.computeTiles();
  return v;
}

View View::distorted(const CameraIntrinsics& cam) {
  View v;
  v.width = cam.width;
  v.height = cam.height;
  v.focal = 0.5 * (cam.K(0, 0) + cam.K(1, 1));
  const size_t n = static_cast<size_t>(v.width) * v.height;
  v.rx.resize(n);
  v.ry.resize(n);
  const cv::Mat K = cam.cvK(), D = cam.cvDistortion();
  // Undistort row by row on all cores; iterate to convergence (OpenCV's default 5 iterations is not enough at
  // the corners of a wide-angle lens).
  cv::parallel_for_(cv::Range(0, v.height), [&](const cv::Range& r) {
    std::vector<cv::Point2f> src(v.width), dst;
    for (int y = r.start; y < r.end; ++y) {
      for (int x = 0; x < v.width; ++x) src[x] = cv::Point2f(static_cast<float>(x), static_cast<float>(y));
      cv::undistortPoints(src, dst, K, D, cv::noArray(), cv::noArray(),
                          cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-12));
      for (int x = 0; x < v.width; ++x) {
        v.rx[static_cast<size_t>(y) * v.width + x] = dst[x].x;
        v.ry[static_cast<size_t>(y) * v.width + x] = dst[x].y;
      }
    }
  });
  v.computeTiles();
  return v;
}

void View::computeTiles() {
  tiles_x = (width + kTile - 1) / kTile;
  tiles_y = (height + kTile - 1) / kTile;
  tile_bounds.assign(static_cast<size_t>(tiles_x) * tiles_y,
                     cv::Vec4f(std::numeric_limits<float>::max(), -std::numeric_limits<float>::max(),
                               std::numeric_limits<float>::max(), -std::numeric_limits<float>::max()));
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      cv::Vec4f& b = tile_bounds[static_cast<size_t>(y / kTile) * tiles_x + x / kTile];
      const size_t i = static_cast<size_t>(y) * width + x;
      b[0] = std::min(b[0], rx[i]);
      b[1] = std::max(b[1], rx[i]);
      b[2] = std::min(b[2], ry[i]);
      b[3] = std::max(b[3], ry[i]);
    }
}

// ---------------------------------------------------------------- SceneRenderer

SceneRenderer::SceneRenderer(const World& world, double near_m) : world_(world), near_(near_m) {
  for (const Texture& t : world.textures) {
    std::vector<TexLevel> lv;
    for (size_t l = 0; l < t.levels.size(); ++l) {
      const cv::Mat& m = t.levels[l];
      CV_Assert(m.type() == CV_8UC1 && (m.cols & (m.cols - 1)) == 0 && (m.rows & (m.rows - 1)) == 0);
      lv.push_back({m.ptr<uint8_t>(0), m.step[0], m.cols - 1, m.rows - 1, 1.0f / static_cast<float>(1 << l)});
    }
    levels_.push_back(std::move(lv));
  }
}

std::vector<SceneRenderer::CamQuad> SceneRenderer::prepare(const Eigen::Isometry3d& T_world_cam,
                                                           const std::vector<Quad>* moving) const {
  const Eigen::Isometry3d T_cam_world = T_world_cam.inverse();
  const Eigen::Matrix3d R = T_cam_world.linear();
  const size_t n_static = world_.quads.size(), n_moving = moving ? moving->size() : 0;
  std::vector<CamQuad> out;
  out.reserve(n_static + n_moving);
  for (size_t qi = 0; qi < n_static + n_moving; ++qi) {
    const Quad& q = qi < n_static ? world_.quads[qi] : (*moving)[qi - n_static];
    const Eigen::Vector3d p0 = T_cam_world * q.origin;
    const Eigen::Vector3d e = R * q.axis_s, f = R * q.axis_t, n = R * q.normal();
    const double c = n.dot(p0);
    if (q.one_sided && c >= 0) continue;  // the camera is behind the face
    // Clip the rectangle against the near plane z >= near (Sutherland-Hodgman), project, take the bounds.
    Eigen::Vector3d poly[4] = {p0, p0 + q.size_s * e, p0 + q.size_s * e + q.size_t * f, p0 + q.size_t * f};
    float b[4] = {std::numeric_limits<float>::max(), -std::numeric_limits<float>::max(),
                  std::numeric_limits<float>::max(), -std::numeric_limits<float>::max()};
    int count = 0;
    double min_z = std::numeric_limits<double>::max();
    for (int i = 0; i < 4; ++i) {
      const Eigen::Vector3d& a = poly[i];
      const Eigen::Vector3d& bb = poly[(i + 1) % 4];
      const bool ina = a.z() >= near_, inb = bb.z() >= near_;
      auto addPoint = [&](const Eigen::Vector3d& p) {
        min_z = std::min(min_z, p.z());
        const float x = static_cast<float>(p.x() / p.z()), y = static_cast<float>(p.y() / p.z());
        b[0] = std::min(b[0], x);
        b[1] = std::max(b[1], x);
        b[2] = std::min(b[2], y);
        b[3] = std::max(b[3], y);
        ++count;
      };
      if (ina) addPoint(a);
      if (ina != inb) addPoint(a + (bb - a) * ((near_ - a.z()) / (bb.z() - a.z())));
    }
    if (count == 0) continue;
    CamQuad cq;
    for (int k = 0; k < 3; ++k) {
      cq.n[k] = static_cast<float>(n[k]);
      cq.e[k] = static_cast<float>(e[k]);
      cq.f[k] = static_cast<float>(f[k]);
    }
    cq.c = static_cast<float>(c);
    cq.s0 = static_cast<float>(e.dot(p0));
    cq.t0 = static_cast<float>(f.dot(p0));
    cq.size_s = static_cast<float>(q.size_s);
    cq.size_t = static_cast<float>(q.size_t);
    std::copy(b, b + 4, cq.bounds);
    cq.quad = &q;
    cq.min_z = static_cast<float>(min_z);
    out.push_back(cq);
  }
  // Front to back, so that tiles already covered by nearer surfaces skip the quads behind them.
  std::stable_sort(out.begin(), out.end(), [](const CamQuad& a, const CamQuad& b) { return a.min_z < b.min_z; });
  return out;
}

void SceneRenderer::raster(const View& view, const std::vector<CamQuad>& quads, Buffers& buf, int ty,
                           const uint8_t* tiles) const {
  const int y0 = ty * View::kTile, y1 = std::min(view.height, y0 + View::kTile);
  const uint8_t* row_tiles = tiles ? tiles + static_cast<size_t>(ty) * view.tiles_x : nullptr;
  auto drawn = [&](int tx) { return !row_tiles || row_tiles[tx]; };
  float row_min = std::numeric_limits<float>::max(), row_max = -row_min;
  for (int tx = 0; tx < view.tiles_x; ++tx) {
    if (!drawn(tx)) continue;
    const cv::Vec4f& tb = view.tile_bounds[static_cast<size_t>(ty) * view.tiles_x + tx];
    row_min = std::min(row_min, tb[2]);
    row_max = std::max(row_max, tb[3]);
  }
  const float near = static_cast<float>(near_);
  // Farthest depth drawn in each tile of this row (infinite while a pixel is empty), refreshed lazily: a quad
  // entirely behind it cannot show in the tile.
  std::vector<float> tile_far(view.tiles_x, std::numeric_limits<float>::infinity());
  std::vector<char> tile_dirty(view.tiles_x, 0);
  for (size_t k = 0; k < quads.size(); ++k) {
    const CamQuad& q = quads[k];
    if (q.bounds[2] > row_max || q.bounds[3] < row_min) continue;
    for (int tx = 0; tx < view.tiles_x; ++tx) {
      if (!drawn(tx)) continue;
      const cv::Vec4f& tb = view.tile_bounds[static_cast<size_t>(ty) * view.tiles_x + tx];
      if (q.bounds[0] > tb[1] || q.bounds[1] < tb[0] || q.bounds[2] > tb[3] || q.bounds[3] < tb[2]) continue;
      const int x0 = tx * View::kTile, x1 = std::min(view.width, x0 + View::kTile);
      if (tile_dirty[tx]) {
        float far = 0;
        for (int y = y0; y < y1; ++y) {
          const float* zb = buf.z.data() + static_cast<size_t>(y) * view.width;
          for (int x = x0; x < x1; ++x) far = std::max(far, zb[x]);
        }
        tile_far[tx] = far;
        tile_dirty[tx] = 0;
      }
      if (q.min_z >= tile_far[tx]) continue;
      // Branch-free so that the compiler vectorises it.
      int wrote = 0;
      const int32_t id = static_cast<int32_t>(k);
      for (int y = y0; y < y1; ++y) {
        const size_t row = static_cast<size_t>(y) * view.width;
        const float* __restrict rx = view.rx.data() + row;
        const float* __restrict ry = view.ry.data() + row;
        float* __restrict zb = buf.z.data() + row;
        int32_t* __restrict ib = buf.id.data() + row;
        for (int x = x0; x < x1; ++x) {
          const float dx = rx[x], dy = ry[x];
          const float den = q.n[0] * dx + q.n[1] * dy + q.n[2];
          const float lam = q.c / den;  // depth z of the hit (the ray is (dx, dy, 1))
          const float s = lam * (q.e[0] * dx + q.e[1] * dy + q.e[2]) - q.s0;
          const float t = lam * (q.f[0] * dx + q.f[1] * dy + q.f[2]) - q.t0;
          const bool hit = (lam > near) & (lam < zb[x]) & (s >= 0) & (s <= q.size_s) & (t >= 0) & (t <= q.size_t);
          zb[x] = hit ? lam : zb[x];
          ib[x] = hit ? id : ib[x];
          wrote |= hit;
        }
      }
      if (wrote) tile_dirty[tx] = 1;
    }
  }
}

namespace {

inline float bilinearWrap(const SceneRenderer::TexLevel& img, float u, float v) {
  // floor without a library call (no SSE4.1 in the baseline instruction set)
  int iu0 = static_cast<int>(u), iv0 = static_cast<int>(v);
  iu0 -= u < static_cast<float>(iu0);
  iv0 -= v < static_cast<float>(iv0);
  const float a = u - static_cast<float>(iu0), b = v - static_cast<float>(iv0);
  const int iu = iu0 & img.wmask, iv = iv0 & img.hmask;
  const int iu1 = (iu + 1) & img.wmask, iv1 = (iv + 1) & img.hmask;
  const uint8_t* r0 = img.data + static_cast<size_t>(iv) * img.step;
  const uint8_t* r1 = img.data + static_cast<size_t>(iv1) * img.step;
  const float top = r0[iu] + a * (r0[iu1] - r0[iu]);
  const float bot = r1[iu] + a * (r1[iu1] - r1[iu]);
  return top + b * (bot - top);
}

// Wrapping an offset into [0, period) keeps texture coordinates small, so float precision is not lost.
inline float wrapOffset(double v, double period) { return static_cast<float>(v - std::floor(v / period) * period); }

// log2 to about 0.01 (exponent plus a quadratic in the mantissa): the level of detail needs no more.
inline float fastLog2(float v) {
  uint32_t bits;
  std::memcpy(&bits, &v, 4);
  const float e = static_cast<float>(static_cast<int>((bits >> 23) & 255) - 127);
  bits = (bits & 0x007fffffu) | 0x3f800000u;
  float m;
  std::memcpy(&m, &bits, 4);  // mantissa in [1, 2)
  return e + (-0.34484843f * m + 2.02466578f) * m - 0.67487759f;
}

}  // namespace

void SceneRenderer::shadeRow(const View& view, const std::vector<CamQuad>& quads, const Buffers& buf, int y, float gain,
                             float noise_sigma, uint64_t noise_seed, uint8_t* out8, float* out32, int x_begin,
                             int x_end) const {
  const size_t row = static_cast<size_t>(y) * view.width;
  if (x_end < 0) x_end = view.width;
  uint64_t state = noise_seed;
  // Irwin-Hall: the sum of four 16-bit uniforms, scaled to unit variance (var of one U(0,1) is 1/12).
  const float noise_scale = noise_sigma * std::sqrt(3.0f) / 65536.0f;
  // Constants of the quad seen by the previous pixel (runs of pixels see the same quad).
  int32_t cached = -2;
  const TexLevel* levels = nullptr;
  const Texture* tex = nullptr;
  float inv_texel_s = 0, inv_texel_t = 0, off_u = 0, off_v = 0, brightness = 0, lod_bias = 0, max_level = 0;
  // Where the lighting varies over the quad (WorldConfig::lighting_zones), each pixel's point of the floor plan,
  // origin + s axis_s + t axis_t, takes its own factor.
  bool lit_per_pixel = false;
  float plan_x0 = 0, plan_y0 = 0, plan_xs = 0, plan_ys = 0, plan_xt = 0, plan_yt = 0;
  for (int x = x_begin; x < x_end; ++x) {
    const int32_t id = buf.id[row + x];
    float value = 0;
    if (id >= 0) {
      const CamQuad& q = quads[id];
      if (id != cached) {
        const Quad& wq = *q.quad;
        tex = &world_.textures[wq.texture];
        levels = levels_[wq.texture].data();
        inv_texel_s = static_cast<float>(1.0 / wq.texel_s);
        inv_texel_t = static_cast<float>(1.0 / wq.texel_t);
        off_u = wrapOffset(wq.texture_offset.x(), tex->levels[0].cols);
        off_v = wrapOffset(wq.texture_offset.y(), tex->levels[0].rows);
        brightness = wq.brightness;
        lod_bias = static_cast<float>(-std::log2(view.focal * std::min(wq.texel_s, wq.texel_t)));
        max_level = static_cast<float>(tex->levels.size() - 1);
        lit_per_pixel = !world_.lighting.uniformOver(wq);
        plan_x0 = static_cast<float>(wq.origin.x());
        plan_y0 = static_cast<float>(wq.origin.y());
        plan_xs = static_cast<float>(wq.axis_s.x());
        plan_ys = static_cast<float>(wq.axis_s.y());
        plan_xt = static_cast<float>(wq.axis_t.x());
        plan_yt = static_cast<float>(wq.axis_t.y());
        cached = id;
      }
      const float dx = view.rx[row + x], dy = view.ry[row + x];
      const float lam = buf.z[row + x];
      const float s = lam * (q.e[0] * dx + q.e[1] * dy + q.e[2]) - q.s0;
      const float t = lam * (q.f[0] * dx + q.f[1] * dy + q.f[2]) - q.t0;
      // Level of detail: log2 of the pixel's footprint on the surface in texels, lam |d| / (f texel), widened by
      // 1 / sqrt(cos) of the slant (cos = |n.d| / |d|): footprint^2 = lam^2 |d|^3 / (|n.d| f^2 texel^2).
      const float d2 = dx * dx + dy * dy + 1.0f;
      const float den = std::max(0.02f, std::abs(q.n[0] * dx + q.n[1] * dy + q.n[2]));
      float lod = 0.5f * fastLog2(lam * lam * d2 * std::sqrt(d2) / den) + lod_bias;
      lod = std::clamp(lod, 0.0f, max_level);
      const int l0 = static_cast<int>(lod);
      const int l1 = std::min(l0 + 1, static_cast<int>(max_level));
      // "Brilinear": blend two levels only in the middle of the level interval, a third of the texture lookups
      // of full trilinear filtering for nearly the same smoothness across level changes.
      const float frac = std::clamp((lod - static_cast<float>(l0) - 0.35f) * (1.0f / 0.3f), 0.0f, 1.0f);
      const float u = s * inv_texel_s + off_u, v = t * inv_texel_t + off_v;
      const float sc0 = levels[l0].scale, sc1 = levels[l1].scale;
      const float a = frac < 1.0f ? bilinearWrap(levels[l0], u * sc0 - 0.5f, v * sc0 - 0.5f) : 0.0f;
      const float b = frac > 0.0f ? bilinearWrap(levels[l1], u * sc1 - 0.5f, v * sc1 - 0.5f) : a;
      value = brightness * (a + frac * (b - a));
      if (lit_per_pixel)
        value *= world_.lighting.at(plan_x0 + s * plan_xs + t * plan_xt, plan_y0 + s * plan_ys + t * plan_yt);
    }
    if (out32) {
      out32[x] = value;
      continue;
    }
    const float sum = irwinHall4(state);
    const float g = gain * value + noise_scale * sum + 0.5f;
    out8[x] = static_cast<uint8_t>(std::clamp(g, 0.0f, 255.0f));
  }
}

void SceneRenderer::render(const View& view, const Eigen::Isometry3d& T_world_cam, double t, cv::Mat* radiance,
                           cv::Mat* depth, const std::vector<uint8_t>* tiles) const {
  const std::vector<Quad> people = world_.peopleAt(t);
  renderQuads(view, prepare(T_world_cam, &people), radiance, depth, tiles);
}

void SceneRenderer::render(const View& view, const Eigen::Isometry3d& T_world_cam, cv::Mat* radiance,
                           cv::Mat* depth) const {
  renderQuads(view, prepare(T_world_cam), radiance, depth, nullptr);
}

void SceneRenderer::renderQuads(const View& view, const std::vector<CamQuad>& quads, cv::Mat* radiance, cv::Mat* depth,
                                const std::vector<uint8_t>* tiles) const {
  if (tiles && tiles->size() != static_cast<size_t>(view.tiles_x) * view.tiles_y)
    throw std::invalid_argument("SceneRenderer::render: need one flag per tile of the view");
  const uint8_t* marks = tiles ? tiles->data() : nullptr;
  Buffers buf;
  buf.z.assign(static_cast<size_t>(view.width) * view.height, std::numeric_limits<float>::infinity());
  buf.id.assign(buf.z.size(), -1);
  cv::parallel_for_(cv::Range(0, view.tiles_y), [&](const cv::Range& r) {
    for (int ty = r.start; ty < r.end; ++ty) raster(view, quads, buf, ty, marks);
  });
  if (depth) {
    depth->create(view.height, view.width, CV_32F);
    for (int y = 0; y < view.height; ++y)
      for (int x = 0; x < view.width; ++x) {
        const size_t i = static_cast<size_t>(y) * view.width + x;
        depth->at<float>(y, x) = buf.id[i] >= 0 ? buf.z[i] : 0.0f;
      }
  }
  if (radiance) {
    radiance->create(view.height, view.width, CV_32F);
    if (marks) *radiance = 0.0f;
    cv::parallel_for_(cv::Range(0, view.height), [&](const cv::Range& r) {
      for (int y = r.start; y < r.end; ++y) {
        float* out = radiance->ptr<float>(y);
        if (!marks) {
          shadeRow(view, quads, buf, y, 1, 0, 0, nullptr, out);
          continue;
        }
        const uint8_t* row_tiles = marks + static_cast<size_t>(y / View::kTile) * view.tiles_x;
        for (int tx = 0; tx < view.tiles_x; ++tx)
          if (row_tiles[tx])
            shadeRow(view, quads, buf, y, 1, 0, 0, nullptr, out, tx * View::kTile,
                     std::min(view.width, (tx + 1) * View::kTile));
      }
    });
  }
}

}  // namespace ips::sim
