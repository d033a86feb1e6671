#pragma once
// E3D's dense stereo on the device: [rectification] -> census 5x5 -> 8/4 path aggregation -> winner-takes-all
// (+ right disparity by diagonal search) -> 3x3 median -> left-right check. See ips/e3d/sgm.hpp for the
// algorithm; sgmReference computes exactly the same maps on the CPU.
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "ips/calibration.hpp"
#include "ips/e3d/sgm.hpp"
#include "ips/e3d/vulkan_context.hpp"

namespace ips {
namespace e3d {

struct StageTiming {
  std::string name;  // rectify, census, aggregate, wta, median, lr_check
  double ms = 0;     // device time from timestamp queries
};

struct MatchOutput {
  cv::Mat disparity;  // CV_16S left disparity * kSubpixelScale, kInvalidDisparity where none
  cv::Mat right;      // CV_16S right disparity (integer * 16, after median), when requested
  std::vector<StageTiming> stages;
  double device_ms = 0;  // sum of the stages
  double total_ms = 0;   // wall time of match(), upload and download included
};

class StereoMatcher {
 public:
  // Allocates everything for images of `size`; throws std::invalid_argument on bad params or a size the
  // device cannot hold (width <= 4096, path-cost volume in at most 24 buffers of maxStorageBufferRange).
  StereoMatcher(VulkanContext& ctx, cv::Size size, const SgmParams& params);
  ~StereoMatcher();
  StereoMatcher(const StereoMatcher&) = delete;
  StereoMatcher& operator=(const StereoMatcher&) = delete;

  // Matches a rectified pair (CV_8UC1, `size`). Throws std::invalid_argument on bad input.
  MatchOutput match(const cv::Mat& left, const cv::Mat& right, bool want_right = false);

  // Enables matchRaw: raw images of raw_size are remapped on the device with the maps of `rect`
  // (rect.size must equal the matcher's size), times its flat-field gains for the grey-value costs (ad, sad, mi;
  // census, which a smooth gain does not change, takes the plain remap).
  void setRectification(const StereoRectification& rect, cv::Size raw_size);
  // Raw pair -> rectified -> disparity, all on the device. rectified0/1 receive the rectified images if given.
  MatchOutput matchRaw(const cv::Mat& raw0, const cv::Mat& raw1, cv::Mat* rectified0 = nullptr,
                       cv::Mat* rectified1 = nullptr, bool want_right = false);

  // Whether matchRaw multiplies by the rectification's flat-field gains (set by setRectification: there are gains
  // and the cost is not census).
  bool appliesFlatField() const;
  cv::Size size() const;
  const SgmParams& params() const;
  // Device memory allocated by this matcher, in bytes (the path-cost volume dominates: paths*W*H*D').
  size_t deviceMemoryBytes() const;
  // How the device walks the paths at full resolution: the aggregation layout, pixels per subgroup, disparities per
  // lane (for the benchmarks' output; the maps do not depend on it).
  std::string layoutDescription() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace e3d
}  // namespace ips
