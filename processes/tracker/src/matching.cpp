#include "ips/tracker/matching.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "ips/tracker/epipolar_integrity.hpp"

namespace ips::tracker {

bool normalizedPatch(const cv::Mat& gray8, int x, int y, int half, double min_std, float* out) {
  if (x - half < 0 || y - half < 0 || x + half >= gray8.cols || y + half >= gray8.rows) return false;
  const int side = 2 * half + 1, n = side * side;
  float sum = 0;
  for (int v = 0; v < side; ++v) {
    const uint8_t* row = gray8.ptr<uint8_t>(y - half + v) + (x - half);
    for (int u = 0; u < side; ++u) {
      out[v * side + u] = row[u];
      sum += row[u];
    }
  }
  const float mean = sum / n;
  float sq = 0;
  for (int k = 0; k < n; ++k) {
    out[k] -= mean;
    sq += out[k] * out[k];
  }
  if (sq < float(min_std * min_std * n) || sq <= 0) return false;
  const float inv = 1.0f / std::sqrt(sq);
  for (int k = 0; k < n; ++k) out[k] *= inv;
  return true;
}

float patchDot(const float* a, const float* b, int n) {
  float s = 0;
#pragma omp simd reduction(+ : s)
  for (int k = 0; k < n; ++k) s += a[k] * b[k];
  return s;
}

namespace {

// Vertex offset of the parabola through (-1, a), (0, b), (1, c), b the maximum; 0 when flat.
float parabolaPeak(float a, float b, float c) {
  const float den = a - 2 * b + c;
  if (!(den < 0)) return 0.f;
  return std::clamp(0.5f * (a - c) / den, -0.5f, 0.5f);
}

void checkPair(const cv::Mat& a, const cv::Mat& b, const char* what) {
  if (a.empty() || b.empty() || a.type() != CV_8UC1 || b.type() != CV_8UC1 || a.size() != b.size())
    throw std::invalid_argument(std::string(what) + ": need two 8-bit grey images of equal size");
}

}  // namespace

namespace {

// NCC of the normalised template t (half size h) with every window of row y of img centred on the columns
// x_lo .. x_lo + nc - 1 (all windows inside the image). The template row loop runs over the candidates
// innermost, which vectorises.
struct RowScratch {
  std::vector<float> strip, acc, colsum, colsq;
};

void rowCorrelation(const cv::Mat& img, int y, int x_lo, int nc, int h, const float* t, RowScratch& s,
                    std::vector<float>& ncc) {
  const int side = 2 * h + 1, n = side * side, sw = nc + 2 * h;
  s.strip.resize(size_t(side) * sw);
  for (int v = 0; v < side; ++v) {
    const uint8_t* row = img.ptr<uint8_t>(y - h + v) + (x_lo - h);
    float* dst = s.strip.data() + size_t(v) * sw;
    for (int k = 0; k < sw; ++k) dst[k] = row[k];
  }
  // Correlation with the zero-mean template: sum t * I (the window mean drops out).
  s.acc.assign(nc, 0.f);
  for (int v = 0; v < side; ++v) {
    const float* srow = s.strip.data() + size_t(v) * sw;
    for (int u = 0; u < side; ++u) {
      const float tv = t[v * side + u];
      const float* src = srow + u;
      float* a = s.acc.data();
      for (int k = 0; k < nc; ++k) a[k] += tv * src[k];
    }
  }
  // Window sums of I and I^2 via column sums.
  s.colsum.assign(sw, 0.f);
  s.colsq.assign(sw, 0.f);
  for (int v = 0; v < side; ++v) {
    const float* srow = s.strip.data() + size_t(v) * sw;
    for (int k = 0; k < sw; ++k) {
      s.colsum[k] += srow[k];
      s.colsq[k] += srow[k] * srow[k];
    }
  }
  ncc.resize(nc);
  float sum = 0, sq = 0;
  for (int k = 0; k < side; ++k) {
    sum += s.colsum[k];
    sq += s.colsq[k];
  }
  for (int k = 0; k < nc; ++k) {
    if (k > 0) {
      sum += s.colsum[k + side - 1] - s.colsum[k - 1];
      sq += s.colsq[k + side - 1] - s.colsq[k - 1];
    }
    const float var = sq - sum * sum / n;  // n * variance of the window
    ncc[k] = var > 1e-3f ? s.acc[k] / std::sqrt(var) : -1.f;
  }
}

int argmax(const std::vector<float>& v) { return int(std::max_element(v.begin(), v.end()) - v.begin()); }

}  // namespace

StereoFeatures matchAlongRows(const cv::Mat& left8, const cv::Mat& right8, const std::vector<Corner>& corners,
                              const MatcherParams& p) {
  checkPair(left8, right8, "matchAlongRows");
  if (p.ncc_half_window < 1 || p.max_disparity < p.min_disparity)
    throw std::invalid_argument("matchAlongRows: bad window or disparity range");
  StereoFeatures out;
  const int h = p.ncc_half_window, n = (2 * h + 1) * (2 * h + 1);
  out.half = h;
  const int w = right8.cols;
  std::vector<float> tmpl(n), right_patch(n), ncc, back;
  RowScratch scratch;
  for (const Corner& c : corners) {
    const int xl = c.xi, y = c.yi;
    if (!normalizedPatch(left8, xl, y, h, p.min_patch_std, tmpl.data())) continue;
    // Candidate right columns of the template centre.
    const int x_lo = std::max(h, int(std::floor(xl - p.max_disparity)));
    const int x_hi = std::min(w - 1 - h, int(std::ceil(xl - p.min_disparity)));
    const int nc = x_hi - x_lo + 1;
    if (nc < 3) continue;
    rowCorrelation(right8, y, x_lo, nc, h, tmpl.data(), scratch, ncc);
    const int best = argmax(ncc);
    if (ncc[best] < p.intra_min_ncc) continue;
    // A peak on the edge of the range may belong to a disparity outside it.
    if (best == 0 || best == nc - 1) continue;
    float second = -1.f;
    for (int k = 0; k < nc; ++k)
      if (std::abs(k - best) > 1) second = std::max(second, ncc[k]);
    if (ncc[best] - second < p.intra_uniqueness) continue;
    const int xr_int = x_lo + best;
    if (!normalizedPatch(right8, xr_int, y, h, p.min_patch_std, right_patch.data())) continue;
    if (p.intra_left_right_check) {
      // The right template searched back along the left row must land on the corner: windows that straddle
      // an occlusion boundary match the background one way and the foreground the other.
      const int b_lo = std::max(h, int(std::floor(xr_int + p.min_disparity)));
      const int b_hi = std::min(w - 1 - h, int(std::ceil(xr_int + p.max_disparity)));
      if (b_hi - b_lo + 1 < 3) continue;
      rowCorrelation(left8, y, b_lo, b_hi - b_lo + 1, h, right_patch.data(), scratch, back);
      if (std::abs(b_lo + argmax(back) - xl) > 1) continue;
    }
    const float xr = xr_int + parabolaPeak(ncc[best - 1], ncc[best], ncc[best + 1]);
    if (xl - xr < p.min_disparity) continue;
    out.push(xl, y, xr, xr_int, ncc[best], tmpl.data(), right_patch.data());
  }
  return out;
}

std::vector<VerticalMatch> matchAcrossRows(const cv::Mat& left8, const cv::Mat& right8,
                                           const std::vector<Corner>& corners, const MatcherParams& m,
                                           const IntegrityParams& p) {
  checkPair(left8, right8, "matchAcrossRows");
  if (m.ncc_half_window < 1 || m.max_disparity < m.min_disparity || p.search_rows < 1)
    throw std::invalid_argument("matchAcrossRows: bad window, disparity range or band");
  const int h = m.ncc_half_window, n = (2 * h + 1) * (2 * h + 1), band = 2 * p.search_rows + 1;
  const int w = right8.cols, rows = right8.rows;
  std::vector<float> tmpl(n), ncc;
  std::vector<std::vector<float>> grid(band);  // correlation per band row and candidate column
  RowScratch scratch;
  std::vector<VerticalMatch> out;
  for (const Corner& c : corners) {
    const int xl = c.xi, y = c.yi;
    if (y - p.search_rows - h < 0 || y + p.search_rows + h >= rows) continue;
    if (!normalizedPatch(left8, xl, y, h, m.min_patch_std, tmpl.data())) continue;
    const int x_lo = std::max(h, int(std::floor(xl - m.max_disparity)));
    const int x_hi = std::min(w - 1 - h, int(std::ceil(xl - m.min_disparity)));
    const int nc = x_hi - x_lo + 1;
    if (nc < 3) continue;
    int best_r = 0, best_k = 0;
    float best = -2.f;
    for (int r = 0; r < band; ++r) {
      rowCorrelation(right8, y - p.search_rows + r, x_lo, nc, h, tmpl.data(), scratch, grid[r]);
      const int k = argmax(grid[r]);
      if (grid[r][k] > best) best = grid[r][k], best_r = r, best_k = k;
    }
    if (best < p.min_ncc) continue;
    // On the band's or the range's edge the peak may lie outside them.
    if (best_r == 0 || best_r == band - 1 || best_k == 0 || best_k == nc - 1) continue;
    // Unique in both directions: along an edge the correlation is flat, and a corner on a near-vertical edge would
    // give any row of the band.
    float second = -1.f;
    for (int r = 0; r < band; ++r)
      for (int k = 0; k < nc; ++k)
        if (std::abs(k - best_k) > 1 || std::abs(r - best_r) > 1) second = std::max(second, grid[r][k]);
    if (best - second < p.uniqueness) continue;
    VerticalMatch vm;
    vm.xl = float(xl);
    vm.y = float(y);
    vm.xr = x_lo + best_k + parabolaPeak(grid[best_r][best_k - 1], best, grid[best_r][best_k + 1]);
    vm.dy = best_r - p.search_rows + parabolaPeak(grid[best_r - 1][best_k], best, grid[best_r + 1][best_k]);
    vm.ncc = best;
    out.push_back(vm);
  }
  return out;
}

std::optional<double> guideScale(const StereoRectification& stereo, double focal_px, double cx, double cy,
                                 double baseline_m, cv::Size map_size) {
  const cv::Size size = stereo.size;
  if (size.width < 1 || map_size.width < 1 || !(stereo.f > 0) || !(focal_px > 0)) return std::nullopt;
  const double scale = focal_px / stereo.f;
  if (!(scale > 0) || scale > 1.0 + 1e-9) return std::nullopt;
  const double tol_px = 1e-3;
  const bool same = std::abs(map_size.width - std::round(size.width * scale)) <= 1 &&
                    std::abs(map_size.height - std::round(size.height * scale)) <= 1 &&
                    std::abs(cx - ((stereo.cx + 0.5) * scale - 0.5)) <= tol_px &&
                    std::abs(cy - ((stereo.cy + 0.5) * scale - 0.5)) <= tol_px &&
                    std::abs(baseline_m - stereo.baseline) <= 1e-6 * stereo.baseline;
  if (!same) return std::nullopt;
  return scale;
}

void appendFeatures(StereoFeatures& a, const StereoFeatures& b) {
  if (b.size() == 0) return;
  if (a.size() == 0) a.half = b.half;
  if (a.half != b.half) throw std::invalid_argument("appendFeatures: template sizes differ");
  a.xl.insert(a.xl.end(), b.xl.begin(), b.xl.end());
  a.y.insert(a.y.end(), b.y.begin(), b.y.end());
  a.xr.insert(a.xr.end(), b.xr.begin(), b.xr.end());
  a.xr_int.insert(a.xr_int.end(), b.xr_int.begin(), b.xr_int.end());
  a.ncc.insert(a.ncc.end(), b.ncc.begin(), b.ncc.end());
  a.left_patch.insert(a.left_patch.end(), b.left_patch.begin(), b.left_patch.end());
  a.right_patch.insert(a.right_patch.end(), b.right_patch.begin(), b.right_patch.end());
}

StereoFeatures matchWithDisparity(const cv::Mat& left8, const cv::Mat& right8, const std::vector<Corner>& corners,
                                  const DisparityGuide& g, const MatcherParams& p, std::vector<Corner>* unguided,
                                  GuidedIntraCounts* counts) {
  checkPair(left8, right8, "matchWithDisparity");
  if (g.disparity.type() != CV_16SC1 || g.disparity.empty() || !(g.scale > 0) || g.scale > 1.0 || g.subpixel_scale < 1)
    throw std::invalid_argument(
        "matchWithDisparity: the guide needs a 16-bit map, a scale in (0, 1] and a subpixel scale");
  if (p.ncc_half_window < 1 || !(p.guide_search_map_px >= 0))
    throw std::invalid_argument("matchWithDisparity: bad window or search range");
  StereoFeatures out;
  GuidedIntraCounts n_local;
  GuidedIntraCounts& n = counts ? *counts : n_local;
  const int h = p.ncc_half_window, patch = (2 * h + 1) * (2 * h + 1);
  out.half = h;
  const int w = right8.cols;
  // Search radius in tracker pixels: the map's tolerance at its resolution, plus one column either side so
  // that a peak at the tolerance's edge is still an interior maximum of the parabola.
  const int radius = int(std::ceil(p.guide_search_map_px / g.scale));
  std::vector<float> tmpl(patch), right_patch(patch), ncc;
  RowScratch scratch;
  for (const Corner& c : corners) {
    const int xl = c.xi, y = c.yi;
    const int u = int(std::lround((xl + 0.5) * g.scale - 0.5)), v = int(std::lround((y + 0.5) * g.scale - 0.5));
    const int16_t raw = (u >= 0 && v >= 0 && u < g.disparity.cols && v < g.disparity.rows)
                            ? g.disparity.at<int16_t>(v, u)
                            : int16_t(g.invalid_value);
    if (raw == g.invalid_value || raw < 0) {
      ++n.map_invalid;
      if (unguided) unguided->push_back(c);
      continue;
    }
    if (!normalizedPatch(left8, xl, y, h, p.min_patch_std, tmpl.data())) continue;
    const double disparity = double(raw) / g.subpixel_scale / g.scale;
    const int xc = int(std::lround(xl - disparity));
    const int x_lo = std::max(h, xc - radius - 1), x_hi = std::min(w - 1 - h, xc + radius + 1);
    const int nc = x_hi - x_lo + 1;
    if (nc < 3) {
      ++n.check_failed;
      continue;
    }
    rowCorrelation(right8, y, x_lo, nc, h, tmpl.data(), scratch, ncc);
    const int best = argmax(ncc);
    if (ncc[best] < p.intra_min_ncc || best == 0 || best == nc - 1) {
      ++n.check_failed;
      continue;
    }
    const int xr_int = x_lo + best;
    if (!normalizedPatch(right8, xr_int, y, h, p.min_patch_std, right_patch.data())) {
      ++n.check_failed;
      continue;
    }
    const float xr = xr_int + parabolaPeak(ncc[best - 1], ncc[best], ncc[best + 1]);
    if (xl - xr < p.min_disparity || xl - xr > p.max_disparity) {
      ++n.check_failed;
      continue;
    }
    ++n.from_map;
    out.push(xl, y, xr, xr_int, ncc[best], tmpl.data(), right_patch.data());
  }
  return out;
}

namespace {

// Subpixel offset (dx, dy) of the best position (x, y) of template t in img, from the correlation with
// the four neighbours. Returns false when a neighbour window leaves the image or is flat.
bool refineSubpixel(const cv::Mat& img, int x, int y, int half, const float* t, float center, float* dx, float* dy) {
  const int n = (2 * half + 1) * (2 * half + 1);
  float buf[4][(2 * 15 + 1) * (2 * 15 + 1)];
  if (half > 15) return false;
  const int off[4][2] = {{-1, 0}, {1, 0}, {0, -1}, {0, 1}};
  float c[4];
  for (int k = 0; k < 4; ++k) {
    if (!normalizedPatch(img, x + off[k][0], y + off[k][1], half, 1e-3, buf[k])) return false;
    c[k] = patchDot(t, buf[k], n);
  }
  *dx = parabolaPeak(c[0], center, c[1]);
  *dy = parabolaPeak(c[2], center, c[3]);
  return true;
}

}  // namespace

std::vector<InterMatch> matchBetweenTimes(const StereoFeatures& prev, const StereoFeatures& now,
                                          const std::vector<Prediction>& pred, const cv::Mat& now_left8,
                                          const cv::Mat& now_right8, const MatcherParams& p) {
  checkPair(now_left8, now_right8, "matchBetweenTimes");
  if (pred.size() != prev.size()) throw std::invalid_argument("matchBetweenTimes: one prediction per feature");
  if (prev.half != now.half) throw std::invalid_argument("matchBetweenTimes: template sizes differ");
  std::vector<InterMatch> out;
  if (prev.size() == 0 || now.size() == 0) return out;
  const int n = prev.patchSize();

  // Bucket the newer features by left position so that a window visits only nearby candidates.
  const int cell = 16;
  const int gw = now_left8.cols / cell + 1, gh = now_left8.rows / cell + 1;
  std::vector<std::vector<int>> grid(size_t(gw) * gh);
  for (size_t j = 0; j < now.size(); ++j) grid[size_t(now.y[j] / cell) * gw + now.xl[j] / cell].push_back(int(j));

  std::vector<int> owner(now.size(), -1);  // best older feature per newer feature
  std::vector<float> owner_score(now.size(), -2.f);
  std::vector<int> choice(prev.size(), -1);
  std::vector<float> choice_score(prev.size(), -2.f);
  for (size_t i = 0; i < prev.size(); ++i) {
    const Prediction& q = pred[i];
    if (!(q.radius > 0) || !std::isfinite(q.xl) || !std::isfinite(q.y)) continue;
    const double pred_disp = q.xl - q.xr;
    const int cx0 = std::max(0, int(std::floor((q.xl - q.radius) / cell)));
    const int cx1 = std::min(gw - 1, int(std::floor((q.xl + q.radius) / cell)));
    const int cy0 = std::max(0, int(std::floor((q.y - q.radius) / cell)));
    const int cy1 = std::min(gh - 1, int(std::floor((q.y + q.radius) / cell)));
    int best = -1;
    float best_s = -2.f, second_s = -2.f;
    for (int cy = cy0; cy <= cy1; ++cy)
      for (int cx = cx0; cx <= cx1; ++cx)
        for (int j : grid[size_t(cy) * gw + cx]) {
          if (std::abs(now.xl[j] - q.xl) > q.radius || std::abs(now.y[j] - q.y) > q.radius) continue;
          if (std::abs((now.xl[j] - now.xr[j]) - pred_disp) > q.radius) continue;
          const float sl = patchDot(prev.leftPatch(i), now.leftPatch(j), n);
          if (sl < p.inter_min_ncc - p.inter_uniqueness) continue;
          const float s = std::min(sl, patchDot(prev.rightPatch(i), now.rightPatch(j), n));
          if (s > best_s) {
            // The old best is a competitor unless it is the same image structure (adjacent pixel).
            if (best >= 0 && (std::abs(now.xl[best] - now.xl[j]) > 2 || std::abs(now.y[best] - now.y[j]) > 2))
              second_s = std::max(second_s, best_s);
            best_s = s;
            best = j;
          } else if (std::abs(now.xl[best] - now.xl[j]) > 2 || std::abs(now.y[best] - now.y[j]) > 2) {
            second_s = std::max(second_s, s);
          }
        }
    if (best < 0 || best_s < p.inter_min_ncc || best_s - second_s < p.inter_uniqueness) continue;
    choice[i] = best;
    choice_score[i] = best_s;
    if (best_s > owner_score[best]) {
      owner_score[best] = best_s;
      owner[best] = int(i);
    }
  }

  for (size_t i = 0; i < prev.size(); ++i) {
    const int j = choice[i];
    if (j < 0 || owner[j] != int(i)) continue;
    float lx, ly, rx, ry;
    const float cl = patchDot(prev.leftPatch(i), now.leftPatch(j), n);
    const float cr = patchDot(prev.rightPatch(i), now.rightPatch(j), n);
    if (!refineSubpixel(now_left8, now.xl[j], now.y[j], now.half, prev.leftPatch(i), cl, &lx, &ly)) continue;
    if (!refineSubpixel(now_right8, now.xr_int[j], now.y[j], now.half, prev.rightPatch(i), cr, &rx, &ry)) continue;
    InterMatch m;
    m.prev = int(i);
    m.now = j;
    m.ncc = choice_score[i];
    m.prev_obs = {double(prev.xl[i]), double(prev.y[i]), double(prev.xr[i])};
    // The older right observation sits (xr - xr_int) from its template centre; it moves with the template.
    const double yl = now.y[j] + ly, yr = now.y[j] + ry;
    if (std::abs(yl - yr) > p.epipolar_tolerance_px) continue;
    m.now_obs.xl = now.xl[j] + lx;
    m.now_obs.y = 0.5 * (yl + yr);
    m.now_obs.xr = now.xr_int[j] + rx + (prev.xr[i] - prev.xr_int[i]);
    if (m.now_obs.xl - m.now_obs.xr < p.min_disparity) continue;
    const Prediction& q = pred[i];
    m.prediction_ok = std::abs(m.now_obs.xl - q.xl) <= p.prior_ok_px && std::abs(m.now_obs.y - q.y) <= p.prior_ok_px;
    out.push_back(m);
  }
  return out;
}

}  // namespace ips::tracker
