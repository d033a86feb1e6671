#include "ips/pfm.hpp"

#include <cstring>
#include <fstream>
#include <stdexcept>

namespace ips {

void writePfm(const std::string& path, const cv::Mat& image) {
  if (image.type() != CV_32FC1) throw std::invalid_argument("writePfm: " + path + ": image must be CV_32FC1");
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error("writePfm: cannot open " + path);
  out << "Pf\n" << image.cols << " " << image.rows << "\n-1\n";  // negative scale: little endian
  for (int r = image.rows - 1; r >= 0; --r)
    out.write(reinterpret_cast<const char*>(image.ptr<float>(r)),
              static_cast<std::streamsize>(image.cols * sizeof(float)));
  if (!out) throw std::runtime_error("writePfm: write failed: " + path);
}

cv::Mat readPfm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("readPfm: cannot open " + path);
  std::string magic;
  int w = 0, h = 0;
  double scale = 0;
  in >> magic >> w >> h >> scale;
  in.get();  // the single whitespace after the header
  if (magic != "Pf" || w <= 0 || h <= 0 || scale == 0)
    throw std::runtime_error("readPfm: not a greyscale PFM: " + path);
  cv::Mat image(h, w, CV_32FC1);
  const bool big_endian = scale > 0;
  for (int r = h - 1; r >= 0; --r) {
    in.read(reinterpret_cast<char*>(image.ptr<float>(r)), static_cast<std::streamsize>(w * sizeof(float)));
    if (!in) throw std::runtime_error("readPfm: truncated: " + path);
    if (big_endian) {
      for (int c = 0; c < w; ++c) {
        uint32_t v;
        std::memcpy(&v, image.ptr<float>(r) + c, 4);
        v = __builtin_bswap32(v);
        std::memcpy(image.ptr<float>(r) + c, &v, 4);
      }
    }
  }
  return image;
}

}  // namespace ips
