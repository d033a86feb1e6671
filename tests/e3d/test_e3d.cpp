// E3D tests: the Vulkan pipeline against the plain C++ reference (exact, subpixel included, since both use
// the same integer arithmetic), the reference against ground truth, device rectification against
// cv::remap, and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "ips/args.hpp"
#include "ips/calibration.hpp"
#include "ips/config.hpp"
#include "ips/e3d/sgm.hpp"
#include "ips/e3d/sgm_options.hpp"
#include "ips/e3d/stereo_matcher.hpp"
#include "ips/eval/disparity.hpp"
#include "ips/shared_data_test.hpp"
#include "ips/test_support/temp_yaml.hpp"
#include "stereo_scenes.hpp"

using namespace ips;
using namespace ips::e3d;
using ips::e3d_test::differences;
using ips::e3d_test::loadGrey;
using ips::test_support::writeTempYaml;

namespace {

VulkanContext& context() {
  static VulkanContext ctx;
  return ctx;
}

// Both aggregation layouts (row passes and lines) must give the reference's maps exactly.
const Aggregation kLayouts[] = {Aggregation::rows, Aggregation::lines};

void expectDeviceEqualsReference(const cv::Mat& left, const cv::Mat& right, SgmParams params) {
  SgmResult ref = sgmReference(left, right, params);
  // The comparison must not be vacuous: most pixels carry a disparity.
  EXPECT_GT(cv::countNonZero(ref.left != kInvalidDisparity), left.total() / 2);
  for (Aggregation layout : kLayouts) {
    params.aggregation = layout;
    StereoMatcher matcher(context(), left.size(), params);
    MatchOutput gpu = matcher.match(left, right, true);
    ASSERT_EQ(gpu.disparity.type(), CV_16S);
    ASSERT_EQ(gpu.disparity.size(), left.size());
    EXPECT_EQ(differences(gpu.disparity, ref.left), 0) << params.describe();
    EXPECT_EQ(differences(gpu.right, ref.right), 0) << params.describe();
  }
}

}  // namespace

TEST(Census, ConstantImageHasNoBitsAndStepSetsDarkerNeighbours) {
  cv::Mat flat(8, 8, CV_8UC1, cv::Scalar(100));
  EXPECT_EQ(cv::countNonZero(census5x5(flat)), 0);
  cv::Mat step(8, 8, CV_8UC1, cv::Scalar(200));
  step.colRange(0, 4).setTo(50);  // left half darker
  cv::Mat c = census5x5(step);
  // Pixel (4,4): neighbours at dx = -2, -1 are darker: 2 columns x 5 rows = 10 bits, in row-major order.
  uint32_t expected = 0;
  for (int dy = -2; dy <= 2; ++dy)
    for (int dx = -2; dx <= 2; ++dx)
      if (dx || dy) expected = (expected << 1) | (dx < 0 ? 1u : 0u);
  EXPECT_EQ(static_cast<uint32_t>(c.at<int32_t>(4, 4)), expected);
}

TEST(SgmReference, ShiftedRandomTextureGivesTheShift) {
  cv::Mat right(60, 120, CV_8UC1);
  cv::RNG rng(7);
  rng.fill(right, cv::RNG::UNIFORM, 0, 256);
  cv::Mat left(right.size(), CV_8UC1);
  const int shift = 9;
  for (int x = 0; x < left.cols; ++x) right.col(std::max(0, x - shift)).copyTo(left.col(x));
  SgmParams p;
  p.num_disparities = 16;
  SgmResult r = sgmReference(left, right, p);
  int good = 0, total = 0;
  for (int y = 3; y < left.rows - 3; ++y)
    for (int x = shift + 20; x < left.cols - 3; ++x, ++total)
      good += std::abs(r.left.at<int16_t>(y, x) - shift * kSubpixelScale) <= kSubpixelScale / 2;
  EXPECT_GT(good, total * 98 / 100);
}

TEST(SgmReference, TsukubaAgainstGroundTruth) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  cv::Mat left = loadGrey("tsukuba", "left.png"), right = loadGrey("tsukuba", "right.png");
  cv::Mat gt = cv::imread(ips::dataDir() + "/stereo/tsukuba/disp_gt.png", cv::IMREAD_GRAYSCALE);
  cv::Mat mask = cv::imread(ips::dataDir() + "/stereo/tsukuba/mask_nonocc.png", cv::IMREAD_GRAYSCALE);
  SgmParams p;
  p.num_disparities = 16;
  p.fill_invalid = true;  // invalid pixels count as bad below
  const cv::Mat d = sgmReference(left, right, p).left;
  cv::Mat truth;
  gt.convertTo(truth, CV_32F, 1.0 / 16);  // disp_gt.png holds 16 x the disparity, 0 where unknown
  truth.setTo(NAN, gt == 0);
  cv::Mat region = cv::Mat::zeros(gt.size(), CV_8U);
  region(cv::Rect(18, 18, gt.cols - 36, gt.rows - 36)).setTo(255);
  region &= mask == 255;
  const ips::eval::DisparityErrors e = ips::eval::disparityErrors(
      ips::eval::disparityPixels(d, kInvalidDisparity, kSubpixelScale), truth, {2.0}, region);
  ASSERT_GT(e.evaluated, 50000);
  EXPECT_LT(e.badPct(0), 4.5);  // measured 3.3 % (OpenCV StereoSGBM MODE_HH: 3.4 %)
}

TEST(StereoMatcher, EqualsReferenceOnTsukuba) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  SgmParams p;
  p.num_disparities = 16;
  expectDeviceEqualsReference(loadGrey("tsukuba", "left.png"), loadGrey("tsukuba", "right.png"), p);
}

TEST(StereoMatcher, EqualsReferenceOnConesWithAdaptiveP2) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  SgmParams p;
  p.num_disparities = 64;
  p.p2_slope = 12;
  expectDeviceEqualsReference(loadGrey("cones", "left.png"), loadGrey("cones", "right.png"), p);
}

TEST(StereoMatcher, EqualsReferenceOddSizeFourPathsMinDisparityNoSubpixel) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  cv::Mat left = loadGrey("teddy", "left.png")(cv::Rect(13, 7, 201, 77)).clone();
  cv::Mat right = loadGrey("teddy", "right.png")(cv::Rect(13, 7, 201, 77)).clone();
  SgmParams p;
  p.num_disparities = 37;
  p.min_disparity = 10;
  p.paths = 4;
  p.subpixel = false;
  p.median = false;
  p.uniqueness = 0;
  expectDeviceEqualsReference(left, right, p);
}

TEST(StereoMatcher, EqualsReferenceNegativeMinDisparityEightPaths) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  cv::Mat left = loadGrey("venus", "left.png")(cv::Rect(40, 30, 150, 90)).clone();
  cv::Mat right = loadGrey("venus", "right.png")(cv::Rect(40, 30, 150, 90)).clone();
  SgmParams p;
  p.num_disparities = 45;
  p.min_disparity = -6;
  p.p2_slope = 40;
  expectDeviceEqualsReference(left, right, p);
}

TEST(StereoMatcher, SecondMatchRightToLeftEqualsReference) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  cv::Mat left = loadGrey("cones", "left.png")(cv::Rect(20, 30, 300, 200)).clone();
  cv::Mat right = loadGrey("cones", "right.png")(cv::Rect(20, 30, 300, 200)).clone();
  SgmParams p;
  p.num_disparities = 60;
  p.min_disparity = 3;
  p.right_map = RightMap::match;
  expectDeviceEqualsReference(left, right, p);
  // The right map of a second match has subpixel values and mostly agrees with the diagonal search.
  const cv::Mat matched = sgmReference(left, right, p).right;
  p.right_map = RightMap::diagonal;
  const cv::Mat diagonal = sgmReference(left, right, p).right;
  const cv::Mat both = (matched != kInvalidDisparity) & (diagonal != kInvalidDisparity);
  cv::Mat diff;
  cv::absdiff(matched, diagonal, diff);
  EXPECT_GT(cv::countNonZero(both & (diff <= kSubpixelScale)), cv::countNonZero(both) * 8 / 10);
  EXPECT_GT(cv::countNonZero(both & (diff != 0) & (diff < kSubpixelScale)), 100);
}

TEST(StereoMatcher, EqualsReferenceWithoutChecks) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  cv::Mat left = loadGrey("venus", "left.png"), right = loadGrey("venus", "right.png");
  SgmParams p;
  p.num_disparities = 32;
  p.lr_max_diff = -1;
  p.uniqueness = 0;
  p.median = false;
  const cv::Mat ref = sgmReference(left, right, p).left;
  for (Aggregation layout : kLayouts) {
    p.aggregation = layout;
    StereoMatcher matcher(context(), left.size(), p);
    MatchOutput gpu = matcher.match(left, right);
    EXPECT_EQ(differences(gpu.disparity, ref), 0) << toString(layout);
    EXPECT_EQ(cv::countNonZero(gpu.disparity == kInvalidDisparity), 0);  // nothing invalidated without checks
  }
}

// A KITTI crop matched in one layout whose volume exceeds lavapipe's 128 MiB storage-buffer limit
// (deviceMemoryBytes above `volume_bytes`): the split must not change the maps.
void expectSplitVolumeEqualsReference(cv::Rect crop, int num_disparities, Aggregation layout, size_t volume_bytes) {
  cv::Mat left = loadGrey("kitti2015_000046", "left.png")(crop).clone();
  cv::Mat right = loadGrey("kitti2015_000046", "right.png")(crop).clone();
  SgmParams p;
  p.num_disparities = num_disparities;
  p.aggregation = layout;
  StereoMatcher matcher(context(), left.size(), p);
  EXPECT_GT(matcher.deviceMemoryBytes(), volume_bytes);
  MatchOutput gpu = matcher.match(left, right, true);
  SgmResult ref = sgmReference(left, right, p);
  EXPECT_EQ(differences(gpu.disparity, ref.left), 0);
  EXPECT_EQ(differences(gpu.right, ref.right), 0);
}

TEST(StereoMatcher, VolumeSplitOverSeveralBuffersEqualsReference) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  // Lines: 8 paths x 700 x 200 x 128 bytes = 143 MB, over several buffers.
  expectSplitVolumeEqualsReference(cv::Rect(300, 150, 700, 200), 128, Aggregation::lines, size_t(8) * 700 * 200 * 128);
}

TEST(StereoMatcher, RowPassSumsOverSeveralBufferRangesEqualReference) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  // Rows: sums of 1000 x 300 x 256 disparities x 2 bytes = 154 MB, over two storage-buffer ranges.
  expectSplitVolumeEqualsReference(cv::Rect(200, 60, 1000, 300), 256, Aggregation::rows, size_t(2) * 1000 * 300 * 256);
}

TEST(StereoMatcher, RepeatedMatchesGiveTheSameResultAndStageTimings) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  cv::Mat left = loadGrey("tsukuba", "left.png"), right = loadGrey("tsukuba", "right.png");
  SgmParams p;
  p.num_disparities = 16;
  StereoMatcher matcher(context(), left.size(), p);
  MatchOutput a = matcher.match(left, right);
  MatchOutput b = matcher.match(right, left);  // something else in between
  MatchOutput c = matcher.match(left, right);
  EXPECT_EQ(differences(a.disparity, c.disparity), 0);
  EXPECT_GT(differences(a.disparity, b.disparity), 0);
  ASSERT_FALSE(c.stages.empty());
  EXPECT_EQ(c.stages.front().name, "census");
}

TEST(StereoMatcher, DeviceRectificationMatchesCpuRemap) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  StereoCalibration calib;
  for (CameraIntrinsics* cam : {&calib.cam0, &calib.cam1}) {
    cam->width = 384;
    cam->height = 288;
    cam->K << 400, 0, 190, 0, 400, 146, 0, 0, 1;
    cam->distortion << -0.2, 0.05, 0.001, -0.001, 0;
  }
  calib.R_cam1_cam0 = Eigen::AngleAxisd(0.02, Eigen::Vector3d(0.2, 1, 0.1).normalized()).toRotationMatrix();
  calib.t_cam1_cam0 = Eigen::Vector3d(-0.2, 0.003, 0.001);
  StereoRectification rect = computeRectification(calib, 0.0);
  cv::Mat raw0 = loadGrey("tsukuba", "left.png"), raw1 = loadGrey("tsukuba", "right.png");
  cv::Mat cpu0, cpu1;
  rectifyPair(rect, raw0, raw1, cpu0, cpu1);
  SgmParams p;
  p.num_disparities = 16;
  StereoMatcher matcher(context(), rect.size, p);
  matcher.setRectification(rect, raw0.size());
  cv::Mat dev0, dev1;
  MatchOutput out = matcher.matchRaw(raw0, raw1, &dev0, &dev1);
  for (auto pair : {std::make_pair(cpu0, dev0), std::make_pair(cpu1, dev1)}) {
    cv::Mat diff;
    cv::absdiff(pair.first, pair.second, diff);
    double max_diff = 0;
    cv::minMaxLoc(diff, nullptr, &max_diff);
    // cv::remap quantises the sample position to 1/32 px, the device does not: on steep edges the two differ
    // by a few grey levels, elsewhere by at most one.
    EXPECT_LE(max_diff, 4.0);
    EXPECT_LT(cv::countNonZero(diff > 1), int(diff.total() / 200));
    EXPECT_GT(cv::countNonZero(pair.first), int(pair.first.total() / 2));
  }
  // The disparity of the device-rectified pair is that of the reference on the same rectified images.
  EXPECT_EQ(differences(out.disparity, sgmReference(dev0, dev1, p).left), 0);
  EXPECT_EQ(out.stages.front().name, "rectify");
}

TEST(StereoMatcher, FlatFieldLiftsTheCornersForMutualInformationAndNotForCensus) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  // A wide-angle pinhole head whose lenses have natural cos^4 vignetting (gain (1 + t)^2: 1.7 in the corners here):
  // the device's rectification for MI is rectifyPair's with the gains, within cv::remap's position rounding (times
  // the gain); census takes the plain remap.
  StereoCalibration calib;
  for (CameraIntrinsics* cam : {&calib.cam0, &calib.cam1}) {
    cam->width = 384;
    cam->height = 288;
    cam->K << 260, 0, 190, 0, 260, 146, 0, 0, 1;
    cam->vignetting_gain = Eigen::Vector3d(2, 1, 0);
  }
  calib.t_cam1_cam0 = Eigen::Vector3d(-0.2, 0, 0);
  const StereoRectification rect = computeRectification(calib, 0.0);
  ASSERT_TRUE(rect.hasFlatField());
  const cv::Mat raw0 = loadGrey("tsukuba", "left.png"), raw1 = loadGrey("tsukuba", "right.png");
  cv::Mat flat[2], plain[2];
  rectifyPair(rect, raw0, raw1, flat[0], flat[1]);
  StereoRectification without = rect;
  without.gain0 = without.gain1 = cv::Mat();
  rectifyPair(without, raw0, raw1, plain[0], plain[1]);
  const cv::Point corner(5, 5), centre(rect.size.width / 2, rect.size.height / 2);
  EXPECT_NEAR(rect.gain0.at<float>(centre), 1.0, 0.01);
  EXPECT_GT(rect.gain0.at<float>(corner), 1.6);
  for (Cost cost : {Cost::mi, Cost::census}) {
    SgmParams p = SgmParams::forCost(cost);
    p.num_disparities = 16;
    p.mi_levels = 2;
    StereoMatcher matcher(context(), rect.size, p);
    matcher.setRectification(rect, raw0.size());
    EXPECT_EQ(matcher.appliesFlatField(), cost == Cost::mi);
    cv::Mat device[2];
    matcher.matchRaw(raw0, raw1, &device[0], &device[1]);
    const cv::Mat* expected = cost == Cost::mi ? flat : plain;
    for (int c = 0; c < 2; ++c) {
      cv::Mat diff;
      cv::absdiff(expected[c], device[c], diff);
      double max_diff = 0;
      cv::minMaxLoc(diff, nullptr, &max_diff);
      EXPECT_LE(max_diff, 4.0 * 1.8) << "camera " << c << " cost " << static_cast<int>(cost);
      EXPECT_LT(cv::countNonZero(diff > 2), int(diff.total() / 200)) << "camera " << c;
    }
  }
  // The flat field made a difference worth testing: the corners' greys lifted.
  EXPECT_GT(cv::mean(flat[0](cv::Rect(0, 0, 40, 40)))[0], 1.3 * cv::mean(plain[0](cv::Rect(0, 0, 40, 40)))[0]);
}

TEST(StereoMatcher, BadInputThrows) {
  SgmParams p;
  p.num_disparities = 16;
  StereoMatcher matcher(context(), cv::Size(64, 32), p);
  cv::Mat a(32, 64, CV_8UC1, cv::Scalar(0)), wrong(31, 64, CV_8UC1), colour(32, 64, CV_8UC3);
  EXPECT_THROW(matcher.match(a, wrong), std::invalid_argument);
  EXPECT_THROW(matcher.match(a, colour), std::invalid_argument);
  EXPECT_THROW(matcher.match(cv::Mat(), a), std::invalid_argument);
  EXPECT_THROW(matcher.matchRaw(a, a), std::logic_error);
  SgmParams bad = p;
  bad.num_disparities = 300;
  EXPECT_THROW(StereoMatcher(context(), cv::Size(64, 32), bad), std::invalid_argument);
  bad = p;
  bad.p2 = 240;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
  bad = p;
  bad.paths = 6;
  EXPECT_THROW(sgmReference(a, a, bad), std::invalid_argument);
  EXPECT_THROW(parseAggregation("diagonal"), std::invalid_argument);
  EXPECT_THROW(parseRightMap("rows"), std::invalid_argument);
  EXPECT_THROW(parseCost("ssd"), std::invalid_argument);
  EXPECT_THROW(StereoMatcher(context(), cv::Size(5000, 10), p), std::invalid_argument);
  bad = p;
  bad.search = Search::narrowed;  // the CPU reference's only, so far
  EXPECT_THROW(StereoMatcher(context(), cv::Size(64, 32), bad), std::invalid_argument);
}

TEST(SgmParams, MutualInformationTakesThePenaltiesOfItsWindow) {
  const SgmParams window3 = SgmParams::forCost(Cost::mi), pixelwise = SgmParams::forCost(Cost::mi, 1);
  EXPECT_EQ(window3.mi_window, 3);
  EXPECT_EQ(pixelwise.mi_window, 1);
  EXPECT_LT(window3.p1, pixelwise.p1);                                // the mean of nine costs needs smaller penalties
  EXPECT_EQ(SgmParams::forCost(Cost::census, 1).p1, SgmParams().p1);  // the window is mi's alone
  // From census to mi keeps the window and takes its penalties.
  SgmParams census;
  census.mi_window = 1;
  EXPECT_EQ(census.withCost(Cost::mi).p1, pixelwise.p1);
  // A config without penalties takes those of its cost and window; given penalties win.
  const Config config(writeTempYaml("sgm_mi_window.yaml",
                                    "a: {cost: mi, mi_window: 1}\n"
                                    "b: {cost: mi, mi_window: 1, p1: 5}\n"
                                    "c: {cost: mi, mi_window: 2}\n"));
  const SgmParams a = SgmParams::fromConfig(config.section("a"));
  EXPECT_EQ(a.mi_window, 1);
  EXPECT_EQ(a.p1, pixelwise.p1);
  EXPECT_EQ(a.p2, pixelwise.p2);
  EXPECT_EQ(SgmParams::fromConfig(config.section("b")).p1, 5);
  EXPECT_THROW(SgmParams::fromConfig(config.section("c")), ConfigError);
}

TEST(SgmParams, MutualInformationLevelsTakeRegionsThatHoldEnoughPixels) {
  const SgmParams p = SgmParams::forCost(Cost::mi);  // 6 x 3 regions of at least 4096 pixels
  ASSERT_EQ(p.mi_region_columns, 6);
  ASSERT_EQ(p.mi_region_rows, 3);
  ASSERT_EQ(p.mi_region_min_pixels, 4096);
  // 640 x 480: regions of 106 x 160 px, at half resolution 53 x 80 = 4240 px, at a quarter 26 x 40.
  const SgmParams full = miLevelParams(p, 0, {640, 480}), half = miLevelParams(p, 1, {320, 240}),
                  quarter = miLevelParams(p, 2, {160, 120});
  EXPECT_EQ(full.mi_region_columns * full.mi_region_rows, 18);
  EXPECT_EQ(half.mi_region_columns * half.mi_region_rows, 18);
  EXPECT_EQ(quarter.mi_region_columns, 1);
  EXPECT_EQ(quarter.mi_region_rows, 1);
  EXPECT_EQ(half.num_disparities, 65);                      // and the level's range: [0, 127] / 2 -> [0, 64]
  const SgmParams small = miLevelParams(p, 0, {384, 190});  // 64 x 63 = 4032 px: one table
  EXPECT_EQ(small.mi_region_columns * small.mi_region_rows, 1);
}

// The tools' SGM options: --mi-window takes mi's penalties for that window, and leaves another cost's alone.
SgmParams paramsFromCommandLine(std::vector<std::string> words) {
  words.insert(words.begin(), "e3d_tool");
  std::vector<char*> argv;
  for (std::string& w : words) argv.push_back(w.data());
  Args args(static_cast<int>(argv.size()), argv.data(), "test");
  addSgmOptions(args);
  EXPECT_TRUE(args.parse());
  return sgmParamsFromArgs(args);
}

TEST(SgmOptions, MiWindowTakesTheMiPenaltiesOfThatWindowOnly) {
  const SgmParams pixelwise = SgmParams::forCost(Cost::mi, 1);
  const SgmParams mi1 = paramsFromCommandLine({"--cost", "mi", "--mi-window", "1"});
  EXPECT_EQ(mi1.mi_window, 1);
  EXPECT_EQ(mi1.p1, pixelwise.p1);
  EXPECT_EQ(mi1.p2, pixelwise.p2);
  EXPECT_EQ(paramsFromCommandLine({"--cost", "mi", "--mi-window", "1", "--p1", "5"}).p1, 5);  // given wins
  // A census configuration with its own penalties keeps them whatever the MI window.
  const std::string path = writeTempYaml("sgm_census_penalties.yaml", "sgm: {cost: census, p1: 9, p2: 60}\n");
  const SgmParams census = paramsFromCommandLine({"--config", path, "--mi-window", "1"});
  EXPECT_EQ(census.cost, Cost::census);
  EXPECT_EQ(census.mi_window, 1);
  EXPECT_EQ(census.p1, 9);
  EXPECT_EQ(census.p2, 60);
}

TEST(StereoMatcher, FillInvalidEqualsReferenceAndLeavesNoHoles) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  cv::Mat left = loadGrey("cones", "left.png"), right = loadGrey("cones", "right.png");
  SgmParams p;
  p.num_disparities = 64;
  p.fill_invalid = true;
  StereoMatcher matcher(context(), left.size(), p);
  MatchOutput gpu = matcher.match(left, right);
  SgmResult ref = sgmReference(left, right, p);
  EXPECT_EQ(differences(gpu.disparity, ref.left), 0);
  p.aggregation = Aggregation::lines;
  EXPECT_EQ(differences(StereoMatcher(context(), left.size(), p).match(left, right).disparity, ref.left), 0);
  p.aggregation = Aggregation::automatic;
  EXPECT_EQ(cv::countNonZero(gpu.disparity == kInvalidDisparity), 0);
  // Filling only changes invalid pixels: the valid ones are those of the unfilled map.
  p.fill_invalid = false;
  cv::Mat unfilled = sgmReference(left, right, p).left;
  cv::Mat was_valid = unfilled != kInvalidDisparity;
  EXPECT_EQ(cv::countNonZero((gpu.disparity != unfilled) & was_valid), 0);
  EXPECT_GT(cv::countNonZero(unfilled == kInvalidDisparity), 1000);
}

// ---- Matching costs other than census (ips/e3d/matching_cost.hpp) ----

TEST(MatchingCost, AdAndSadByTheirDefinitions) {
  cv::Mat left(20, 30, CV_8UC1), right(20, 30, CV_8UC1);
  cv::RNG rng(3);
  rng.fill(left, cv::RNG::UNIFORM, 0, 256);
  rng.fill(right, cv::RNG::UNIFORM, 0, 256);
  SgmParams p = SgmParams::forCost(Cost::ad);
  p.num_disparities = 6;
  p.min_disparity = 2;
  std::vector<uint8_t> ad = costVolume(left, right, p);
  p.cost = Cost::sad;
  std::vector<uint8_t> sad = costVolume(left, right, p);
  auto clampc = [](int v, int hi) { return std::min(std::max(v, 0), hi); };
  for (int y : {0, 7, 19})
    for (int x : {0, 1, 5, 29})
      for (int k = 0; k < 6; ++k) {
        const int d = 2 + k;
        const size_t i = (static_cast<size_t>(y) * 30 + x) * 6 + k;
        EXPECT_EQ(ad[i], std::min(63, std::abs(left.at<uint8_t>(y, x) - right.at<uint8_t>(y, clampc(x - d, 29)))));
        int sum = 0;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx)
            sum += std::abs(left.at<uint8_t>(clampc(y + dy, 19), clampc(x + dx, 29)) -
                            right.at<uint8_t>(clampc(y + dy, 19), clampc(x + dx - d, 29)));
        EXPECT_EQ(sad[i], std::min(63, (sum + 4) / 9));
      }
}

TEST(MatchingCost, Log2InQuarterBitsIsWithinItsResolution) {
  for (uint64_t v : {1ull, 2ull, 3ull, 255ull, 256ull, 257ull, 1000ull, 65535ull, 123456789ull, 1ull << 40})
    EXPECT_NEAR(log2q8(v) / 256.0, std::log2(static_cast<double>(v)), 1.0 / 128) << v;
  EXPECT_EQ(log2q8(1024), 10 * 256);
}

TEST(MatchingCost, MutualInformationTableFollowsTheGreyMappingOfThePair) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  // The right image is the left one darkened (gain 0.5) at disparity 0: the table must be cheapest where the right
  // grey is half the left grey, which no difference cost would find.
  cv::Mat left = loadGrey("teddy", "left.png");
  cv::Mat right;
  left.convertTo(right, CV_8U, 0.5);
  const cv::Mat zero(left.size(), CV_16S, cv::Scalar(0));
  const cv::Mat table = miTable(left, right, zero);
  int good = 0, rows = 0;
  for (int i = 40; i < 220; i += 5) {
    double lowest = 0;
    cv::Point at;
    cv::minMaxLoc(table.row(i), &lowest, nullptr, &at, nullptr);
    ++rows;
    good += std::abs(at.x - i / 2) <= 2;
    // A right grey that occurs (the right image reaches 127), but never with this left grey, costs far more.
    if (i / 2 + 40 <= 120) {
      EXPECT_GE(table.at<uint8_t>(i, i / 2 + 40), table.at<uint8_t>(i, i / 2) + 20) << i;
    }
  }
  EXPECT_GT(good, rows * 9 / 10);
  // With no matched pixel at all, a uniform table.
  const cv::Mat none(left.size(), CV_16S, cv::Scalar(kInvalidDisparity));
  double lo = 0, hi = 0;
  cv::minMaxLoc(miTable(left, right, none), &lo, &hi);
  EXPECT_EQ(lo, hi);
}

TEST(StereoMatcher, AdAndSadEqualReference) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  cv::Mat left = loadGrey("cones", "left.png")(cv::Rect(60, 40, 240, 150)).clone();
  cv::Mat right = loadGrey("cones", "right.png")(cv::Rect(60, 40, 240, 150)).clone();
  for (const char* cost : {"ad", "sad"}) {
    SgmParams p = SgmParams::forCost(parseCost(cost));
    p.num_disparities = 56;
    p.min_disparity = 2;
    expectDeviceEqualsReference(left, right, p);
    p.right_map = RightMap::match;
    p.paths = 4;
    expectDeviceEqualsReference(left, right, p);
  }
}

TEST(StereoMatcher, MutualInformationHierarchyEqualsReference) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  cv::Mat left = loadGrey("teddy", "left.png")(cv::Rect(30, 50, 300, 180)).clone();
  cv::Mat right = loadGrey("teddy", "right.png")(cv::Rect(30, 50, 300, 180)).clone();
  SgmParams p = SgmParams::forCost(Cost::mi);
  p.num_disparities = 60;
  p.mi_levels = 3;
  expectDeviceEqualsReference(left, right, p);  // the 3x3 window, the default
  p.mi_window = 1;                              // pixelwise, Hirschmueller's
  expectDeviceEqualsReference(left, right, p);
  p.mi_window = 3;
  const SgmParams defaults = p;
  p.mi_region_columns = 5;  // regions on every level, an uneven grid (300 / 5, 180 / 2 at the full resolution)
  p.mi_region_rows = 2;
  p.mi_region_min_pixels = 0;
  expectDeviceEqualsReference(left, right, p);
  p.mi_region_min_pixels = 2000;  // the full resolution's regions (60 x 90 px) only, one table below (30 x 45)
  expectDeviceEqualsReference(left, right, p);
  p.mi_region_columns = p.mi_region_rows = 1;  // one table per level
  expectDeviceEqualsReference(left, right, p);
  p = defaults;
  p.mi_levels = 1;  // the full resolution only, learning from the start disparity and then from itself
  p.mi_coarse_iterations = 3;
  p.right_map = RightMap::match;  // its regions mirrored with the images
  p.mi_region_min_pixels = 0;
  p.fill_invalid = true;
  expectDeviceEqualsReference(left, right, p);
}

// Bad 2.0 % of a CV_16S map of cones against its ground truth (all pixels with one, invalid counted as bad).
double conesBad2(const cv::Mat& d16) {
  const cv::Mat gt = cv::imread(ips::dataDir() + "/stereo/cones/disp_gt.png", cv::IMREAD_GRAYSCALE);
  int bad = 0, n = 0;
  for (int y = 0; y < gt.rows; ++y)
    for (int x = 0; x < gt.cols; ++x) {
      if (gt.at<uint8_t>(y, x) == 0) continue;
      ++n;
      const int v = d16.at<int16_t>(y, x);
      bad += v == kInvalidDisparity || std::abs(v / 16.0 - gt.at<uint8_t>(y, x) / 4.0) > 2.0;
    }
  return 100.0 * bad / n;
}

TEST(StereoMatcher, MutualInformationRegionsFollowVignetting) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  // The right image 40 % darker towards its corners (the illumination falling with the distance to the centre, as
  // a lens's vignetting): the grey relation between the images changes across the image, which one table cannot
  // follow and a table per region can.
  const cv::Mat left = loadGrey("cones", "left.png"), right = loadGrey("cones", "right.png");
  cv::Mat vignetted(right.size(), CV_8UC1);
  const double cx = (right.cols - 1) / 2.0, cy = (right.rows - 1) / 2.0, r2max = cx * cx + cy * cy;
  for (int y = 0; y < right.rows; ++y)
    for (int x = 0; x < right.cols; ++x)
      vignetted.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(
          right.at<uint8_t>(y, x) * (1.0 - 0.4 * ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / r2max));
  SgmParams regions = SgmParams::forCost(Cost::mi);
  regions.num_disparities = 64;
  SgmParams one_table = regions;
  one_table.mi_region_columns = one_table.mi_region_rows = 1;
  const double with_regions =
      conesBad2(StereoMatcher(context(), left.size(), regions).match(left, vignetted).disparity);
  const double with_one_table =
      conesBad2(StereoMatcher(context(), left.size(), one_table).match(left, vignetted).disparity);
  std::cout << "vignetted cones, bad 2.0 %: " << regions.mi_region_columns << "x" << regions.mi_region_rows
            << " regions " << with_regions << ", one table " << with_one_table << "\n";
  EXPECT_LT(with_regions, with_one_table - 2.0);
}

TEST(StereoMatcher, MutualInformationAndCensusHoldWhereTheRightImageIsDarkerAndAdDoesNot) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  // Radiometric robustness, the reason MI and census exist: gain 0.6 and gamma 1.3 on the right image.
  cv::Mat left = loadGrey("cones", "left.png"), right = loadGrey("cones", "right.png");
  cv::Mat changed(right.size(), CV_8UC1);
  for (int y = 0; y < right.rows; ++y)
    for (int x = 0; x < right.cols; ++x)
      changed.at<uint8_t>(y, x) =
          cv::saturate_cast<uint8_t>(0.6 * 255.0 * std::pow(right.at<uint8_t>(y, x) / 255.0, 1.3));
  std::map<std::string, double> growth;
  for (const char* cost : {"census", "mi", "ad"}) {
    SgmParams p = SgmParams::forCost(parseCost(cost));
    p.num_disparities = 64;
    p.fill_invalid = true;
    StereoMatcher matcher(context(), left.size(), p);
    const double before = conesBad2(matcher.match(left, right).disparity);
    const double after = conesBad2(matcher.match(left, changed).disparity);
    growth[cost] = after - before;
  }
  EXPECT_LT(growth["census"], 2.0);
  EXPECT_LT(growth["mi"], 3.0);
  EXPECT_GT(growth["ad"], 10.0);
}
