#pragma once
// Normalized cross-correlation matching in the rectified pair:
//  - intra-matching: a left corner against every column of the same row of the right image within the
//    disparity range;
//  - inter-matching: a stereo feature of the older pair against the stereo features of the newer pair that
//    lie in a search window around the position predicted by the motion prior, in both cameras, refined to
//    subpixel by the correlation around the best candidate.
// Templates are centred on integer pixels (no interpolation); the correlation peak gives the subpixel part.
#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "ips/calibration.hpp"
#include "ips/tracker/corners.hpp"
#include "ips/tracker/motion.hpp"
#include "ips/tracker/params.hpp"

namespace ips::tracker {

// A template normalised to zero mean and unit norm, so that NCC of two templates is their dot product.
// Returns false when the window leaves the image or its grey-level std is below min_std.
bool normalizedPatch(const cv::Mat& gray8, int x, int y, int half, double min_std, float* out);
float patchDot(const float* a, const float* b, int n);

// Left-right correspondences of one pair.
struct StereoFeatures {
  int half = 0;                                // template half size
  std::vector<int> xl, y;                      // left pixel (integer: the template centre)
  std::vector<float> xr;                       // subpixel right column on row y
  std::vector<int> xr_int;                     // right template centre
  std::vector<float> ncc;                      // intra correlation
  std::vector<float> left_patch, right_patch;  // normalised templates, (2h+1)^2 floats each
  size_t size() const { return xl.size(); }
  int patchSize() const { return (2 * half + 1) * (2 * half + 1); }
  const float* leftPatch(size_t i) const { return left_patch.data() + i * patchSize(); }
  const float* rightPatch(size_t i) const { return right_patch.data() + i * patchSize(); }
  // Appends one correspondence with its two normalised templates (patchSize() floats each).
  void push(int x_left, int row, float x_right, int x_right_int, float correlation, const float* left,
            const float* right) {
    xl.push_back(x_left);
    y.push_back(row);
    xr.push_back(x_right);
    xr_int.push_back(x_right_int);
    ncc.push_back(correlation);
    left_patch.insert(left_patch.end(), left, left + patchSize());
    right_patch.insert(right_patch.end(), right, right + patchSize());
  }
};

// Intra-matching of the corners of the rectified left image along their rows of the rectified right image.
StereoFeatures matchAlongRows(const cv::Mat& left8, const cv::Mat& right8, const std::vector<Corner>& corners,
                              const MatcherParams& params);

// A dense disparity map of the same rectified pair (E3D's DISPARITY message), possibly at a reduced resolution:
// map pixel (u, v) samples where the tracker's rectified pixel ((u + 0.5) / scale - 0.5, (v + 0.5) / scale - 0.5)
// does (ips::scaledRectification), and its disparity in map pixels is data / subpixel_scale.
struct DisparityGuide {
  cv::Mat disparity;  // CV_16SC1
  int subpixel_scale = 16;
  int invalid_value = -1;
  double scale = 1.0;  // map width / tracker's rectified width
};

// The guide's scale when a map with this rectified pinhole and size belongs to the tracker's rectification:
// same baseline, f and principal point scaled alike to within 1e-3 px, the size scaled alike. Anything else
// (another calibration, another alpha) gives nothing.
std::optional<double> guideScale(const StereoRectification& rect, double focal_px, double cx, double cy,
                                 double baseline_m, cv::Size map_size);

// What the guided intra-matching did with the corners.
struct GuidedIntraCounts {
  int from_map = 0;      // matched at the map's disparity
  int map_invalid = 0;   // no disparity there: left to the row search
  int check_failed = 0;  // the correlation disagreed with the map (peak on the range's edge or below min NCC)
};

// Intra-matching guided by a disparity map: each corner's right column is the map's disparity checked by NCC
// along the row within guide_search_map_px / scale (+1 for the parabola), and refined at the correlation peak.
// Corners where the map has no disparity are appended to `unguided` (for matchAlongRows); corners whose check
// fails are dropped: the map and the image disagree there, and neither is trusted.
StereoFeatures matchWithDisparity(const cv::Mat& left8, const cv::Mat& right8, const std::vector<Corner>& corners,
                                  const DisparityGuide& guide, const MatcherParams& params,
                                  std::vector<Corner>* unguided, GuidedIntraCounts* counts);

// Appends b's features to a (same template size).
void appendFeatures(StereoFeatures& a, const StereoFeatures& b);

// Where a feature of the older pair is expected in the newer pair, and how far to search [px].
struct Prediction {
  double xl = 0, y = 0, xr = 0;
  double radius = 0;
};

struct InterMatch {
  int prev = -1, now = -1;              // indices into the older / newer StereoFeatures
  StereoObservation prev_obs, now_obs;  // same scene point in both pairs (subpixel)
  float ncc = 0;                        // the lower of the left and right correlations
  bool prediction_ok = false;           // found within prior_ok_px of the prediction
};

// One prediction per feature of `prev`. `now_left8` / `now_right8` are the newer rectified images (for the
// subpixel refinement). Each newer feature is matched at most once (the best older feature keeps it).
std::vector<InterMatch> matchBetweenTimes(const StereoFeatures& prev, const StereoFeatures& now,
                                          const std::vector<Prediction>& predictions, const cv::Mat& now_left8,
                                          const cv::Mat& now_right8, const MatcherParams& params);

}  // namespace ips::tracker
