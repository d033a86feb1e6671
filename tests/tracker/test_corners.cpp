// Harris corners against images whose corners are known: rendered squares (antialiased, at subpixel
// positions), at full resolution and through the pyramid level used for wide images.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>
#include <random>

#include "ips/tracker/corners.hpp"

using namespace ips::tracker;

namespace {

// Bright squares on a dark background, rendered 8x larger and area-averaged: corners at exact subpixel
// positions. Returns the true corner positions (pixel centres at integer coordinates).
cv::Mat squares(int w, int h, double side, std::vector<cv::Point2d>* corners) {
  const int s = 8;
  cv::Mat big(h * s, w * s, CV_8UC1, cv::Scalar(40));
  corners->clear();
  const double step = 2.5 * side;
  for (double y0 = 0.8 * side + 0.3; y0 + side < h - 0.8 * side; y0 += step)
    for (double x0 = 0.8 * side + 0.6; x0 + side < w - 0.8 * side; x0 += step) {
      // Pixel (i, j) of the small image covers [i - 0.5, i + 0.5); the big image's pixel k covers small
      // coordinates [(k) / s - 0.5, (k + 1) / s - 0.5).
      const int bx0 = int(std::lround((x0 + 0.5) * s)), by0 = int(std::lround((y0 + 0.5) * s));
      const int bx1 = int(std::lround((x0 + side + 0.5) * s)), by1 = int(std::lround((y0 + side + 0.5) * s));
      cv::rectangle(big, cv::Point(bx0, by0), cv::Point(bx1 - 1, by1 - 1), cv::Scalar(210), cv::FILLED);
      const double ax0 = double(bx0) / s - 0.5, ay0 = double(by0) / s - 0.5;
      const double ax1 = double(bx1) / s - 0.5, ay1 = double(by1) / s - 0.5;
      corners->insert(corners->end(), {{ax0, ay0}, {ax1, ay0}, {ax0, ay1}, {ax1, ay1}});
    }
  cv::Mat img;
  cv::resize(big, img, cv::Size(w, h), 0, 0, cv::INTER_AREA);
  cv::GaussianBlur(img, img, cv::Size(0, 0), 0.7);  // a real lens: no perfectly sharp step
  return img;
}

// The autocorrelation peak of a blurred right-angle corner lies about one pixel (per axis) inside the corner along its
// bisector (Harris' known localisation bias; the matching does not care, it correlates templates).
constexpr double kHarrisBias = 2.0;

double nearest(const std::vector<cv::Point2d>& pts, double x, double y) {
  double best = 1e9;
  for (const auto& p : pts) best = std::min(best, std::hypot(p.x - x, p.y - y));
  return best;
}

void checkFindsAllCorners(const cv::Mat& img, const std::vector<cv::Point2d>& truth, const DetectorParams& params,
                          double max_error) {
  const std::vector<Corner> found = detectCorners(img, params, 4);
  ASSERT_FALSE(found.empty());
  for (const Corner& c : found) {  // nothing on straight edges or in flat areas
    EXPECT_LT(nearest(truth, c.x, c.y), max_error) << "spurious corner at " << c.x << "," << c.y;
    EXPECT_LE(std::abs(c.x - c.xi), 1.0f);
    EXPECT_LE(std::abs(c.y - c.yi), 1.0f);
  }
  std::vector<cv::Point2d> found_pts;
  for (const Corner& c : found) found_pts.emplace_back(c.x, c.y);
  int missed = 0;
  for (const auto& t : truth) missed += nearest(found_pts, t.x, t.y) > max_error;
  EXPECT_EQ(missed, 0);
}

}  // namespace

TEST(Corners, HarrisFindsSquareCorners) {
  std::vector<cv::Point2d> truth;
  const cv::Mat img = squares(320, 240, 20.0, &truth);
  DetectorParams p;
  p.quality_level = 0.05;
  p.max_per_cell = 20;
  checkFindsAllCorners(img, truth, p, kHarrisBias);
}

TEST(Corners, MinEigenFindsSquareCorners) {
  std::vector<cv::Point2d> truth;
  const cv::Mat img = squares(320, 240, 20.0, &truth);
  DetectorParams p;
  p.response = CornerResponse::MinEigen;
  p.quality_level = 0.05;
  p.max_per_cell = 20;
  checkFindsAllCorners(img, truth, p, kHarrisBias);
}

TEST(Corners, SubpixelPositionIsCloserThanThePixel) {
  std::vector<cv::Point2d> truth;
  const cv::Mat img = squares(320, 240, 20.0, &truth);
  DetectorParams p;
  p.quality_level = 0.05;
  p.max_per_cell = 20;
  double err_sub = 0, err_int = 0;
  const auto found = detectCorners(img, p, 4);
  for (const Corner& c : found) {
    err_sub += nearest(truth, c.x, c.y);
    err_int += nearest(truth, c.xi, c.yi);
  }
  EXPECT_LT(err_sub, err_int);
}

TEST(Corners, WideImagesAreSearchedOnAPyramidLevel) {
  std::vector<cv::Point2d> truth;
  const cv::Mat img = squares(1360, 1024, 40.0, &truth);
  DetectorParams p;
  p.quality_level = 0.05;
  p.max_per_cell = 40;
  p.max_detection_width = 800;  // 1360 -> 680
  checkFindsAllCorners(img, truth, p, 2.0 * kHarrisBias);
}

TEST(Corners, GridLimitsCornersPerCell) {
  cv::Mat noise(240, 320, CV_8UC1);
  cv::randu(noise, 0, 255);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), 1.5);
  DetectorParams p;
  p.grid_cols = 4;
  p.grid_rows = 3;
  p.max_per_cell = 5;
  const auto found = detectCorners(noise, p, 10);
  EXPECT_EQ(found.size(), size_t(4 * 3 * 5));  // plenty of texture: every cell is full
  std::vector<int> per_cell(12, 0);
  for (const Corner& c : found) {
    EXPECT_GE(c.xi, 10);
    EXPECT_LT(c.xi, 310);
    EXPECT_GE(c.yi, 10);
    EXPECT_LT(c.yi, 230);
    per_cell[std::min(2, c.yi / 80) * 4 + std::min(3, c.xi / 80)]++;
  }
  for (int n : per_cell) EXPECT_EQ(n, 5);
}

TEST(Corners, FlatImageHasNoCornersAndBadInputThrows) {
  DetectorParams p;
  EXPECT_TRUE(detectCorners(cv::Mat(100, 100, CV_8UC1, cv::Scalar(77)), p, 4).empty());
  EXPECT_THROW(detectCorners(cv::Mat(), p, 4), std::invalid_argument);
  EXPECT_THROW(detectCorners(cv::Mat(100, 100, CV_16UC1, cv::Scalar(7)), p, 4), std::invalid_argument);
  p.grid_cols = 0;
  EXPECT_THROW(detectCorners(cv::Mat(100, 100, CV_8UC1, cv::Scalar(77)), p, 4), std::invalid_argument);
}
