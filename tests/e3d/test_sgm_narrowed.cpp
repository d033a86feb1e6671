// The narrowed search of E3D's SGM reference (search "narrowed", ips/e3d/sgm.hpp): the bands it derives from the
// coarse map, the full search when every band is the range, and its quality against the ground truth of a
// Middlebury scene beside the full search's. CPU only.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "ips/e3d/matching_cost.hpp"
#include "ips/e3d/sgm.hpp"
#include "ips/eval/disparity.hpp"
#include "ips/shared_data_test.hpp"
#include "stereo_scenes.hpp"

using namespace ips;
using namespace ips::e3d;
using ips::e3d_test::differences;
using ips::e3d_test::loadGrey;

namespace {

SgmParams narrowed(int num_disparities) {
  SgmParams p;
  p.num_disparities = num_disparities;
  p.search = Search::narrowed;
  return p;
}

}  // namespace

TEST(NarrowedSearch, BandsFollowTheCoarseMapWidenAtEdgesAndAreFullWhereItIsInvalid) {
  // A coarse map (half of 80 x 40) at 10 px on the left, 30.5 px on the right from coarse column 20, invalid in
  // coarse rows 15..19.
  cv::Mat coarse(20, 40, CV_16S, cv::Scalar(10 * kSubpixelScale));
  coarse(cv::Rect(20, 0, 20, 20)).setTo(30 * kSubpixelScale + 8);
  coarse(cv::Rect(0, 15, 40, 5)).setTo(kInvalidDisparity);
  SgmParams p = narrowed(128);
  p.band_width = 16;
  p.band_margin = 3;
  const DisparityBands b = narrowedBands(coarse, cv::Size(80, 40), p);
  auto band = [&](int x, int y) {
    const size_t i = static_cast<size_t>(y) * 80 + x;
    return std::make_pair(int(b.lo[i]), int(b.hi[i]));
  };
  // Inside the 10 px region: the doubled 20 px +- 3 (7 wide), widened to 16 about it.
  EXPECT_EQ(band(10, 4), std::make_pair(20 - 7, 20 + 8));
  // Inside the right region: 30.5 doubled, 61 +- 3, widened to 16.
  EXPECT_EQ(band(60, 4), std::make_pair(61 - 7, 61 + 8));
  // At the edge (coarse columns 19 and 20 in the neighbourhood): both sides, 20 - 3 .. 61 + 3.
  EXPECT_EQ(band(39, 4), std::make_pair(17, 64));
  EXPECT_EQ(band(40, 4), std::make_pair(17, 64));
  // Coarse rows 15..19 invalid: rows whose neighbourhood still holds row 14 keep a band, the rest the full range.
  EXPECT_EQ(band(10, 29), std::make_pair(13, 28));
  EXPECT_EQ(band(10, 31), std::make_pair(13, 28));
  EXPECT_EQ(band(10, 32), std::make_pair(0, 127));
  // At the range's ends the band is shifted into it, not cut.
  p.min_disparity = 18;
  const DisparityBands shifted = narrowedBands(coarse, cv::Size(80, 40), p);
  EXPECT_EQ(int(shifted.lo[4 * 80 + 10]), 0);
  EXPECT_EQ(int(shifted.hi[4 * 80 + 10]), 15);
  // 32 rows of bands (16 wide, 48 on the four columns at the edge), 8 rows of the full range.
  EXPECT_DOUBLE_EQ(b.searchedShare(), (32.0 * (76 * 16 + 4 * 48) + 8.0 * 80 * 128) / (80.0 * 40 * 128));
}

TEST(NarrowedSearch, WithBandsAsWideAsTheRangeIsTheFullSearchBitForBit) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  const cv::Rect crop(100, 100, 160, 90);
  const cv::Mat left = loadGrey("cones", "left.png")(crop).clone(),
                right = loadGrey("cones", "right.png")(crop).clone();
  SgmParams p = narrowed(48);
  p.band_width = 48;
  SgmParams full = p;
  full.search = Search::full;
  const SgmResult reference = sgmReference(left, right, full);
  const SgmResult wide = sgmReference(left, right, p);
  EXPECT_GT(cv::countNonZero(reference.left != kInvalidDisparity), left.total() * 3 / 4);
  EXPECT_EQ(differences(wide.left, reference.left), 0);
  EXPECT_EQ(differences(wide.right, reference.right), 0);
  // Path costs over bands that are the range are the full search's.
  const std::vector<uint8_t> cost = costVolume(left, right, full);
  const DisparityBands bands = DisparityBands::full(left.size(), full.num_disparities);
  for (int r = 0; r < 8; ++r) EXPECT_EQ(pathCosts(left, cost, full, r, &bands), pathCosts(left, cost, full, r));
}

TEST(NarrowedSearch, PathCostsOutsideTheBandsAreOutOfBandAndInsideBoundedByOneByte) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  const cv::Rect crop(60, 60, 120, 80);
  const cv::Mat left = loadGrey("teddy", "left.png")(crop).clone(),
                right = loadGrey("teddy", "right.png")(crop).clone();
  SgmParams p = narrowed(64);
  p.band_width = 12;
  const cv::Mat coarse = sgmReference(halfSize(left), halfSize(right), coarseLevelParams(p)).left;
  const DisparityBands bands = narrowedBands(coarse, left.size(), p);
  ASSERT_LT(bands.searchedShare(), 0.5);
  const std::vector<uint8_t> cost = costVolume(left, right, p);
  for (int r = 0; r < 8; ++r) {
    const std::vector<uint16_t> path = pathCosts(left, cost, p, r, &bands);
    size_t outside = 0, above = 0;
    for (size_t i = 0; i < bands.lo.size(); ++i)
      for (int k = 0; k < p.num_disparities; ++k) {
        const uint16_t v = path[i * p.num_disparities + k];
        const bool in_band = k >= bands.lo[i] && k <= bands.hi[i];
        outside += !in_band && v != kOutOfBand;
        above += in_band && v > kCensusMaxCost + p.p2;
      }
    EXPECT_EQ(outside, 0u) << "path " << r;
    EXPECT_EQ(above, 0u) << "path " << r;
  }
}

TEST(NarrowedSearch, KeepsTheFullSearchsQualityOnTeddyWithAboutHalfTheVolume) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  const cv::Mat left = loadGrey("teddy", "left.png"), right = loadGrey("teddy", "right.png");
  const cv::Mat gt = cv::imread(ips::dataDir() + "/stereo/teddy/disp_gt.png", cv::IMREAD_GRAYSCALE);
  const cv::Mat mask = cv::imread(ips::dataDir() + "/stereo/teddy/mask_nonocc.png", cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(gt.empty());
  cv::Mat truth;
  gt.convertTo(truth, CV_32F, 1.0 / 4);  // 4 x the disparity, 0 where unknown
  truth.setTo(NAN, gt == 0);
  const cv::Mat region = mask == 255;
  auto bad2 = [&](const cv::Mat& d16, double& density) {
    const ips::eval::DisparityErrors e = ips::eval::disparityErrors(
        ips::eval::disparityPixels(d16, kInvalidDisparity, kSubpixelScale), truth, {2.0}, region);
    density = e.densityPct();
    return e.badPct(0);
  };
  SgmParams full;
  full.num_disparities = 64;
  const SgmParams p = narrowed(64);
  double full_density = 0, narrowed_density = 0;
  const double full_bad = bad2(sgmReference(left, right, full).left, full_density);
  const double narrowed_bad = bad2(sgmReference(left, right, p).left, narrowed_density);
  // Measured: full 6.06 %, narrowed 5.89 % (invalid pixels count as bad); density 97.2 and 97.5 %.
  EXPECT_LT(narrowed_bad, full_bad + 0.1);
  EXPECT_GT(narrowed_density, full_density - 0.5);
  const cv::Mat coarse = sgmReference(halfSize(left), halfSize(right), coarseLevelParams(p)).left;
  EXPECT_LT(narrowedBands(coarse, left.size(), p).searchedShare(), 0.6);  // measured 0.53
}

TEST(NarrowedSearch, RefusesWhatItDoesNotSupport) {
  SgmParams p = narrowed(64);
  EXPECT_NO_THROW(p.validate());
  EXPECT_THROW(p.withCost(Cost::mi).validate(), std::invalid_argument);
  SgmParams bad = p;
  bad.right_map = RightMap::match;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
  bad = p;
  bad.band_width = 2;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
  bad = p;
  bad.band_margin = -1;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
  EXPECT_THROW(parseSearch("tsgm"), std::invalid_argument);
  EXPECT_EQ(parseSearch("narrowed"), Search::narrowed);
  EXPECT_THROW(narrowedBands(cv::Mat(10, 10, CV_16S), cv::Size(40, 20), p), std::invalid_argument);
}
