// NCC matching: intra-matching along rows against Middlebury ground-truth disparities, inter-matching
// between times on textured-plane stereo images (plane homographies of a real image) against the exact
// image motion of each point.
#include <gtest/gtest.h>

#include <algorithm>
#include <opencv2/imgcodecs.hpp>

#include "ips/tracker/matching.hpp"
#include "test_util.hpp"

using namespace ips::tracker;

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

}  // namespace

TEST(Matching, PatchNormalisation) {
  cv::Mat img(40, 40, CV_8UC1);
  cv::randu(img, 0, 255);
  std::vector<float> a(121), b(121);
  ASSERT_TRUE(normalizedPatch(img, 20, 20, 5, 1.0, a.data()));
  EXPECT_NEAR(patchDot(a.data(), a.data(), 121), 1.0, 1e-5);
  // Gain and offset (an exposure change) do not change a normalised template.
  cv::Mat brighter;
  img.convertTo(brighter, CV_8UC1, 0.5, 60);
  ASSERT_TRUE(normalizedPatch(brighter, 20, 20, 5, 1.0, b.data()));
  EXPECT_GT(patchDot(a.data(), b.data(), 121), 0.995);
  // Flat or out-of-image windows are refused.
  EXPECT_FALSE(normalizedPatch(cv::Mat(40, 40, CV_8UC1, cv::Scalar(9)), 20, 20, 5, 1.0, a.data()));
  EXPECT_FALSE(normalizedPatch(img, 3, 20, 5, 1.0, a.data()));
  EXPECT_FALSE(normalizedPatch(img, 20, 36, 5, 1.0, a.data()));
}

// Left-right matches on rows of a rectified real pair against the ground truth.
TEST(Matching, IntraMatchingAgreesWithMiddleburyGroundTruth) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  for (const char* scene : {"cones", "teddy"}) {
    const std::string dir = test::dataDir() + "/stereo/" + scene + "/";
    const cv::Mat left = cv::imread(dir + "left.png", cv::IMREAD_GRAYSCALE);
    const cv::Mat right = cv::imread(dir + "right.png", cv::IMREAD_GRAYSCALE);
    const cv::Mat gt = cv::imread(dir + "disp_gt.png", cv::IMREAD_GRAYSCALE);  // disparity * 4, 0 unknown
    const cv::Mat nonocc = cv::imread(dir + "mask_nonocc.png", cv::IMREAD_GRAYSCALE);
    const cv::Mat disc = cv::imread(dir + "mask_disc.png", cv::IMREAD_GRAYSCALE);  // 255: near a depth edge
    ASSERT_FALSE(left.empty());
    DetectorParams dp;
    MatcherParams mp;
    mp.min_disparity = 1;
    mp.max_disparity = 63;  // the scene's search range 0..63
    const auto corners = detectCorners(left, dp, 12);
    const StereoFeatures f = matchAlongRows(left, right, corners, mp);
    // A window that straddles a depth edge measures its dominant side, not necessarily the centre pixel's
    // (and Harris likes such places): judged separately.
    std::vector<double> err, err_smooth;
    for (size_t i = 0; i < f.size(); ++i) {
      if (nonocc.at<uint8_t>(f.y[i], f.xl[i]) != 255 || gt.at<uint8_t>(f.y[i], f.xl[i]) == 0) continue;
      err.push_back(std::abs((f.xl[i] - f.xr[i]) - gt.at<uint8_t>(f.y[i], f.xl[i]) / 4.0));
      if (disc.at<uint8_t>(f.y[i], f.xl[i]) != 255) err_smooth.push_back(err.back());
    }
    ASSERT_GT(err.size(), 0.3 * corners.size()) << scene;
    const double bad1 = std::count_if(err.begin(), err.end(), [](double e) { return e > 1.0; }) / double(err.size());
    const double bad3 = std::count_if(err.begin(), err.end(), [](double e) { return e > 3.0; }) / double(err.size());
    const double bad1_smooth = std::count_if(err_smooth.begin(), err_smooth.end(), [](double e) { return e > 1.0; }) /
                               double(err_smooth.size());
    std::printf("[ INTRA    ] %s: bad>3px %.1f %%; away from depth edges (%zu): bad>1px %.1f %%\n", scene, 100 * bad3,
                err_smooth.size(), 100 * bad1_smooth);
    EXPECT_LT(bad1_smooth, 0.05) << scene;
    EXPECT_LT(bad3, 0.10) << scene;
    std::printf("[ INTRA    ] %s: %zu corners, %zu matches, %zu evaluated, bad>1px %.1f %%, median error %.3f px\n",
                scene, corners.size(), f.size(), err.size(), 100 * bad1, median(err));
    EXPECT_LT(bad1, 0.15) << scene;
    EXPECT_LT(median(err), 0.25) << scene;  // ground truth is quantised to 1/4 px
    for (size_t i = 0; i < f.size(); ++i) {
      EXPECT_GE(f.ncc[i], mp.intra_min_ncc);
      EXPECT_LE(std::abs(f.xr[i] - f.xr_int[i]), 0.5f);
    }
  }
}

TEST(Matching, IntraMatchingRejectsBadInput) {
  MatcherParams mp;
  cv::Mat a(50, 60, CV_8UC1, cv::Scalar(3)), b(50, 61, CV_8UC1, cv::Scalar(3));
  EXPECT_THROW(matchAlongRows(a, b, {}, mp), std::invalid_argument);
  EXPECT_THROW(matchAlongRows(a, cv::Mat(), {}, mp), std::invalid_argument);
  mp.max_disparity = mp.min_disparity - 1;  // an empty range
  EXPECT_THROW(matchAlongRows(a, a, {}, mp), std::invalid_argument);
}

// A textured plane seen by a rectified stereo pair at two times with a known motion: every matched point's
// position in the newer pair is known exactly (ray - plane intersection, then projection).
TEST(Matching, InterMatchingFollowsKnownPlaneMotion) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  const int w = 640, h = 480;
  const double f = 500, baseline = 0.12;
  test::TexturedPlane plane;
  plane.texture = test::realTexture(w, h);
  plane.K << f, 0, w / 2.0, 0, f, h / 2.0, 0, 0, 1;
  plane.n = Eigen::Vector3d(0.2, -0.1, 1).normalized();
  plane.d = 3.0;
  RectifiedStereo cam;
  cam.f = f;
  cam.cx = w / 2.0;
  cam.cy = h / 2.0;
  cam.baseline = baseline;
  RigidMotion motion;  // X_prev = R X_now + t
  motion.R = expSO3(Eigen::Vector3d(0.01, -0.03, 0.005));
  motion.t = Eigen::Vector3d(0.08, 0.02, 0.15);
  const Eigen::Vector3d right_offset(baseline, 0, 0);
  const cv::Mat l0 = plane.render(Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
  const cv::Mat r0 = plane.render(Eigen::Matrix3d::Identity(), right_offset);
  const cv::Mat l1 = plane.render(motion.R, motion.t);
  const cv::Mat r1 = plane.render(motion.R, motion.R * right_offset + motion.t);

  DetectorParams dp;
  MatcherParams mp;
  const StereoFeatures f0 = matchAlongRows(l0, r0, detectCorners(l0, dp, 12), mp);
  const StereoFeatures f1 = matchAlongRows(l1, r1, detectCorners(l1, dp, 12), mp);
  ASSERT_GT(f0.size(), 100u);
  // Predictions from the true motion, through each feature's own (measured) depth.
  std::vector<Prediction> pred(f0.size());
  for (size_t i = 0; i < f0.size(); ++i) {
    const Eigen::Vector3d p = motion.R.transpose() * (cam.triangulate(f0.xl[i], f0.y[i], f0.xr[i]) - motion.t);
    const Eigen::Vector3d uv = cam.project(p);
    pred[i] = {uv(0), uv(1), uv(2), 6.0};
  }
  const std::vector<InterMatch> m = matchBetweenTimes(f0, f1, pred, l1, r1, mp);
  ASSERT_GT(m.size(), f0.size() / 3);
  std::vector<double> err_l, err_r;
  int ok = 0;
  for (const InterMatch& im : m) {
    // Exact: the ray of the older left pixel meets the plane; that point seen by the newer pair.
    const Eigen::Vector3d ray = plane.K.inverse() * Eigen::Vector3d(im.prev_obs.xl, im.prev_obs.y, 1.0);
    const Eigen::Vector3d X0 = ray * (plane.d / plane.n.dot(ray));
    const Eigen::Vector3d uv = cam.project(motion.R.transpose() * (X0 - motion.t));
    err_l.push_back(std::hypot(im.now_obs.xl - uv(0), im.now_obs.y - uv(1)));
    err_r.push_back(std::abs(im.now_obs.xr - uv(2)));
    ok += im.prediction_ok;
  }
  const double within = std::count_if(err_l.begin(), err_l.end(), [](double e) { return e < 0.5; }) / double(m.size());
  std::vector<double> sorted = err_l;
  std::sort(sorted.begin(), sorted.end());
  std::printf("[ INTER    ] p90 %.3f p95 %.3f p99 %.3f max %.3f\n", sorted[sorted.size() * 9 / 10],
              sorted[sorted.size() * 95 / 100], sorted[sorted.size() * 99 / 100], sorted.back());
  std::printf("[ INTER    ] %zu of %zu features matched; median error left %.3f px, right %.3f px; %.1f %% < 0.5 px\n",
              m.size(), f0.size(), median(err_l), median(err_r), 100 * within);
  EXPECT_LT(median(err_l), 0.2);
  EXPECT_LT(median(err_r), 0.2);
  // The plane comes 5 % closer and turns: templates deform, which costs some subpixel accuracy.
  EXPECT_GT(within, 0.85);
  EXPECT_LT(sorted[sorted.size() * 99 / 100], 1.5);
  EXPECT_GT(ok, int(0.95 * m.size()));  // the true motion predicts within prior_ok_px
  // One match per newer feature.
  std::vector<int> used(f1.size(), 0);
  for (const InterMatch& im : m) EXPECT_EQ(++used[im.now], 1);
}

TEST(Matching, InterMatchingFindsNothingOutsideAWrongWindow) {
  IPS_REQUIRE_SHARED_DATA("stereo");
  const int w = 640, h = 480;
  test::TexturedPlane plane;
  plane.texture = test::realTexture(w, h);
  plane.K << 500, 0, w / 2.0, 0, 500, h / 2.0, 0, 0, 1;
  const cv::Mat l0 = plane.render(Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
  const cv::Mat r0 = plane.render(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.12, 0, 0));
  DetectorParams dp;
  MatcherParams mp;
  const StereoFeatures f0 = matchAlongRows(l0, r0, detectCorners(l0, dp, 12), mp);
  ASSERT_GT(f0.size(), 50u);
  // The same pair again, but every window placed 60 px off: correct matches are out of reach.
  std::vector<Prediction> pred(f0.size());
  for (size_t i = 0; i < f0.size(); ++i) pred[i] = {f0.xl[i] + 60.0, double(f0.y[i]), f0.xr[i] + 60.0, 6.0};
  const auto m = matchBetweenTimes(f0, f0, pred, l0, r0, mp);
  EXPECT_LT(m.size(), f0.size() / 10);
  for (size_t i = 0; i < f0.size(); ++i) pred[i] = {double(f0.xl[i]), double(f0.y[i]), f0.xr[i], 6.0};
  EXPECT_GT(matchBetweenTimes(f0, f0, pred, l0, r0, mp).size(), 0.9 * f0.size());
}

// Repeated texture (a fence, tiles): along the row every period looks the same, so the uniqueness test must
// refuse those corners rather than pick a wrong disparity; the textured rest still matches.
TEST(Matching, RepeatedTextureIsRefusedNotMismatched) {
  const int w = 480, h = 240, disparity = 7, period = 12;
  cv::Mat scene(h, w + disparity, CV_8UC1);
  cv::Mat noise(h, w + disparity, CV_8UC1);
  cv::randu(noise, 0, 255);
  cv::GaussianBlur(noise, scene, cv::Size(0, 0), 1.2);
  for (int y = 0; y < h / 2; ++y)  // upper half: a periodic pattern of blobs
    for (int x = 0; x < w + disparity; ++x) {
      const double v = std::sin(2 * M_PI * x / period) * std::sin(2 * M_PI * y / period);
      scene.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(128 + 100 * v);
    }
  // A fronto-parallel scene: right pixel x - d shows what left pixel x shows.
  const cv::Mat left = scene(cv::Rect(0, 0, w, h)).clone();
  const cv::Mat right = scene(cv::Rect(disparity, 0, w, h)).clone();
  DetectorParams dp;
  MatcherParams mp;
  mp.max_disparity = 48;
  const auto corners = detectCorners(left, dp, 12);
  int corners_top = 0;
  for (const Corner& c : corners) corners_top += c.yi < h / 2 - 8;
  ASSERT_GT(corners_top, 20);  // the pattern is full of corners
  const StereoFeatures f = matchAlongRows(left, right, corners, mp);
  int top = 0, bottom = 0;
  for (size_t i = 0; i < f.size(); ++i) {
    EXPECT_NEAR(f.xl[i] - f.xr[i], disparity, 0.5) << "at " << f.xl[i] << "," << f.y[i] << ": " << f.xl[i] - f.xr[i];
    (f.y[i] < h / 2 - 8 ? top : bottom)++;
  }
  std::printf("[ REPEAT   ] %d corners on the pattern, %d matched there; %d matches in the random half\n", corners_top,
              top, bottom);
  EXPECT_GT(bottom, 50);
}
