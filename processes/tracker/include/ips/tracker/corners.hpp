#pragma once
// Harris corners (Harris and Stephens 1988), spread over the image on a grid, with subpixel positions.
#include <opencv2/core.hpp>
#include <vector>

#include "ips/tracker/params.hpp"

namespace ips::tracker {

struct Corner {
  float x = 0, y = 0;  // subpixel position (quadratic fit of the response around the maximum) [px]
  int xi = 0, yi = 0;  // the pixel of the response maximum
  float response = 0;
};

// Corner strength of every pixel of an 8-bit grey image (CV_32F), Harris or minimum eigenvalue.
cv::Mat cornerResponse(const cv::Mat& gray8, const DetectorParams& params);

// Local 3x3 maxima of the response, at least `margin` pixels from every edge, above quality_level times
// the strongest, at most max_per_cell per grid cell (the strongest), sorted by cell. Images wider than
// max_detection_width are searched on a pyramid level (positions given at full resolution). Throws
// std::invalid_argument on an empty or non-8-bit image.
std::vector<Corner> detectCorners(const cv::Mat& gray8, const DetectorParams& params, int margin);

}  // namespace ips::tracker
