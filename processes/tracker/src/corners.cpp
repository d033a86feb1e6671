#include "ips/tracker/corners.hpp"

#include <algorithm>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace ips::tracker {

namespace {

// Buffers of the response kept from one image to the next. Allocating them afresh every frame (OpenCV's
// cornerHarris allocates derivative and product images of the full level) returned the memory to the system and
// page-faulted it in again each time: on a 752x480 image that cost ten times the arithmetic (40 ms instead of 4)
// on a virtual machine.
struct ResponseWorkspace {
  cv::Mat dx, dy, products, sums;
};

// The Harris response exactly as cv::cornerHarris computes it (same scale, derivatives, unnormalised box sums),
// in reused buffers; the minimum eigenvalue through OpenCV.
void computeResponse(const cv::Mat& gray8, const DetectorParams& p, cv::Mat& response) {
  if (gray8.empty() || gray8.type() != CV_8UC1) throw std::invalid_argument("cornerResponse: need an 8-bit grey image");
  if (p.response != CornerResponse::Harris) {
    cv::cornerMinEigenVal(gray8, response, p.block_size, p.sobel_size, cv::BORDER_REFLECT_101);
    return;
  }
  thread_local ResponseWorkspace ws;
  const double scale = 1.0 / ((1 << (p.sobel_size - 1)) * p.block_size * 255.0);
  cv::Sobel(gray8, ws.dx, CV_32F, 1, 0, p.sobel_size, scale, 0, cv::BORDER_REFLECT_101);
  cv::Sobel(gray8, ws.dy, CV_32F, 0, 1, p.sobel_size, scale, 0, cv::BORDER_REFLECT_101);
  ws.products.create(gray8.size(), CV_32FC3);
  for (int y = 0; y < gray8.rows; ++y) {
    const float* gx = ws.dx.ptr<float>(y);
    const float* gy = ws.dy.ptr<float>(y);
    float* out = ws.products.ptr<float>(y);
    for (int x = 0; x < gray8.cols; ++x) {
      out[3 * x] = gx[x] * gx[x];
      out[3 * x + 1] = gx[x] * gy[x];
      out[3 * x + 2] = gy[x] * gy[x];
    }
  }
  cv::boxFilter(ws.products, ws.sums, CV_32F, cv::Size(p.block_size, p.block_size), cv::Point(-1, -1), false,
                cv::BORDER_REFLECT_101);
  response.create(gray8.size(), CV_32FC1);
  const float k = float(p.harris_k);
  for (int y = 0; y < gray8.rows; ++y) {
    const float* c = ws.sums.ptr<float>(y);
    float* out = response.ptr<float>(y);
    for (int x = 0; x < gray8.cols; ++x) {
      const float a = c[3 * x], b = c[3 * x + 1], d = c[3 * x + 2];
      out[x] = a * d - b * b - k * (a + d) * (a + d);
    }
  }
}

}  // namespace

cv::Mat cornerResponse(const cv::Mat& gray8, const DetectorParams& p) {
  cv::Mat response;
  computeResponse(gray8, p, response);
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
  thread_local cv::Mat response;  // reused across frames (see ResponseWorkspace)
  computeResponse(gray8, p, response);
  const int w = response.cols, h = response.rows;
  margin = std::max(margin, 1);  // the 3x3 maximum test and the subpixel fit need one pixel around
  if (w <= 2 * margin || h <= 2 * margin) return {};

  double max_response = 0;
  cv::minMaxLoc(response, nullptr, &max_response);
  if (!(max_response > 0)) return {};
  const float threshold = float(p.quality_level * max_response);

  // The strongest strict local maxima per cell (ties broken towards the first pixel in scan order), kept in a
  // bounded list per cell while scanning: a low-contrast image (a dark hall, sensor noise) has a local maximum
  // above the threshold at a large share of its pixels, and storing them all before choosing cost more than the
  // response itself.
  const int cells = p.grid_cols * p.grid_rows;
  const size_t keep = size_t(p.max_per_cell);
  std::vector<std::vector<Corner>> per_cell(cells);
  for (auto& cell : per_cell) cell.reserve(keep);
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
      std::vector<Corner>& cell = per_cell[cy * p.grid_cols + std::min(p.grid_cols - 1, int(x / cell_w))];
      Corner c;
      c.xi = x;
      c.yi = y;
      c.response = v;
      if (cell.size() < keep) {
        cell.push_back(c);
        continue;
      }
      auto weakest = std::min_element(cell.begin(), cell.end(),
                                      [](const Corner& a, const Corner& b) { return a.response < b.response; });
      if (v > weakest->response) *weakest = c;
    }
  }
  std::vector<Corner> out;
  for (auto& cell : per_cell) {
    std::stable_sort(cell.begin(), cell.end(),
                     [](const Corner& a, const Corner& b) { return a.response > b.response; });
    for (Corner c : cell) {
      // Subpixel: vertex of the parabola through the maximum and its two neighbours, per axis.
      const int x = c.xi, y = c.yi;
      const float* up = response.ptr<float>(y - 1);
      const float* row = response.ptr<float>(y);
      const float* dn = response.ptr<float>(y + 1);
      const float v = row[x];
      const float dxd = row[x - 1] - 2 * v + row[x + 1];
      const float dyd = up[x] - 2 * v + dn[x];
      const float ox = dxd < 0 ? 0.5f * (row[x - 1] - row[x + 1]) / dxd : 0.f;
      const float oy = dyd < 0 ? 0.5f * (up[x] - dn[x]) / dyd : 0.f;
      c.x = x + std::clamp(ox, -0.5f, 0.5f);
      c.y = y + std::clamp(oy, -0.5f, 0.5f);
      out.push_back(c);
    }
  }
  return out;
}

}  // namespace

}  // namespace ips::tracker
