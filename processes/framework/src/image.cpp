#include "ips/framework/image.hpp"

#include <cmath>
#include <cstring>
#include <stdexcept>

namespace ips::fw {

namespace {
cv::Mat view(const ips::stereo_pair_t& m, const std::vector<uint8_t>& data) {
  const int type = m.pixel_format == ips::stereo_pair_t::PIXEL_MONO16 ? CV_16UC1 : CV_8UC1;
  return cv::Mat(m.height, m.width, type, const_cast<uint8_t*>(data.data()), static_cast<size_t>(m.stride));
}
void copyInto(const cv::Mat& img, std::vector<uint8_t>& out) {
  const size_t row = img.cols * img.elemSize();
  out.resize(row * img.rows);
  for (int r = 0; r < img.rows; ++r) std::memcpy(out.data() + r * row, img.ptr(r), row);
}
}  // namespace

cv::Mat mono8Copy(const cv::Mat& image) {
  cv::Mat out;
  if (image.type() == CV_16UC1)
    image.convertTo(out, CV_8U, 1.0 / 256.0);
  else
    out = image.clone();
  return out;
}

cv::Mat leftImage(const ips::stereo_pair_t& m) { return view(m, m.left); }
cv::Mat rightImage(const ips::stereo_pair_t& m) { return view(m, m.right); }

ips::stereo_pair_t makeStereoPair(int64_t utime, int64_t seq, const cv::Mat& left, const cv::Mat& right,
                                  const std::string& serial_left, const std::string& serial_right) {
  if (left.size() != right.size() || left.type() != right.type() || (left.type() != CV_8UC1 && left.type() != CV_16UC1))
    throw std::invalid_argument("makeStereoPair: two mono8 or mono16 images of one size required");
  ips::stereo_pair_t m;
  m.utime = utime;
  m.seq = seq;
  m.width = left.cols;
  m.height = left.rows;
  m.pixel_format = left.type() == CV_8UC1 ? ips::stereo_pair_t::PIXEL_MONO8 : ips::stereo_pair_t::PIXEL_MONO16;
  m.stride = static_cast<int32_t>(left.cols * left.elemSize());
  m.exposure_us[0] = m.exposure_us[1] = 0;
  m.gain_db[0] = m.gain_db[1] = 0;
  m.serial_left = serial_left;
  m.serial_right = serial_right;
  copyInto(left, m.left);
  copyInto(right, m.right);
  m.data_size = static_cast<int32_t>(m.left.size());
  return m;
}

cv::Mat disparityImage(const ips::disparity_map_t& m) {
  cv::Mat d(m.height, m.width, CV_32FC1);
  for (int r = 0; r < m.height; ++r)
    for (int c = 0; c < m.width; ++c) {
      const int16_t v = m.data[r][c];
      d.at<float>(r, c) = v == m.invalid_value ? NAN : static_cast<float>(v) / m.subpixel_scale;
    }
  return d;
}

}  // namespace ips::fw
