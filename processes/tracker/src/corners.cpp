#include "ips/tracker/corners.hpp"

#include <algorithm>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace ips::tracker {

cv::Mat cornerResponse(const cv::Mat& gray8, const DetectorParams& p) {
  if (gray8.empty() || gray8.type() != CV_8UC1) throw std::invalid_argument("cornerResponse: need an 8-bit grey image");
  cv::Mat response;
  if (p.response == CornerResponse::Harris)
    cv::cornerHarris(gray8, response, p.block_size, p.sobel_size, p.harris_k, cv::BORDER_REFLECT_101);
  else
    cv::cornerMinEigenVal(gray8, response, p.block_size, p.sobel_size, cv::BORDER_REFLECT_101);
  return response;
}

namespace {

std::vector<Corner> detectAtLevel(const cv::Mat& gray8, const DetectorParams& p, int margin);

}  // namespace

std::vector<Corner> detectCorners(const cv::Mat& gray8, const DetectorParams& p, int margin) {
  if (p.grid_cols < 1 || p.grid_rows < 1 || p.max_per_cell < 1 || p.max_detection_width < 16)
    throw std::invalid_argument("detectCorners: grid, max_per_cell and max_detection_width must be positive");
  if (gray8.empty() || gray8.type() != CV_8UC1) throw std::invalid_argument("detectCorners: need an 8-bit grey image");
  cv::Mat level = gray8;
  int scale = 1;
  while (level.cols > p.max_detection_width) {
    cv::Mat down;
    cv::pyrDown(level, down);
    level = down;
    scale *= 2;
  }
  if (scale == 1) return detectAtLevel(gray8, p, margin);
  // pyrDown's pixel i is centred on full-resolution pixel 2i.
  std::vector<Corner> corners = detectAtLevel(level, p, (margin + scale - 1) / scale + 1);
  for (Corner& c : corners) {
    c.x *= float(scale);
    c.y *= float(scale);
    c.xi = std::clamp(int(std::lround(c.x)), margin, gray8.cols - 1 - margin);
    c.yi = std::clamp(int(std::lround(c.y)), margin, gray8.rows - 1 - margin);
  }
  return corners;
}

namespace {

std::vector<Corner> detectAtLevel(const cv::Mat& gray8, const DetectorParams& p, int margin) {
  const cv::Mat response = cornerResponse(gray8, p);
  const int w = response.cols, h = response.rows;
  margin = std::max(margin, 1);  // the 3x3 maximum test and the subpixel fit need one pixel around
  if (w <= 2 * margin || h <= 2 * margin) return {};

  double max_response = 0;
  cv::minMaxLoc(response, nullptr, &max_response);
  if (!(max_response > 0)) return {};
  const float threshold = float(p.quality_level * max_response);

  // Candidates per cell: strict local maxima (ties broken towards the first pixel in scan order).
  const int cells = p.grid_cols * p.grid_rows;
  std::vector<std::vector<Corner>> per_cell(cells);
  const float cell_w = float(w) / p.grid_cols, cell_h = float(h) / p.grid_rows;
  for (int y = margin; y < h - margin; ++y) {
    const float* up = response.ptr<float>(y - 1);
    const float* row = response.ptr<float>(y);
    const float* dn = response.ptr<float>(y + 1);
    const int cy = std::min(p.grid_rows - 1, int(y / cell_h));
    for (int x = margin; x < w - margin; ++x) {
      const float v = row[x];
      if (v < threshold) continue;
      if (!(v > row[x - 1] && v >= row[x + 1] && v > up[x - 1] && v > up[x] && v > up[x + 1] && v >= dn[x - 1] &&
            v >= dn[x] && v >= dn[x + 1]))
        continue;
      Corner c;
      c.xi = x;
      c.yi = y;
      c.response = v;
      // Subpixel: vertex of the parabola through the maximum and its two neighbours, per axis.
      const float dxd = row[x - 1] - 2 * v + row[x + 1];
      const float dyd = up[x] - 2 * v + dn[x];
      const float ox = dxd < 0 ? 0.5f * (row[x - 1] - row[x + 1]) / dxd : 0.f;
      const float oy = dyd < 0 ? 0.5f * (up[x] - dn[x]) / dyd : 0.f;
      c.x = x + std::clamp(ox, -0.5f, 0.5f);
      c.y = y + std::clamp(oy, -0.5f, 0.5f);
      const int cx = std::min(p.grid_cols - 1, int(x / cell_w));
      per_cell[cy * p.grid_cols + cx].push_back(c);
    }
  }
  std::vector<Corner> out;
  for (auto& cell : per_cell) {
    const size_t keep = std::min<size_t>(cell.size(), size_t(p.max_per_cell));
    std::partial_sort(cell.begin(), cell.begin() + keep, cell.end(),
                      [](const Corner& a, const Corner& b) { return a.response > b.response; });
    out.insert(out.end(), cell.begin(), cell.begin() + keep);
  }
  return out;
}

}  // namespace

}  // namespace ips::tracker
