#include "report_page.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

namespace ips::report {

namespace {

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot read");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string base64(const std::vector<uchar>& bytes) {
  static const char* const kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (size_t i = 0; i < bytes.size(); i += 3) {
    const uint32_t b0 = bytes[i], b1 = i + 1 < bytes.size() ? bytes[i + 1] : 0,
                   b2 = i + 2 < bytes.size() ? bytes[i + 2] : 0;
    const uint32_t v = (b0 << 16) | (b1 << 8) | b2;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? kAlphabet[(v >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? kAlphabet[v & 63] : '=';
  }
  return out;
}

// Replaces the one occurrence of `marker` in `page` by `text`.
void fill(std::string& page, const std::string& marker, const std::string& text, const std::string& template_path) {
  const size_t at = page.find(marker);
  if (at == std::string::npos) throw std::runtime_error(template_path + ": has no placeholder " + marker);
  page.replace(at, marker.size(), text);
}

}  // namespace

std::string jsonArray(const std::vector<double>& values, int digits) {
  std::ostringstream os;
  os << std::setprecision(digits) << '[';
  for (size_t i = 0; i < values.size(); ++i) {
    if (i) os << ',';
    if (std::isfinite(values[i]))
      os << values[i];
    else
      os << "null";
  }
  os << ']';
  return os.str();
}

std::string jsonString(const std::string& value) {
  std::string o = "\"";
  for (char c : value) {
    if (c == '"' || c == '\\') o += '\\';
    if (static_cast<unsigned char>(c) < 0x20) c = ' ';
    // Inside the page's <script> element "</script" would end it: '<' goes escaped.
    if (c == '<') {
      o += "\\u003c";
      continue;
    }
    o += c;
  }
  return o + "\"";
}

std::string pngDataUri(const cv::Mat& image) {
  std::vector<uchar> png;
  if (!cv::imencode(".png", image, png)) throw std::runtime_error("cannot encode a report picture as PNG");
  return "data:image/png;base64," + base64(png);
}

cv::Mat colourMapped(const cv::Mat& values, double vmin, double vmax, int colormap, const cv::Mat& marked,
                     const cv::Scalar& marked_bgr) {
  cv::Mat u8;
  const double span = std::max(1e-9, vmax - vmin);
  values.convertTo(u8, CV_8U, 255.0 / span, -vmin * 255.0 / span);  // saturates at 0 and 255
  cv::Mat colour;
  cv::applyColorMap(u8, colour, colormap);
  if (!marked.empty()) colour.setTo(marked_bgr, marked);
  return colour;
}

std::string colourBarDataUri(int colormap) {
  cv::Mat ramp(1, 256, CV_8U);
  for (int i = 0; i < 256; ++i) ramp.at<uchar>(0, i) = static_cast<uchar>(i);
  cv::Mat colour;
  cv::applyColorMap(ramp, colour, colormap);
  return pngDataUri(colour);
}

std::string cssColour(const cv::Scalar& bgr) {
  char s[8];
  std::snprintf(s, sizeof s, "#%02x%02x%02x", static_cast<int>(bgr[2]), static_cast<int>(bgr[1]),
                static_cast<int>(bgr[0]));
  return s;
}

std::vector<size_t> subsample(size_t n, size_t max_samples) {
  std::vector<size_t> idx;
  if (n == 0 || max_samples == 0) return idx;
  const size_t step = std::max<size_t>(1, (n + max_samples - 1) / max_samples);
  for (size_t i = 0; i < n; i += step) idx.push_back(i);
  if (idx.back() != n - 1) {
    if (idx.size() >= max_samples)
      idx.back() = n - 1;
    else
      idx.push_back(n - 1);
  }
  return idx;
}

std::string colourMapsJson(const DisparityColours& colours) {
  return "{\"disparity\": \"" + colourBarDataUri(cv::COLORMAP_TURBO) + "\", \"error\": \"" +
         colourBarDataUri(cv::COLORMAP_INFERNO) + "\", \"invalid\": \"" + cssColour(colours.invalid) +
         "\", \"not_evaluated\": \"" + cssColour(colours.not_evaluated) + "\", \"no_estimate\": \"" +
         cssColour(colours.no_estimate) + "\"}";
}

std::string disparityExampleJson(const cv::Mat& left, const cv::Mat& estimate, const cv::Mat& truth, double dmin,
                                 double dmax, double error_max, const std::string& fields,
                                 const DisparityColours& colours) {
  const cv::Mat est_invalid = estimate < 0;
  std::ostringstream e;
  e << std::setprecision(6) << "{\"width\": " << estimate.cols << ", \"height\": " << estimate.rows
    << ", \"disparity_min\": " << dmin << ", \"disparity_max\": " << dmax << ", \"error_max\": " << error_max
    << ", \"left\": \"" << pngDataUri(left) << "\", \"estimate\": \""
    << pngDataUri(colourMapped(estimate, dmin, dmax, cv::COLORMAP_TURBO, est_invalid, colours.invalid)) << "\"";
  if (!truth.empty()) {
    const cv::Mat gt_invalid = truth < 0;
    cv::Mat err;
    cv::absdiff(estimate, truth, err);
    cv::Mat err_colour = colourMapped(err, 0, error_max, cv::COLORMAP_INFERNO, gt_invalid, colours.not_evaluated);
    err_colour.setTo(colours.no_estimate, est_invalid & ~gt_invalid);
    e << ", \"truth\": \""
      << pngDataUri(colourMapped(truth, dmin, dmax, cv::COLORMAP_TURBO, gt_invalid, colours.invalid))
      << "\", \"error\": \"" << pngDataUri(err_colour) << "\"";
  }
  e << fields << "}";
  return e.str();
}

std::string pointCloudJson(const cv::Mat& disparity, const cv::Mat& grey, double focal_px, double cx, double cy,
                           double baseline_m, size_t max_points, double min_disparity_px, int64_t seq) {
  const int valid = cv::countNonZero(disparity >= min_disparity_px);
  const int stride = std::max(1, static_cast<int>(std::ceil(std::sqrt(valid / static_cast<double>(max_points)))));
  std::vector<double> xyz, grey_values;
  for (int r = stride / 2; r < disparity.rows; r += stride)
    for (int c = stride / 2; c < disparity.cols; c += stride) {
      const float d = disparity.at<float>(r, c);
      if (d < min_disparity_px) continue;
      const double z = focal_px * baseline_m / d;
      xyz.push_back((c - cx) * z / focal_px);
      xyz.push_back((r - cy) * z / focal_px);
      xyz.push_back(z);
      grey_values.push_back(grey.at<uchar>(r, c));
    }
  return "{\"seq\": " + std::to_string(seq) + ", \"points\": " + std::to_string(grey_values.size()) +
         ", \"stride_px\": " + std::to_string(stride) + ", \"xyz\": " + jsonArray(xyz, 4) +
         ", \"grey\": " + jsonArray(grey_values, 3) + "}";
}

std::string mapJson(const std::vector<Eigen::Vector3d>& points, const std::vector<uint8_t>& grey, size_t max_points,
                    const Eigen::Vector3d& up, const std::string& placed_by) {
  std::vector<double> xyz, grey_values;
  for (size_t i : subsample(points.size(), max_points)) {
    for (int k = 0; k < 3; ++k) xyz.push_back(points[i][k]);
    grey_values.push_back(i < grey.size() ? grey[i] : 0);
  }
  return "{\"points\": " + std::to_string(grey_values.size()) + ", \"voxels\": " + std::to_string(points.size()) +
         ", \"up\": " + jsonArray({up.x(), up.y(), up.z()}) + ", \"placed_by\": " + jsonString(placed_by) +
         ", \"xyz\": " + jsonArray(xyz, 5) + ", \"grey\": " + jsonArray(grey_values, 3) + "}";
}

void writePage(const std::string& template_path, const std::vector<PageScript>& scripts, const std::string& data_json,
               const std::string& out_path) {
  std::string page = readFile(template_path);
  // The data first: the libraries' text may contain anything, the data block only what this tool wrote.
  fill(page, "/*@REPORT_DATA@*/", data_json, template_path);
  for (const auto& s : scripts) {
    std::string text = readFile(s.path);
    if (text.find("</script") != std::string::npos)
      throw std::runtime_error(s.path + ": contains \"</script\" and cannot be inlined into the page");
    fill(page, s.marker, text, template_path);
  }
  std::ofstream out(out_path, std::ios::binary);
  out << page;
  out.close();
  if (!out) throw std::runtime_error(out_path + ": cannot write (disk full?)");
}

}  // namespace ips::report
