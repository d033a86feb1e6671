#pragma once
// Disparity maps against a true disparity: bad-N (pixels without a disparity count as bad) and density, the
// figures of the Middlebury and KITTI stereo benchmarks, in one place for every tool and test that scores a map.
// Maps are CV_32F in pixels with NaN (or any non-finite value) where there is no disparity; the fixed-point maps of
// E3D and of DISPARITY messages are turned into that form by disparityPixels.
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

namespace ips::eval {

struct DisparityErrors {
  int64_t pixels = 0;              // in the region
  int64_t estimated = 0;           // of those, with an estimated disparity
  int64_t evaluated = 0;           // of those, with a true disparity
  int64_t valid = 0;               // evaluated pixels with an estimate
  double abs_error_sum = 0;        // over the valid pixels, in the error's unit (see disparityErrors)
  std::vector<double> thresholds;  // as given
  std::vector<int64_t> bad;        // per threshold: evaluated pixels without an estimate or off by more
  std::vector<int64_t> bad_valid;  // per threshold: valid pixels off by more

  // bad-N [%] of the evaluated pixels, invalid counted as bad.
  double badPct(size_t i) const { return evaluated ? 100.0 * bad[i] / evaluated : 0.0; }
  // bad-N [%] among the valid pixels only: whether the published disparities are right.
  double badValidPct(size_t i) const { return valid ? 100.0 * bad_valid[i] / valid : 0.0; }
  // Share [%] of the region's pixels with an estimate.
  double densityPct() const { return pixels ? 100.0 * estimated / pixels : 0.0; }
  double meanAbsError() const { return valid ? abs_error_sum / valid : 0.0; }
};

// `estimate` and `truth`: CV_32F of one size, non-finite where none. `region` (CV_8U, optional): only its non-zero
// pixels count. The error of a pixel is |estimate - truth| * error_scale, compared with each threshold: with maps at
// a reduced resolution s, error_scale 1/s gives the error in full-resolution pixels.
DisparityErrors disparityErrors(const cv::Mat& estimate, const cv::Mat& truth, const std::vector<double>& thresholds,
                                const cv::Mat& region = cv::Mat(), double error_scale = 1.0);

// A fixed-point map (CV_16S, value = disparity * subpixel_scale) as CV_32F pixels, NaN for invalid_value.
cv::Mat disparityPixels(const cv::Mat& fixed_point, int invalid_value, double subpixel_scale);

// A full-resolution true disparity (CV_32F, non-finite where none) at a map's smaller size: each map pixel takes
// the full-resolution pixel nearest to its centre ((c + 0.5) / s - 0.5, as E3D's rectification at output_scale s
// places it), its disparity multiplied by s so that it is in the map's pixels.
cv::Mat truthAtSize(const cv::Mat& truth, cv::Size size);

// A disparity map (CV_32F, non-finite = none, drawn black) colour-mapped over [0, max_disparity], for looking at.
cv::Mat colourDisparity(const cv::Mat& disparity, double max_disparity);

}  // namespace ips::eval
