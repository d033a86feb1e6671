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
