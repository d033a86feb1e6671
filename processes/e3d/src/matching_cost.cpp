// E3D's matching costs and the Mutual Information table (see ips/e3d/matching_cost.hpp): the plain C++ versions
// the device stages are compared with.
#include "ips/e3d/matching_cost.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

#include "ips/e3d/sgm.hpp"
#include "ips/e3d_shaders/interface.h"

namespace ips {
namespace e3d {

namespace {

int clampi(int v, int lo, int hi) { return v < lo ? lo : (v > hi ? hi : v); }

constexpr int kCostMax = 63;  // ad, sad, mi
constexpr int kBins = 256;
// The Parzen window: binomial (1 6 15 20 15 6 1), sum 64.
constexpr int kParzen[7] = {1, 6, 15, 20, 15, 6, 1};

// The costs [y][x][k] of sad and of windowed mi: the mean of the centre pixel's pair cost, pair_cost_at(x, y)(L,
// R), over the 3x3 windows around x and x - d, every column and row clamped into the image, rounded and truncated:
// min((sum + 4) / 9, 63).
template <typename PairCostAt>
void window3x3Mean(const cv::Mat& left, const cv::Mat& right, const SgmParams& p, std::vector<uint8_t>& cost,
                   PairCostAt pair_cost_at) {
  const int W = left.cols, H = left.rows, D = p.num_disparities;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const auto pair_cost = pair_cost_at(x, y);
      for (int k = 0; k < D; ++k) {
        int sum = 0;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int yy = clampi(y + dy, 0, H - 1);
            sum += pair_cost(left.at<uint8_t>(yy, clampi(x + dx, 0, W - 1)),
                             right.at<uint8_t>(yy, clampi(x + dx - (p.min_disparity + k), 0, W - 1)));
          }
        cost[(static_cast<size_t>(y) * W + x) * D + k] = static_cast<uint8_t>(std::min((sum + 4) / 9, kCostMax));
      }
    }
}

}  // namespace

int maxCost(Cost cost) { return cost == Cost::census ? kCensusMaxCost : kCostMax; }

bool isWindowCost(const SgmParams& params) {
  return params.cost == Cost::sad || (params.cost == Cost::mi && params.mi_window == 3);
}

cv::Mat census5x5(const cv::Mat& image) {
  if (image.empty() || image.type() != CV_8UC1) throw std::invalid_argument("census5x5: need a CV_8UC1 image");
  const int W = image.cols, H = image.rows;
  cv::Mat out(image.size(), CV_32S);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const int c = image.at<uint8_t>(y, x);
      uint32_t code = 0;
      for (int dy = -2; dy <= 2; ++dy)
        for (int dx = -2; dx <= 2; ++dx) {
          if (dx == 0 && dy == 0) continue;
          const int q = image.at<uint8_t>(clampi(y + dy, 0, H - 1), clampi(x + dx, 0, W - 1));
          code = (code << 1) | (q < c ? 1u : 0u);
        }
      out.at<int32_t>(y, x) = static_cast<int32_t>(code);
    }
  return out;
}

int miRegionOf(int coordinate, int regions, int extent) { return E3D_REGION_OF(coordinate, regions, extent); }

const cv::Mat& MiTables::at(int x, int y, cv::Size size) const {
  const int column = miRegionOf(mirrored ? size.width - 1 - x : x, columns, size.width);
  return tables[static_cast<size_t>(miRegionOf(y, rows, size.height) * columns + column)];
}

MiTables MiTables::swapped() const {
  MiTables s = *this;
  s.mirrored = !mirrored;
  for (cv::Mat& t : s.tables) t = t.t();
  return s;
}

std::vector<uint8_t> costVolume(const cv::Mat& left, const cv::Mat& right, const SgmParams& p,
                                const cv::Mat& mi_table) {
  MiTables tables;
  if (!mi_table.empty()) tables.tables.push_back(mi_table);
  return costVolume(left, right, p, tables);
}

std::vector<uint8_t> costVolume(const cv::Mat& left, const cv::Mat& right, const SgmParams& p,
                                const MiTables& mi_tables) {
  const int W = left.cols, H = left.rows, D = p.num_disparities;
  std::vector<uint8_t> cost(static_cast<size_t>(W) * H * D);
  auto at = [&](int y, int x, int k) -> uint8_t& { return cost[(static_cast<size_t>(y) * W + x) * D + k]; };
  auto column = [&](int x, int k) { return clampi(x - (p.min_disparity + k), 0, W - 1); };
  if (p.cost == Cost::census) {
    const cv::Mat cl = census5x5(left), cr = census5x5(right);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        for (int k = 0; k < D; ++k) {
          const uint32_t a = static_cast<uint32_t>(cl.at<int32_t>(y, x));
          const uint32_t b = static_cast<uint32_t>(cr.at<int32_t>(y, column(x, k)));
          at(y, x, k) = static_cast<uint8_t>(__builtin_popcount(a ^ b));
        }
  } else {
    // The intensity costs: a pair cost of the two greys, pixelwise (ad, mi with mi_window 1) or its mean over the
    // 3x3 windows (sad, mi with mi_window 3).
    if (p.cost == Cost::mi) {
      if (mi_tables.columns < 1 || mi_tables.rows < 1 ||
          mi_tables.tables.size() != static_cast<size_t>(mi_tables.columns * mi_tables.rows))
        throw std::invalid_argument("costVolume: cost mi needs one table per region");
      for (const cv::Mat& t : mi_tables.tables)
        if (t.type() != CV_8UC1 || t.rows != kBins || t.cols != kBins)
          throw std::invalid_argument("costVolume: cost mi needs 256x256 CV_8UC1 tables");
    }
    // The pair cost of centre pixel (x, y): its region's table (mi) or the grey difference.
    const auto pair_cost_at = [&](int x, int y) {
      const cv::Mat* table = p.cost == Cost::mi ? &mi_tables.at(x, y, left.size()) : nullptr;
      return [table](int left_grey, int right_grey) {
        return table ? int(table->at<uint8_t>(left_grey, right_grey)) : std::abs(left_grey - right_grey);
      };
    };
    if (isWindowCost(p)) {
      window3x3Mean(left, right, p, cost, pair_cost_at);
    } else {
      for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
          const auto pair_cost = pair_cost_at(x, y);
          for (int k = 0; k < D; ++k)
            at(y, x, k) = static_cast<uint8_t>(
                std::min(pair_cost(left.at<uint8_t>(y, x), right.at<uint8_t>(y, column(x, k))), kCostMax));
        }
    }
  }
  return cost;
}

const std::vector<int32_t>& log2FractionTable() {
  static const std::vector<int32_t> table = [] {
    std::vector<int32_t> t(256);
    for (int j = 0; j < 256; ++j) t[j] = static_cast<int32_t>(std::lround(256.0 * std::log2(1.0 + j / 256.0)));
    return t;
  }();
  return table;
}

int log2q8(uint64_t v) {
  if (v == 0) throw std::invalid_argument("log2q8(0)");
  int e = 63;
  while (!((v >> e) & 1u)) --e;
  const uint64_t top = e >= 8 ? v >> (e - 8) : v << (8 - e);  // 256..511: the leading one and 8 bits
  return 256 * e + log2FractionTable()[static_cast<int>(top - 256)];
}

namespace {

// Convolution with kParzen along one axis of a 256x256 table (rows: along k), zero or repeated edges.
template <typename T>
std::vector<T> parzen2(const std::vector<T>& in, bool along_k, bool repeat_edges) {
  std::vector<T> out(in.size(), 0);
  for (int i = 0; i < kBins; ++i)
    for (int k = 0; k < kBins; ++k) {
      T acc = 0;
      for (int t = 0; t < 7; ++t) {
        int ii = i, kk = k;
        (along_k ? kk : ii) += t - 3;
        if (ii < 0 || ii >= kBins || kk < 0 || kk >= kBins) {
          if (!repeat_edges) continue;
          ii = clampi(ii, 0, kBins - 1);
          kk = clampi(kk, 0, kBins - 1);
        }
        acc += static_cast<T>(kParzen[t]) * in[ii * kBins + kk];
      }
      out[i * kBins + k] = acc;
    }
  return out;
}

template <typename T>
std::vector<T> parzen1(const std::vector<T>& in, bool repeat_edges) {
  std::vector<T> out(kBins, 0);
  for (int i = 0; i < kBins; ++i)
    for (int t = 0; t < 7; ++t) {
      int ii = i + t - 3;
      if (ii < 0 || ii >= kBins) {
        if (!repeat_edges) continue;
        ii = clampi(ii, 0, kBins - 1);
      }
      out[i] += static_cast<T>(kParzen[t]) * in[ii];
    }
  return out;
}

}  // namespace

std::vector<JointHistogram> miJointHistograms(const cv::Mat& left, const cv::Mat& right, const cv::Mat& disparity16,
                                              int columns, int rows) {
  if (left.type() != CV_8UC1 || right.type() != CV_8UC1 || left.size() != right.size() ||
      disparity16.type() != CV_16S || disparity16.size() != left.size())
    throw std::invalid_argument("miJointHistogram: need two CV_8UC1 images and a CV_16S disparity map of one size");
  if (columns < 1 || rows < 1) throw std::invalid_argument("miJointHistograms: need at least one region");
  const int W = left.cols, H = left.rows;
  std::vector<JointHistogram> histograms(static_cast<size_t>(columns * rows));
  for (JointHistogram& h : histograms) h.bins.assign(kBins * kBins, 0);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const int d = disparity16.at<int16_t>(y, x);
      if (d == kInvalidDisparity) continue;
      const int xr = x - ((d + kSubpixelScale / 2) >> 4);
      if (xr < 0 || xr >= W) continue;
      JointHistogram& h = histograms[static_cast<size_t>(miRegionOf(y, rows, H) * columns + miRegionOf(x, columns, W))];
      ++h.bins[left.at<uint8_t>(y, x) * kBins + right.at<uint8_t>(y, xr)];
      ++h.count;
    }
  return histograms;
}

JointHistogram miJointHistogram(const cv::Mat& left, const cv::Mat& right, const cv::Mat& disparity16) {
  return miJointHistograms(left, right, disparity16, 1, 1).front();
}

cv::Mat miTable(const cv::Mat& left, const cv::Mat& right, const cv::Mat& disparity16) {
  return miTable(miJointHistogram(left, right, disparity16));
}

MiTables miTables(const cv::Mat& left, const cv::Mat& right, const cv::Mat& disparity16, int columns, int rows) {
  MiTables tables;
  tables.columns = columns;
  tables.rows = rows;
  for (const JointHistogram& h : miJointHistograms(left, right, disparity16, columns, rows))
    tables.tables.push_back(miTable(h));
  return tables;
}

cv::Mat miTable(const JointHistogram& histogram) {
  // 1. The joint histogram of the matched pixels.
  const std::vector<uint64_t>& hist = histogram.bins;
  const uint64_t n = histogram.count;
  // 2. Parzen smoothing of the joint histogram and of the marginals.
  std::vector<uint64_t> marginal_left(kBins, 0), marginal_right(kBins, 0);
  for (int i = 0; i < kBins; ++i)
    for (int k = 0; k < kBins; ++k) {
      marginal_left[i] += hist[i * kBins + k];
      marginal_right[k] += hist[i * kBins + k];
    }
  const std::vector<uint64_t> smooth = parzen2(parzen2(hist, true, false), false, false);  // scale 4096
  const std::vector<uint64_t> smooth_left = parzen1(marginal_left, false),
                              smooth_right = parzen1(marginal_right, false);
  // 3. Information in 1/256 bit (n = 0: a uniform table).
  const uint64_t total = std::max<uint64_t>(n, 1);
  std::vector<int32_t> info(kBins * kBins), info_left(kBins), info_right(kBins);
  for (int i = 0; i < kBins * kBins; ++i) info[i] = log2q8(4096 * total) - log2q8(std::max<uint64_t>(smooth[i], 1));
  for (int i = 0; i < kBins; ++i) {
    info_left[i] = log2q8(64 * total) - log2q8(std::max<uint64_t>(smooth_left[i], 1));
    info_right[i] = log2q8(64 * total) - log2q8(std::max<uint64_t>(smooth_right[i], 1));
  }
  // 4. Second smoothing (scale 4096 for the joint, 64 for the marginals).
  const std::vector<int32_t> joint = parzen2(parzen2(info, true, true), false, true);
  const std::vector<int32_t> entropy_left = parzen1(info_left, true), entropy_right = parzen1(info_right, true);
  // 5. Costs: mi in 1/256 bit x 4096 = l*64 + r*64 - j; cost = clamp(32 - round(4 mi), 0, 63).
  cv::Mat table(kBins, kBins, CV_8UC1);
  for (int i = 0; i < kBins; ++i)
    for (int k = 0; k < kBins; ++k) {
      const int64_t mi = 64 * int64_t(entropy_left[i]) + 64 * int64_t(entropy_right[k]) - joint[i * kBins + k];
      const int64_t quarter_bits = (mi + (int64_t(1) << 17)) >> 18;  // round(4 mi / (256 * 4096))
      table.at<uint8_t>(i, k) = static_cast<uint8_t>(clampi(static_cast<int>(32 - quarter_bits), 0, kCostMax));
    }
  return table;
}

uint32_t miStartHash(int x, int y) {
  uint32_t h = static_cast<uint32_t>(x) * 0x9E3779B1u ^ static_cast<uint32_t>(y) * 0x85EBCA77u;
  h ^= h >> 15;
  h *= 0x2C1B3C6Du;
  h ^= h >> 12;
  return h;
}

cv::Mat miStartDisparity(cv::Size size, int min_disparity, int num_disparities) {
  cv::Mat d(size, CV_16S);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x)
      d.at<int16_t>(y, x) = static_cast<int16_t>(
          (min_disparity + static_cast<int>(miStartHash(x, y) % static_cast<uint32_t>(num_disparities))) *
          kSubpixelScale);
  return d;
}

cv::Mat halfSize(const cv::Mat& image) {
  if (image.empty() || image.type() != CV_8UC1) throw std::invalid_argument("halfSize: need a CV_8UC1 image");
  const int W = image.cols, H = image.rows;
  cv::Mat out((H + 1) / 2, (W + 1) / 2, CV_8UC1);
  for (int y = 0; y < out.rows; ++y)
    for (int x = 0; x < out.cols; ++x) {
      int sum = 0;
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx)
          sum += image.at<uint8_t>(std::min(2 * y + dy, H - 1), std::min(2 * x + dx, W - 1));
      out.at<uint8_t>(y, x) = static_cast<uint8_t>((sum + 2) / 4);
    }
  return out;
}

cv::Mat doubleDisparity(const cv::Mat& d16, cv::Size to) {
  cv::Mat out(to, CV_16S);
  for (int y = 0; y < to.height; ++y)
    for (int x = 0; x < to.width; ++x) {
      const int v = d16.at<int16_t>(std::min(y / 2, d16.rows - 1), std::min(x / 2, d16.cols - 1));
      out.at<int16_t>(y, x) = v == kInvalidDisparity ? kInvalidDisparity : static_cast<int16_t>(2 * v);
    }
  return out;
}

void levelRange(int min_disparity, int num_disparities, int level, int& level_min, int& level_num) {
  const int scale = 1 << level;
  const int lo = min_disparity >= 0 ? min_disparity / scale : -((-min_disparity + scale - 1) / scale);  // floor
  const int max = min_disparity + num_disparities - 1;
  const int hi = max >= 0 ? (max + scale - 1) / scale : -((-max) / scale);  // ceil
  level_min = lo;
  level_num = hi - lo + 1;
}

}  // namespace e3d
}  // namespace ips
