#pragma once
// Images from files as the matchers take them: 8-bit grey.
#include <opencv2/core.hpp>
#include <string>

namespace ips {

// Any image OpenCV reads (grey, colour by COLOR_BGR2GRAY, 16 bit scaled to 8) as 8-bit grey; throws
// std::runtime_error naming the file when it cannot be read.
cv::Mat loadGrey(const std::string& path);

}  // namespace ips
