#pragma once
// E3D's matching costs (SgmParams::cost), in the integer arithmetic the device shares:
//  census  popcount(census_left(x) ^ census_right(x - d)), 5x5 census codes: 0..24
//  ad      absolute grey difference, truncated: min(|L(x) - R(x - d)|, 63)
//  sad     mean absolute difference over the 3x3 windows around x and x - d (each column and row clamped into
//          the image), rounded and truncated: min((sum + 4) / 9, 63)
//  mi      Mutual Information (Hirschmueller 2008): a 256 x 256 table T of costs 0..63 indexed by the two grey
//          values, learnt from a disparity map (below); with mi_window 1 the pixelwise T[L(x)][R(x - d)], with
//          mi_window 3 (the default) its mean over the 3x3 windows as for sad: min((sum T + 4) / 9, 63)
// x - d is clamped into the row (for sad: x - d + dx), as everywhere in E3D.
//
// Mutual Information table, from a left image, a right image and a disparity map of the left one:
//  1. joint histogram H(i, k) of (L(p), R(p - d(p))) over the pixels with a valid disparity whose match is inside;
//  2. Parzen smoothing with the binomial kernel b = (1 6 15 20 15 6 1) / 64 (zero outside 0..255): Hs = H * b * b,
//     marginals HL = sum_k H, HR = sum_i H, smoothed once;
//  3. information in 1/256 bit: J = log2q8(4096 n) - log2q8(max(Hs, 1)), and likewise for the marginals (scale 64);
//  4. second smoothing of the information (edge values repeated): j = J * b * b, l = IL * b, r = IR * b;
//  5. mi(i, k) = l(i) + r(k) - j(i, k) (bits); cost = clamp(32 - round(4 mi), 0, 63): 1/4 bit per cost unit.
// log2q8(v) = 256 * floor(log2 v) + kLog2Fraction[the 8 bits after the leading one], the fraction table rounded
// from log2; all other steps are integer, so the device computes the same table bit for bit.
//
// Regions (SgmParams::mi_region_columns, mi_region_rows): a grid over the image, each region with its own table
// learnt from the matched pixels of the region (the left pixel's position); the cost of pixel (x, y) reads the table
// of (x, y)'s region for every pair of its window.
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace ips {
namespace e3d {

struct SgmParams;
enum class Cost;

// Largest cost of a cost function (24 for census, 63 for the others).
int maxCost(Cost cost);
// Whether the cost is the mean of a pair cost over the 3x3 windows (sad, mi with mi_window 3): the reference and
// the device's cost stage (cost_window3x3.glsl) both follow this.
bool isWindowCost(const SgmParams& params);

// Census 5x5 transform (CV_32S holding the 24-bit codes).
cv::Mat census5x5(const cv::Mat& image);

// The region of a coordinate in [0, extent) split into `regions` parts, region i starting at floor(i * extent /
// regions) (E3D_REGION_OF, the same on the device).
int miRegionOf(int coordinate, int regions, int extent);

// Mutual Information tables (CV_8UC1 256x256, [left grey][right grey]), one per region of a columns x rows grid,
// row-major (region (i, j) at j * columns + i). `mirrored`: the tables of the mirrored pair (the mirrored right
// image as the left one; transposed tables), whose column x is column width - 1 - x of the images the regions
// were laid on.
struct MiTables {
  int columns = 1, rows = 1;
  std::vector<cv::Mat> tables;
  bool mirrored = false;
  // The table of pixel (x, y) of an image of `size`.
  const cv::Mat& at(int x, int y, cv::Size size) const;
  // The tables of the swapped pair (each transposed, mirrored flipped).
  MiTables swapped() const;
};

// Matching costs [y][x][k] (k = 0..num_disparities-1, d = min_disparity + k) of a rectified CV_8UC1 pair.
// mi_tables (or the single mi_table) are used when params.cost is "mi".
std::vector<uint8_t> costVolume(const cv::Mat& left, const cv::Mat& right, const SgmParams& params,
                                const MiTables& mi_tables);
std::vector<uint8_t> costVolume(const cv::Mat& left, const cv::Mat& right, const SgmParams& params,
                                const cv::Mat& mi_table = cv::Mat());

// log2q8 (see above) of v >= 1; the fraction table is exposed for the device.
int log2q8(uint64_t v);
const std::vector<int32_t>& log2FractionTable();  // 256 entries: round(256 log2(1 + j / 256))

// The joint histogram the Mutual Information table learns from (the CPU reference of the histogram stage): bin
// left grey * 256 + right grey of every pixel of the left image whose disparity (CV_16S, disparity x 16, rounded
// half up to whole pixels) is valid and matches a pixel inside the right image's row; `count` is their number.
struct JointHistogram {
  std::vector<uint64_t> bins;  // 65536
  uint64_t count = 0;
};
JointHistogram miJointHistogram(const cv::Mat& left, const cv::Mat& right, const cv::Mat& disparity16);
// The histograms of the regions of a columns x rows grid (row-major), each of its region's left pixels.
std::vector<JointHistogram> miJointHistograms(const cv::Mat& left, const cv::Mat& right, const cv::Mat& disparity16,
                                              int columns, int rows);

// The Mutual Information cost table (CV_8UC1 256x256) of a pair and a disparity map of the left image (CV_16S,
// disparity x 16, kInvalidDisparity where none): from miJointHistogram. An empty histogram gives the table of a
// uniform one.
cv::Mat miTable(const cv::Mat& left, const cv::Mat& right, const cv::Mat& disparity16);
cv::Mat miTable(const JointHistogram& histogram);
// One table per region of a columns x rows grid, each from its region's histogram (miJointHistograms).
MiTables miTables(const cv::Mat& left, const cv::Mat& right, const cv::Mat& disparity16, int columns, int rows);

// The start of the hierarchy: a pseudo-random disparity in [min_disparity, min_disparity + num_disparities)
// (x 16) for every pixel, the same on the device.
cv::Mat miStartDisparity(cv::Size size, int min_disparity, int num_disparities);
uint32_t miStartHash(int x, int y);

// The pyramid step: the mean of each 2x2 block, rounded (sizes (w + 1) / 2, (h + 1) / 2; the last column and row
// repeated for odd sizes).
cv::Mat halfSize(const cv::Mat& image);

// A disparity map at twice the resolution (size `to`): values doubled, each pixel from (x / 2, y / 2).
cv::Mat doubleDisparity(const cv::Mat& disparity16, cv::Size to);

// The search range at pyramid level `level` (0 = full resolution): [floor(min / 2^l), ceil(max / 2^l)].
void levelRange(int min_disparity, int num_disparities, int level, int& level_min, int& level_num);

}  // namespace e3d
}  // namespace ips
