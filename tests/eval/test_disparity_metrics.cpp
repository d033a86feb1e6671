// Disparity scores of small maps whose bad pixels are counted by hand: invalid pixels count as bad, pixels without
// a truth or outside the region do not count, the error scale converts map pixels into full-resolution ones, and
// the truth sampled at a smaller map's pixel centres is scaled into its pixels.
#include <gtest/gtest.h>

#include <cmath>

#include "ips/eval/disparity.hpp"

using namespace ips::eval;

namespace {

// A 1x6 map: three good, one 2.5 px off, one invalid, one without a truth.
struct Row {
  cv::Mat estimate = (cv::Mat_<float>(1, 6) << 10.f, 20.f, 30.5f, 42.5f, NAN, 7.f);
  cv::Mat truth = (cv::Mat_<float>(1, 6) << 10.f, 20.2f, 30.f, 40.f, 12.f, NAN);
};

}  // namespace

TEST(DisparityMetrics, InvalidCountsAsBadAndPixelsWithoutTruthDoNotCount) {
  const Row m;
  const DisparityErrors e = disparityErrors(m.estimate, m.truth, {0.25, 1.0, 2.0, 4.0});
  EXPECT_EQ(e.pixels, 6);
  EXPECT_EQ(e.estimated, 5);
  EXPECT_EQ(e.evaluated, 5);
  EXPECT_EQ(e.valid, 4);
  // Errors of the valid pixels: 0, 0.2, 0.5, 2.5; the invalid one is bad at every threshold.
  EXPECT_EQ(e.bad, (std::vector<int64_t>{3, 2, 2, 1}));
  EXPECT_EQ(e.bad_valid, (std::vector<int64_t>{2, 1, 1, 0}));
  EXPECT_DOUBLE_EQ(e.badPct(2), 40.0);
  EXPECT_DOUBLE_EQ(e.badValidPct(2), 25.0);
  EXPECT_NEAR(e.meanAbsError(), (0 + 0.2 + 0.5 + 2.5) / 4, 1e-6);
  EXPECT_NEAR(e.densityPct(), 100.0 * 5 / 6, 1e-12);
}

TEST(DisparityMetrics, RegionAndErrorScale) {
  const Row m;
  const cv::Mat region = (cv::Mat_<uint8_t>(1, 6) << 0, 1, 1, 1, 0, 0);
  // At half resolution an error of 0.5 map pixels is 1 full-resolution pixel.
  const DisparityErrors e = disparityErrors(m.estimate, m.truth, {0.9}, region, 2.0);
  EXPECT_EQ(e.pixels, 3);
  EXPECT_EQ(e.evaluated, 3);
  EXPECT_EQ(e.bad[0], 2);  // 0.4 and 5.0 full-resolution px off; 0.2 * 2 = 0.4 is good
  EXPECT_NEAR(e.meanAbsError(), (0.4 + 1.0 + 5.0) / 3, 1e-5);
}

TEST(DisparityMetrics, FixedPointMapsAndTheirInvalidValue) {
  const cv::Mat fixed = (cv::Mat_<int16_t>(1, 3) << 160, -1, 24);
  const cv::Mat px = disparityPixels(fixed, -1, 16.0);
  EXPECT_FLOAT_EQ(px.at<float>(0, 0), 10.f);
  EXPECT_TRUE(std::isnan(px.at<float>(0, 1)));
  EXPECT_FLOAT_EQ(px.at<float>(0, 2), 1.5f);
}

TEST(DisparityMetrics, TruthAtHalfSizeSamplesPixelCentresAndScales) {
  cv::Mat truth(4, 4, CV_32F);
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) truth.at<float>(r, c) = float(10 * r + c);
  truth.at<float>(3, 3) = NAN;
  const cv::Mat half = truthAtSize(truth, cv::Size(2, 2));
  // Map pixel (r, c) covers full-resolution pixels 2r..2r+1; its centre rounds to 2r+1.
  EXPECT_FLOAT_EQ(half.at<float>(0, 0), 0.5f * 11);
  EXPECT_FLOAT_EQ(half.at<float>(0, 1), 0.5f * 13);
  EXPECT_FLOAT_EQ(half.at<float>(1, 0), 0.5f * 31);
  EXPECT_TRUE(std::isnan(half.at<float>(1, 1)));
  EXPECT_TRUE(cv::norm(truthAtSize(truth(cv::Rect(0, 0, 3, 3)), cv::Size(3, 3)), truth(cv::Rect(0, 0, 3, 3))) == 0);
}

TEST(DisparityMetrics, MismatchedInputsAreRejected) {
  const Row m;
  EXPECT_THROW(disparityErrors(m.estimate, cv::Mat(1, 5, CV_32F), {2.0}), std::invalid_argument);
  EXPECT_THROW(disparityErrors(m.estimate, m.truth, {2.0}, cv::Mat(1, 6, CV_32F)), std::invalid_argument);
  EXPECT_THROW(disparityPixels(cv::Mat(1, 1, CV_32F), -1, 16), std::invalid_argument);
}
