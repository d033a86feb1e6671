// Plain C++ reference of E3D's SGM (see ips/e3d/sgm.hpp). Written for clarity, not speed: it is what the
// device pipeline is compared with, pixel for pixel.
#include <algorithm>
#include <array>
#include <climits>
#include <cstdlib>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <vector>

#include "ips/e3d/sgm.hpp"

namespace ips {
namespace e3d {

namespace {

int clampi(int v, int lo, int hi) { return v < lo ? lo : (v > hi ? hi : v); }

// Rounds 8 * (c0 - c2) / den to the nearest integer, halves away from zero (the device does the same).
int equiangularOffset16(int c0, int c1, int c2) {
  int den = std::max(c0, c2) - c1;
  if (den <= 0) return 0;
  int num = 8 * (c0 - c2);
  int mag = (2 * std::abs(num) + den) / (2 * den);
  return num < 0 ? -mag : mag;
}

}  // namespace

// Step 6: the 3x3 median (the device's median3x3).
cv::Mat median3x3(const cv::Mat& in) {
  cv::Mat out(in.size(), CV_16S);
  for (int y = 0; y < in.rows; ++y)
    for (int x = 0; x < in.cols; ++x) {
      std::array<int16_t, 9> v;
      int n = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
          v[n++] = in.at<int16_t>(clampi(y + dy, 0, in.rows - 1), clampi(x + dx, 0, in.cols - 1));
      std::nth_element(v.begin(), v.begin() + 4, v.end());
      out.at<int16_t>(y, x) = v[4];
    }
  return out;
}

DisparityBands DisparityBands::full(cv::Size size, int num_disparities) {
  DisparityBands b;
  b.size = size;
  b.num_disparities = num_disparities;
  const size_t n = static_cast<size_t>(size.area());
  b.lo.assign(n, 0);
  b.hi.assign(n, static_cast<uint8_t>(num_disparities - 1));
  return b;
}

double DisparityBands::searchedShare() const {
  double sum = 0;
  for (size_t i = 0; i < lo.size(); ++i) sum += width(i);
  return lo.empty() ? 0.0 : sum / (static_cast<double>(lo.size()) * num_disparities);
}

SgmParams coarseLevelParams(const SgmParams& p) {
  SgmParams c = p;
  levelRange(p.min_disparity, p.num_disparities, 1, c.min_disparity, c.num_disparities);
  c.search = Search::full;
  c.fill_invalid = false;
  return c;
}

DisparityBands narrowedBands(const cv::Mat& coarse16, cv::Size size, const SgmParams& p) {
  const int D = p.num_disparities;
  DisparityBands b = DisparityBands::full(size, D);
  if (coarse16.type() != CV_16S || coarse16.cols != (size.width + 1) / 2 || coarse16.rows != (size.height + 1) / 2)
    throw std::invalid_argument("narrowedBands: the coarse map must be CV_16S of the half size");
  const int width = std::min(p.band_width, D);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      int dmin = INT_MAX, dmax = INT_MIN;  // x 16, at the coarse resolution
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int cy = y / 2 + dy, cx = x / 2 + dx;
          if (cy < 0 || cy >= coarse16.rows || cx < 0 || cx >= coarse16.cols) continue;
          const int d = coarse16.at<int16_t>(cy, cx);
          if (d == kInvalidDisparity) continue;
          dmin = std::min(dmin, d);
          dmax = std::max(dmax, d);
        }
      if (dmin == INT_MAX) continue;  // no coarse match near: the full range
      // Doubled to full resolution, to whole pixels outwards (floor, ceil of 2 d / 16 = d / 8), with the margin.
      const int lo_d = (dmin >= 0 ? dmin / 8 : -((-dmin + 7) / 8)) - p.band_margin;
      const int hi_d = (dmax >= 0 ? (dmax + 7) / 8 : -((-dmax) / 8)) + p.band_margin;
      int lo = clampi(lo_d - p.min_disparity, 0, D - 1), hi = clampi(hi_d - p.min_disparity, 0, D - 1);
      const int extra = width - (hi - lo + 1);
      if (extra > 0) {  // widen to band_width about the span, shifted into the range
        lo -= extra / 2;
        hi += extra - extra / 2;
        if (lo < 0) hi -= lo, lo = 0;
        if (hi > D - 1) lo -= hi - (D - 1), hi = D - 1;
      }
      const size_t i = static_cast<size_t>(y) * size.width + x;
      b.lo[i] = static_cast<uint8_t>(lo);
      b.hi[i] = static_cast<uint8_t>(hi);
    }
  return b;
}

// Step 3, one path.
std::vector<uint16_t> pathCosts(const cv::Mat& left, const std::vector<uint8_t>& cost, const SgmParams& p, int r,
                                const DisparityBands* bands) {
  const int W = left.cols, H = left.rows, D = p.num_disparities;
  if (r < 0 || r >= 8) throw std::invalid_argument("pathCosts: path must be 0..7");
  const DisparityBands full = bands ? DisparityBands() : DisparityBands::full(left.size(), D);
  const DisparityBands& band = bands ? *bands : full;
  if (band.size != left.size() || band.num_disparities != D)
    throw std::invalid_argument("pathCosts: bands of another size or range");
  constexpr int kInfinity = 1 << 20;  // outside a band: above any path cost plus any penalty
  std::vector<int> path(cost.size(), kInfinity);
  const int dx = kPathDirections[r][0], dy = kPathDirections[r][1];
  // Visit pixels so that p - r always comes before p.
  for (int yi = 0; yi < H; ++yi) {
    const int y = dy >= 0 ? yi : H - 1 - yi;
    for (int xi = 0; xi < W; ++xi) {
      const int x = dx >= 0 ? xi : W - 1 - xi;
      const size_t pixel = static_cast<size_t>(y) * W + x;
      const size_t idx = pixel * D;
      const int lo = band.lo[pixel], hi = band.hi[pixel];
      const int px = x - dx, py = y - dy;
      if (px < 0 || px >= W || py < 0 || py >= H) {
        for (int k = lo; k <= hi; ++k) path[idx + k] = cost[idx + k];
      } else {
        const size_t previous = static_cast<size_t>(py) * W + px;
        const size_t pidx = previous * D;
        const int plo = band.lo[previous], phi = band.hi[previous];
        int m = path[pidx + plo];
        for (int k = plo + 1; k <= phi; ++k) m = std::min(m, path[pidx + k]);
        int p2 = p.p2;
        if (p.p2_slope > 0) {
          const int grad = std::abs(int(left.at<uint8_t>(y, x)) - int(left.at<uint8_t>(py, px)));
          p2 = std::max(p.p1, p.p2 - (p.p2_slope * grad) / 16);
        }
        for (int k = lo; k <= hi; ++k) {  // entries outside the previous band are kInfinity
          int best = std::min(path[pidx + k], m + p2);
          if (k > 0) best = std::min(best, path[pidx + k - 1] + p.p1);
          if (k + 1 < D) best = std::min(best, path[pidx + k + 1] + p.p1);
          path[idx + k] = cost[idx + k] + best - m;
        }
      }
    }
  }
  std::vector<uint16_t> out(path.size());
  for (size_t i = 0; i < path.size(); ++i) out[i] = path[i] >= kInfinity ? kOutOfBand : static_cast<uint16_t>(path[i]);
  return out;
}

// Step 3: the sums of the path costs [y][x][k].
std::vector<uint16_t> aggregateCosts(const cv::Mat& left, const std::vector<uint8_t>& cost, const SgmParams& p,
                                     const DisparityBands* bands) {
  std::vector<uint16_t> sum(cost.size(), 0);
  for (int r = 0; r < p.paths; ++r) {
    const std::vector<uint16_t> path = pathCosts(left, cost, p, r, bands);
    for (size_t i = 0; i < sum.size(); ++i)
      sum[i] = path[i] == kOutOfBand ? kOutOfBand : static_cast<uint16_t>(sum[i] + path[i]);
  }
  return sum;
}

// Steps 4-5: the left map by winner-takes-all and the right map by the diagonal search, before the median.
void winnerTakesAll(const std::vector<uint16_t>& sum, cv::Size size, const SgmParams& p, cv::Mat& dl, cv::Mat& dr,
                    const DisparityBands* bands) {
  const int W = size.width, H = size.height, D = p.num_disparities;
  const DisparityBands full = bands ? DisparityBands() : DisparityBands::full(size, D);
  const DisparityBands& band = bands ? *bands : full;
  dl.create(H, W, CV_16S);
  dr.create(H, W, CV_16S);
  for (int y = 0; y < H; ++y) {
    std::vector<int> bestRight(W, -1), bestRightCost(W, 0);
    for (int x = 0; x < W; ++x) {
      const size_t pixel = static_cast<size_t>(y) * W + x;
      const int lo = band.lo[pixel], hi = band.hi[pixel];
      const uint16_t* s = &sum[pixel * D];
      int best = lo;
      for (int k = lo + 1; k <= hi; ++k)
        if (s[k] < s[best]) best = k;
      // A winner on a band's edge inside the range: the minimum may lie beyond it.
      bool valid = !(best == lo && lo > 0) && !(best == hi && hi < D - 1);
      if (p.uniqueness > 0) {
        for (int k = lo; k <= hi; ++k)
          if (std::abs(k - best) > 1 && s[k] * (100 - p.uniqueness) < s[best] * 100) valid = false;
      }
      int d16 = (p.min_disparity + best) * kSubpixelScale;
      if (p.subpixel && best > lo && best < hi) d16 += equiangularOffset16(s[best - 1], s[best], s[best + 1]);
      dl.at<int16_t>(y, x) = valid ? static_cast<int16_t>(d16) : kInvalidDisparity;
      for (int k = lo; k <= hi; ++k) {  // diagonal search for the right image
        const int xr = x - p.min_disparity - k;
        if (xr < 0 || xr >= W) continue;
        if (bestRight[xr] < 0 || s[k] < bestRightCost[xr] || (s[k] == bestRightCost[xr] && k < bestRight[xr])) {
          bestRight[xr] = k;
          bestRightCost[xr] = s[k];
        }
      }
    }
    for (int xr = 0; xr < W; ++xr)
      dr.at<int16_t>(y, xr) = bestRight[xr] < 0
                                  ? kInvalidDisparity
                                  : static_cast<int16_t>((p.min_disparity + bestRight[xr]) * kSubpixelScale);
  }
}

// Step 6: the left-right check, in place.
void leftRightCheck(cv::Mat& dl, const cv::Mat& dr, int max_diff) {
  const int W = dl.cols, H = dl.rows;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      int16_t& d = dl.at<int16_t>(y, x);
      if (d == kInvalidDisparity) continue;
      const int xr = x - ((d + kSubpixelScale / 2) >> 4);
      if (xr < 0 || xr >= W) {
        d = kInvalidDisparity;
        continue;
      }
      const int16_t r = dr.at<int16_t>(y, xr);
      if (r == kInvalidDisparity || std::abs(int(d) - int(r)) > max_diff * kSubpixelScale) d = kInvalidDisparity;
    }
}

namespace {

// Steps 3-5: from the matching costs [y][x][k], the left and right maps before the median.
void rawMaps(const cv::Mat& left, const std::vector<uint8_t>& cost, const SgmParams& p, cv::Mat& dl, cv::Mat& dr,
             const DisparityBands* bands = nullptr) {
  winnerTakesAll(aggregateCosts(left, cost, p, bands), left.size(), p, dl, dr, bands);
}

// One match with given Mutual Information tables (ignored by the other costs): steps 3-6 (no fill).
// With `bands` (census, ad, sad; right_map diagonal) only each pixel's band is searched.
SgmResult matchWithTables(const cv::Mat& left, const cv::Mat& right, const SgmParams& p, const MiTables& mi_tables,
                          const DisparityBands* bands = nullptr) {
  cv::Mat dl, dr;
  rawMaps(left, costVolume(left, right, p, mi_tables), p, dl, dr, bands);
  if (p.right_map == RightMap::match) {
    // The right image's map from a second match, right to left: the mirrored pair (mirrored right image as the
    // left one) has the same disparities; its left map, mirrored back, is the right map. The Mutual Information
    // tables of the swapped pair are the transposed ones, their regions mirrored.
    cv::Mat mirrored_left, mirrored_right, mirrored_map, unused;
    cv::flip(right, mirrored_left, 1);
    cv::flip(left, mirrored_right, 1);
    rawMaps(mirrored_left, costVolume(mirrored_left, mirrored_right, p, mi_tables.swapped()), p, mirrored_map, unused);
    cv::flip(mirrored_map, dr, 1);
  }

  if (p.median) {
    dl = median3x3(dl);
    dr = median3x3(dr);
  }
  if (p.lr_max_diff >= 0) leftRightCheck(dl, dr, p.lr_max_diff);
  return {dl, dr};
}

}  // namespace

// Step 7: each invalid pixel takes the smaller (background) of the nearest valid disparities on its row.
void fillInvalid(cv::Mat& dl) {
  const int W = dl.cols, H = dl.rows;
  for (int y = 0; y < H; ++y) {
    const cv::Mat row = dl.row(y).clone();
    std::vector<int> next_valid(W, kInvalidDisparity);
    int next = kInvalidDisparity;
    for (int x = W - 1; x >= 0; --x) {
      if (row.at<int16_t>(x) != kInvalidDisparity) next = row.at<int16_t>(x);
      next_valid[x] = next;
    }
    int last = kInvalidDisparity;
    for (int x = 0; x < W; ++x) {
      const int d = row.at<int16_t>(x);
      if (d != kInvalidDisparity) {
        last = d;
      } else if (last != kInvalidDisparity) {
        dl.at<int16_t>(y, x) =
            static_cast<int16_t>(next_valid[x] == kInvalidDisparity ? last : std::min(last, next_valid[x]));
      } else {
        dl.at<int16_t>(y, x) = static_cast<int16_t>(next_valid[x]);
      }
    }
  }
}

SgmResult sgmReference(const cv::Mat& left, const cv::Mat& right, const SgmParams& p) {
  p.validate();
  if (left.empty() || left.type() != CV_8UC1 || right.type() != CV_8UC1 || left.size() != right.size())
    throw std::invalid_argument("sgmReference: need two CV_8UC1 images of the same size");
  if (p.search == Search::narrowed) {
    // The coarse match over the half resolution's range, then each pixel's band at full resolution.
    const SgmResult coarse = matchWithTables(halfSize(left), halfSize(right), coarseLevelParams(p), MiTables());
    const DisparityBands bands = narrowedBands(coarse.left, left.size(), p);
    SgmResult result = matchWithTables(left, right, p, MiTables(), &bands);
    if (p.fill_invalid) fillInvalid(result.left);
    return result;
  }
  if (p.cost != Cost::mi) {
    SgmResult result = matchWithTables(left, right, p, MiTables());
    if (p.fill_invalid) fillInvalid(result.left);
    return result;
  }
  // Mutual Information, hierarchically: the pyramid, the coarsest level from the start disparity (repeatedly),
  // then each finer level from the checked left map of the level below, doubled.
  std::vector<cv::Mat> lefts{left}, rights{right};
  for (int l = 1; l < p.mi_levels; ++l) {
    lefts.push_back(halfSize(lefts.back()));
    rights.push_back(halfSize(rights.back()));
  }
  cv::Mat guide;  // the disparity the next table learns from, at the next level's resolution
  SgmResult result;
  for (int l = p.mi_levels - 1; l >= 0; --l) {
    const SgmParams lp = miLevelParams(p, l, lefts[l].size());
    const int iterations = l == p.mi_levels - 1 ? p.mi_coarse_iterations : 1;
    if (l == p.mi_levels - 1) guide = miStartDisparity(lefts[l].size(), lp.min_disparity, lp.num_disparities);
    for (int it = 0; it < iterations; ++it) {
      result = matchWithTables(lefts[l], rights[l], lp,
                               miTables(lefts[l], rights[l], guide, lp.mi_region_columns, lp.mi_region_rows));
      guide = result.left;
    }
    if (l > 0) guide = doubleDisparity(result.left, lefts[l - 1].size());
  }
  if (p.fill_invalid) fillInvalid(result.left);
  return result;
}

}  // namespace e3d
}  // namespace ips
