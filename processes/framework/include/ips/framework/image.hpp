#pragma once
// Between ips::stereo_pair_t and OpenCV images.
#include <ips/disparity_map_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <ips/stereo_time_t.hpp>
#include <opencv2/core.hpp>
#include <string>

namespace ips::fw {

// Views of the two images (no copy: they live as long as the message). The message must have passed validate().
cv::Mat leftImage(const ips::stereo_pair_t& m);
cv::Mat rightImage(const ips::stereo_pair_t& m);

// An 8-bit copy (mono16 is scaled down by 256), which outlives the message.
cv::Mat mono8Copy(const cv::Mat& image);

// A message holding copies of two mono8 or mono16 images of one size.
// The pair's stamp as STEREO_TIME carries it on the control bus (published, and logged, before each STEREO).
inline ips::stereo_time_t stereoTimeOf(const ips::stereo_pair_t& m) { return ips::stereo_time_t{m.utime, m.seq}; }

ips::stereo_pair_t makeStereoPair(int64_t utime, int64_t seq, const cv::Mat& left, const cv::Mat& right,
                                  const std::string& serial_left = "", const std::string& serial_right = "");

// The disparity [px] of a map as CV_32FC1, NaN where it holds the invalid value. The message must have passed
// validate().
cv::Mat disparityImage(const ips::disparity_map_t& m);

}  // namespace ips::fw
