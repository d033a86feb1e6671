#pragma once
// Semi-Global Matching (Hirschmueller 2008) as E3D runs it, and its plain C++ reference.
//
// Algorithm (identical integer arithmetic on the device and in sgmReference):
//  1.-2. Matching cost C(x,y,d), d = min_disparity + k, k = 0..num_disparities-1, x-d clamped into the image:
//     census 5x5 (the default), AD, SAD or Mutual Information, see ips/e3d/matching_cost.hpp. Census: 24 bits,
//     bit set when the neighbour is darker than the centre (neighbours clamped), C = popcount of the xor (0..24).
//     Mutual Information is learnt hierarchically (mi_levels): at 1/2^(levels-1) of the resolution from a
//     pseudo-random disparity (mi_coarse_iterations times), then at each finer level from the left-right checked
//     map of the level below, doubled; each level is a full match with the level's range.
//  3. Path costs along 8 (or 4) directions r:
//       L_r(p,k) = C(p,k) + min(L_r(p-r,k), L_r(p-r,k+-1) + P1, min_i L_r(p-r,i) + P2') - min_i L_r(p-r,i)
//     with P2' = max(P1, P2 - (p2_slope * |I(p) - I(p-r)|) / 16) (p2_slope = 0: constant P2).
//     Every L_r <= maxCost + P2 <= 255, so the device keeps one byte per path, pixel and disparity.
//  4. S = sum of the paths; winner-takes-all k* = argmin S (smallest k on ties).
//     Uniqueness: invalid when min_{|k-k*|>1} S * (100 - uniqueness) < S(k*) * 100.
//     Subpixel (equiangular, as rSGM): offset = (c0 - c2) / (2 (max(c0, c2) - c1)), rounded to 1/16 px
//     in integer arithmetic, so the device and the reference agree exactly.
//  5. Right disparity (right_map "diagonal") by the diagonal search in S: d_R(xr) = argmin_k S(xr + min_disparity
//     + k, y, k); or (right_map "match") by a second match right to left: steps 1-4 on the mirrored pair (the
//     mirrored right image as the left one, which keeps the disparities), its left map mirrored back.
//  6. 3x3 median of both maps (optional; invalid pixels take part as kInvalidDisparity), then the
//     left-right check: invalid when |d_L(x) - d_R(x - round(d_L(x)))| > lr_max_diff.
//  Narrowed search (search "narrowed", tSGM: Rothermel et al. 2012): steps 1-6 first on the half-size pair
//     (halfSize) over the range at half resolution (levelRange level 1), without fill; then each full-resolution
//     pixel searches only its band [lo, hi] of the range (narrowedBands): the 3x3 coarse neighbourhood's valid
//     disparities, doubled, +- band_margin, widened to band_width; where they span more, the band spans them
//     (a depth edge: both sides searched); where none is valid (occlusion, no texture), the full range. In step 3
//     the previous pixel's entries outside its band are +infinity and its minimum is over its band; in step 4 a
//     winner on a band edge that is not the range's edge is invalid (the minimum may lie outside), subpixel needs
//     both neighbours in the band; step 5 searches the in-band entries. With every band the full range the result
//     is the full search's, bit for bit.
//  7. Optional (fill_invalid): each invalid pixel takes the smaller of the nearest valid disparities left and
//     right on its row (background fill of occlusions, Hirschmueller 2008); for evaluations that count
//     invalid pixels as errors. Off by default: a navigation consumer wants to know what was not measured.
#include <opencv2/core.hpp>
#include <string>

#include "ips/e3d/matching_cost.hpp"

namespace ips {
class Config;
namespace e3d {

// Disparity maps are CV_16S holding disparity * kSubpixelScale; pixels without a disparity hold
// kInvalidDisparity (maps onto disparity_map_t: subpixel_scale = 16, invalid_value = -32768).
constexpr int kSubpixelScale = 16;
constexpr int16_t kInvalidDisparity = -32768;
constexpr int kMaxDisparities = 256;
constexpr int kCensusMaxCost = 24;
constexpr int kDefaultMiWindow = 3;  // SgmParams::mi_window

// Options, parsed once from their config text (the names in parentheses; parse* throw std::invalid_argument
// naming the accepted values).
enum class Cost { census, ad, sad, mi };            // (census, ad, sad, mi) ips/e3d/matching_cost.hpp
enum class RightMap { diagonal, match };            // (diagonal, match) see 5. above
enum class Aggregation { automatic, rows, lines };  // (auto, rows, lines) see SgmParams::aggregation
enum class Search { full, narrowed };               // (full, narrowed) see "Narrowed search" above
Cost parseCost(const std::string& text);
RightMap parseRightMap(const std::string& text);
Aggregation parseAggregation(const std::string& text);
Search parseSearch(const std::string& text);
const char* toString(Cost cost);
const char* toString(RightMap right_map);
const char* toString(Aggregation aggregation);
const char* toString(Search search);

struct SgmParams {
  int num_disparities = 128;     // search range size, 1..256
  int min_disparity = 0;         // smallest disparity searched [px]
  Cost cost = Cost::census;      // ips/e3d/matching_cost.hpp
  int mi_levels = 5;             // mi: pyramid levels (1 = full resolution only, from the start disparity)
  int mi_coarse_iterations = 2;  // mi: matches at the coarsest level, each learning from the one before
  // mi: the cost is the mean of the table's costs over this square window: 1 = pixelwise (Hirschmueller 2008),
  // 3 = 3x3. One pixel's grey pair carries little information where the texture is fine and faint (a road): the
  // mean over nine pairs separates the true disparity from its neighbours, as census does with its 5x5 window
  // (measured with each window on the six scenes: processes/e3d/README.md, "The other costs").
  int mi_window = kDefaultMiWindow;
  // mi: one table per region of a mi_region_columns x mi_region_rows grid over the image: each region's table learns
  // from the matched pixels of that region, and a pixel's cost reads its region's table. Why: vignetting and the
  // lens's fall-off change the grey relation between the cameras across the field of view (KITTI's road towards
  // the lower corners), which one table cannot follow. The grid is fixed in the image, not in pixels, because that
  // radiometry is a function of the position in the field of view. A level of the hierarchy takes the regions only
  // when each holds at least mi_region_min_pixels pixels, else one table: a histogram of 65536 bins learns little
  // from a few hundred pixels (4096, 1/16 of the bins: the full resolution of every scene, the half resolution of
  // the larger ones). processes/e3d/README.md: the grids and rules measured.
  int mi_region_columns = 6;
  int mi_region_rows = 3;
  int mi_region_min_pixels = 4096;
  // Defaults: the values of rSGM (Spangenberg et al. 2014; its public code kbatsos/Real-Time-Stereo, CPU/sgm) for
  // the same 5x5 census cost, set by its authors and not fitted here (processes/e3d/README.md shows them on the
  // six scenes of ../shared/data/stereo, beside a grid around them). P1 is under a third of the cost range, so a
  // slanted surface (a road steps one disparity every few rows) is cheaper than a wrong constant disparity along every
  // path.
  int p1 = 7;        // penalty for a disparity change of 1 px (census cost units, 0..24)
  int p2 = 50;       // penalty for larger changes; p2 + 24 <= 255 (path costs fit one byte)
  int p2_slope = 4;  // adaptive P2: P2' = max(P1, P2 - p2_slope * |dI| / 16); rSGM's 50 - 0.25 |dI|; 0 = constant
  int paths = 8;     // 8 or 4 (horizontal + vertical)
  // Uniqueness test [percent], 0 = off (as OpenCV's uniquenessRatio). Off: the left-right check already tests each
  // match; on top of it rSGM's 5 % removes 0.2 % of the pixels, about half of them right ones (README).
  int uniqueness = 0;
  bool subpixel = true;  // equiangular interpolation (else integer disparities * 16)
  bool median = true;    // 3x3 median on both maps before the left-right check
  // Left-right check tolerance [px]; < 0 = no check. 2 px is rSGM's "1 px" check: it truncates the difference to
  // an integer before comparing (int(d_L - d_R) > 1), so it rejects differences of 2 px and more; this check
  // compares at 1/16 px.
  int lr_max_diff = 2;
  // How the right image's map for the check is found (see 5. above): diagonal (a search in the aggregated costs
  // of the left match, cheap) or match (a second match right to left, about twice the time).
  RightMap right_map = RightMap::diagonal;
  bool fill_invalid = false;  // fill invalid pixels from their row neighbours (see 7. above)
  // Search range per pixel: full (every disparity of the range everywhere; the reference) or narrowed (a band
  // around the half-resolution match, see "Narrowed search" above; census, ad and sad with right_map diagonal).
  Search search = Search::full;
  // narrowed: the band's least width [px]. A coarse match is right to about one coarse pixel (2 px here); what the
  // band must hold beyond that are structures the half resolution loses (a cone's tip, a spoke), whose disparity
  // none of the coarse neighbours has. Measured on the six scenes (processes/e3d/README.md): 16, 24, 32, 48 px
  // give a mean bad 2.0 of 5.17, 5.16, 5.12, 5.09 % against the full search's 5.12 %.
  int band_width = 32;
  int band_margin = 2;  // narrowed: [px] on both sides of the coarse neighbourhood's doubled span (one coarse pixel)
  // How the device walks the paths (the results are the same): rows = two row passes, one per thread (for CPU
  // devices: lavapipe), lines = one dispatch per path, one subgroup per image line (for GPUs), automatic ("auto")
  // = rows on a CPU device, lines otherwise. Not an algorithm parameter: sgmReference ignores it.
  Aggregation aggregation = Aggregation::automatic;
  // Pixels one subgroup of the row passes works on at once, each on subgroup size / row_pixels lanes (a power of two
  // up to the subgroup size), or 0: chosen from the range (the least padding with at most 32 disparities per lane,
  // then the most pixels with at most 16). Not an algorithm parameter either: the maps are the same; on lavapipe most
  // of a pixel's cost does not grow with its disparities, and the pixels of a subgroup share it
  // (processes/e3d/README.md, "Speed").
  int row_pixels = 0;

  // The defaults with the penalties chosen for a cost function (census: the defaults above) and, for mi, for its
  // window (mi_window: the mean of nine table costs varies less than one, so its penalties are smaller).
  static SgmParams forCost(Cost cost, int mi_window = kDefaultMiWindow);
  // These parameters with another cost function and its penalties (P1, P2, p2_slope of forCost for this
  // mi_window).
  SgmParams withCost(Cost cost) const;
  // Throws std::invalid_argument naming the bad parameter.
  void validate() const;
  // Reads the keys above (same names) from a Config section; absent keys keep their defaults.
  static SgmParams fromConfig(const Config& section);
  std::string describe() const;
};

struct SgmResult {
  cv::Mat left;   // CV_16S disparity of the left image (after median and LR check)
  cv::Mat right;  // CV_16S disparity of the right image (diagonal search, after median)
};

// The parameters of level `level` (0 = full resolution) of the Mutual Information hierarchy: the level's search
// range, and one region (the whole image) unless the level's (of `level_size`) smallest region holds
// mi_region_min_pixels pixels. The reference and the device both.
SgmParams miLevelParams(const SgmParams& params, int level, cv::Size level_size);

// Search bands: for each pixel (row-major) the searched indices k = lo..hi (inclusive) of the range 0..D-1.
struct DisparityBands {
  cv::Size size;
  int num_disparities = 0;
  std::vector<uint8_t> lo, hi;
  // Every pixel the full range (the full search).
  static DisparityBands full(cv::Size size, int num_disparities);
  int width(size_t pixel) const { return hi[pixel] - lo[pixel] + 1; }
  // The share of the full volume searched: sum of the widths / (pixels x D).
  double searchedShare() const;
};

// The parameters of the coarse match of the narrowed search: the half resolution's range, full search, no fill.
SgmParams coarseLevelParams(const SgmParams& params);
// The bands of the narrowed search at full resolution (`size`) from the coarse match's left map (CV_16S, of
// halfSize(size)), see "Narrowed search" above.
DisparityBands narrowedBands(const cv::Mat& coarse16, cv::Size size, const SgmParams& params);

// Plain C++ reference of the algorithm above (single-threaded, slow; for tests and for checking).
// left, right: CV_8UC1, same size. Throws std::invalid_argument on bad input.
SgmResult sgmReference(const cv::Mat& left, const cv::Mat& right, const SgmParams& params);

// The directions (dx, dy) of the SGM paths in the order they are taken: 4 paths are the first four (along the rows
// and the columns), 8 all of them. Device and reference walk them in this order; the device keeps path r in slice r.
inline constexpr int kPathDirections[8][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}, {1, 1}, {-1, -1}, {1, -1}, {-1, 1}};

// The single steps of sgmReference, each the CPU reference of one device stage (its tests compare them alone).
// Step 3 for one path: the path costs L_r [y][x][k] along kPathDirections[path] of the matching costs `cost`
// ([y][x][k], as costVolume) of the image `left` (CV_8UC1, for the adaptive P2).
// With `bands`, only each pixel's band is searched (entries outside it are kOutOfBand); without, the full range.
constexpr uint16_t kOutOfBand = 0xffff;
std::vector<uint16_t> pathCosts(const cv::Mat& left, const std::vector<uint8_t>& cost, const SgmParams& params,
                                int path, const DisparityBands* bands = nullptr);
// Step 3: the sums over the paths of the path costs [y][x][k] of the matching costs `cost` ([y][x][k], as
// costVolume) of the image `left` (CV_8UC1, for the adaptive P2).
std::vector<uint16_t> aggregateCosts(const cv::Mat& left, const std::vector<uint8_t>& cost, const SgmParams& params,
                                     const DisparityBands* bands = nullptr);
// Steps 4-5: the left map (winner-takes-all, uniqueness, subpixel) and the right map (diagonal search) of the sums
// [y][x][k] of an image of `size`; both CV_16S, before the median.
void winnerTakesAll(const std::vector<uint16_t>& sums, cv::Size size, const SgmParams& params, cv::Mat& left16,
                    cv::Mat& right16, const DisparityBands* bands = nullptr);
// Step 6: the 3x3 median of a CV_16S map (border replicated; invalid pixels take part with their value).
cv::Mat median3x3(const cv::Mat& disparity16);
// Step 6: the left-right check of the CV_16S left map against the right one, in place (max_diff in px).
void leftRightCheck(cv::Mat& left16, const cv::Mat& right16, int max_diff);

// Step 7 on any CV_16S map (invalid = kInvalidDisparity), in place: each invalid pixel takes the smaller
// (background) of the nearest valid disparities left and right on its row. The CPU reference of the device's fill,
// so that an evaluation can apply the same fill to every method's raw map.
void fillInvalid(cv::Mat& disparity16);

// Converts a CV_16S disparity map to CV_32F pixels (invalid = +inf), the PFM convention.
cv::Mat disparityToFloat(const cv::Mat& disparity16);

}  // namespace e3d
}  // namespace ips
