// Intra-matching taken from E3D's disparity map (matchWithDisparity) against the tracker's own row search
// (matchAlongRows) and against the simulator's true disparity, on rendered pairs of the default walk; E3D is the
// e3d process's matcher on Vulkan (lavapipe here) at the deployment's half resolution (config/e3d_sim.yaml).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "ips/eval/e3d_guide.hpp"
#include "ips/sim/rig.hpp"
#include "ips/tracker/params.hpp"
#include "ips/tracker/stereo_tracker.hpp"

using namespace ips::tracker;

namespace {

// The default simulated walk.
struct Walk : ips::sim::Rig {
  Walk() : Rig(ips::sim::Scenario::defaults()) {}
};

const TrackerParams& deployedParams() {
  static const TrackerParams p = loadTrackerParams(std::string(IPS_SOURCE_DIR) + "/config/tracker.yaml");
  return p;
}

// |measured - true| disparity of each feature [px]; features where the truth sees nothing are left out.
std::vector<double> disparityErrors(const StereoFeatures& f, const cv::Mat& gt) {
  std::vector<double> e;
  for (size_t i = 0; i < f.size(); ++i) {
    const float d = gt.at<float>(f.y[i], f.xl[i]);
    if (d > 0) e.push_back(std::abs((f.xl[i] - f.xr[i]) - d));
  }
  std::sort(e.begin(), e.end());
  return e;
}

double shareBelow(const std::vector<double>& e, double limit) {
  return e.empty() ? 0.0 : double(std::lower_bound(e.begin(), e.end(), limit) - e.begin()) / e.size();
}

}  // namespace

TEST(GuidedIntraMatching, AgreesWithTheRowSearchAndTheTruthOnSimulatedPairs) {
  static Walk w;
  StereoTracker tracker(w.head.calibration, deployedParams());
  ips::eval::E3dGuide e3d(w.head.calibration, std::string(IPS_SOURCE_DIR) + "/config/e3d_sim.yaml",
                          tracker.rectification());
  const MatcherParams& mp = deployedParams().matcher;
  const int margin = deployedParams().detector.border + mp.ncc_half_window + 1;
  size_t own_total = 0, guided_total = 0, common = 0, same_column = 0;
  std::vector<double> own_err, guided_err;
  // Frames across the walk (8 Hz): the start, corridors, a turn.
  for (int64_t k : {40, 200, 420, 640}) {
    const ips::sim::StereoFrame f = w.renderer.render(k, true);
    tracker.process(f.utime_stamp, f.left, f.right);
    const cv::Mat& left = tracker.rectifiedLeft();
    const cv::Mat& right = tracker.rectifiedRight();
    const std::vector<Corner> corners = detectCorners(left, deployedParams().detector, margin);
    const StereoFeatures own = matchAlongRows(left, right, corners, mp);
    std::vector<Corner> unguided;
    GuidedIntraCounts counts;
    StereoFeatures guided =
        matchWithDisparity(left, right, corners, e3d.match(f.left, f.right), mp, &unguided, &counts);
    EXPECT_EQ(counts.from_map, int(guided.size()));
    EXPECT_EQ(counts.map_invalid, int(unguided.size()));
    // E3D has a disparity at most corners (its invalid pixels are occlusions and mismatches).
    EXPECT_GT(counts.from_map, int(0.8 * corners.size())) << "frame " << k;
    appendFeatures(guided, matchAlongRows(left, right, unguided, mp));
    own_total += own.size();
    guided_total += guided.size();
    // Where both matched a corner, the same correlation peak gives the same column.
    for (size_t i = 0; i < guided.size(); ++i)
      for (size_t j = 0; j < own.size(); ++j)
        if (own.xl[j] == guided.xl[i] && own.y[j] == guided.y[i]) {
          ++common;
          same_column += own.xr[j] == guided.xr[i];
        }
    const cv::Mat& gt = f.gt_disparity;
    for (double e : disparityErrors(own, gt)) own_err.push_back(e);
    for (double e : disparityErrors(guided, gt)) guided_err.push_back(e);
  }
  std::sort(own_err.begin(), own_err.end());
  std::sort(guided_err.begin(), guided_err.end());
  ASSERT_GT(own_err.size(), 500u);
  ASSERT_GT(guided_err.size(), 500u);
  const double own_med = own_err[own_err.size() / 2], guided_med = guided_err[guided_err.size() / 2];
  std::printf(
      "[ E3D-AIDED ] matches own %zu, from the map %zu; same column %zu of %zu; |d - d_true| median own %.3f "
      "px, map %.3f px; within 1 px own %.1f %%, map %.1f %%\n",
      own_total, guided_total, same_column, common, own_med, guided_med, 100 * shareBelow(own_err, 1.0),
      100 * shareBelow(guided_err, 1.0));
  // As many matches (the row search's uniqueness and left-right tests drop repetitive texture the map resolves),
  EXPECT_GE(guided_total, own_total * 95 / 100);
  // the same peak where both matched,
  EXPECT_GE(same_column, common * 95 / 100);
  // and as close to the truth: the median within 0.02 px, gross errors (> 1 px) no more frequent.
  EXPECT_LT(guided_med, own_med + 0.02);
  EXPECT_GE(shareBelow(guided_err, 1.0), shareBelow(own_err, 1.0) - 0.005);
}

TEST(GuidedIntraMatching, CornersWithoutADisparityGoToTheRowSearch) {
  static Walk w;
  StereoTracker tracker(w.head.calibration, deployedParams());
  const ips::sim::StereoFrame f = w.renderer.render(200);
  tracker.process(f.utime_stamp, f.left, f.right);
  const MatcherParams& mp = deployedParams().matcher;
  const std::vector<Corner> corners =
      detectCorners(tracker.rectifiedLeft(), deployedParams().detector, deployedParams().detector.border + 6);
  ASSERT_GT(corners.size(), 100u);
  DisparityGuide empty;
  empty.scale = 0.5;
  empty.invalid_value = -16;
  const cv::Size half((tracker.rectifiedLeft().cols + 1) / 2, (tracker.rectifiedLeft().rows + 1) / 2);
  empty.disparity = cv::Mat(half, CV_16SC1, cv::Scalar(empty.invalid_value));
  std::vector<Corner> unguided;
  GuidedIntraCounts counts;
  const StereoFeatures none =
      matchWithDisparity(tracker.rectifiedLeft(), tracker.rectifiedRight(), corners, empty, mp, &unguided, &counts);
  EXPECT_EQ(none.size(), 0u);
  EXPECT_EQ(unguided.size(), corners.size());
  EXPECT_EQ(counts.map_invalid, int(corners.size()));
  // The tracker given that map matches exactly as without one.
  StereoTracker a(w.head.calibration, deployedParams()), b(w.head.calibration, deployedParams());
  const TrackResult ra = a.process(f.utime_stamp, f.left, f.right);
  const TrackResult rb = b.process(f.utime_stamp, f.left, f.right, nullptr, &empty);
  EXPECT_TRUE(rb.intra_guided);
  EXPECT_EQ(ra.num_intra_matches, rb.num_intra_matches);
  EXPECT_EQ(a.features().xr, b.features().xr);
}

TEST(GuidedIntraMatching, AWrongMapFailsTheCorrelationCheck) {
  // A map whose disparities are all 6 px off (a map of another pair, a bad calibration): the correlation
  // within the search range has its peak on the range's edge, and the corner is dropped, not matched wrongly.
  static Walk w;
  StereoTracker tracker(w.head.calibration, deployedParams());
  const ips::sim::StereoFrame f = w.renderer.render(200, true);
  tracker.process(f.utime_stamp, f.left, f.right);
  const MatcherParams& mp = deployedParams().matcher;
  const std::vector<Corner> corners =
      detectCorners(tracker.rectifiedLeft(), deployedParams().detector, deployedParams().detector.border + 6);
  DisparityGuide wrong;
  wrong.scale = 1.0;
  wrong.subpixel_scale = 16;
  wrong.invalid_value = -16;
  cv::Mat d = f.gt_disparity + 6.0;
  d.setTo(0, f.gt_disparity <= 0);
  d.convertTo(wrong.disparity, CV_16SC1, 16.0);
  GuidedIntraCounts counts;
  std::vector<Corner> unguided;
  const StereoFeatures m =
      matchWithDisparity(tracker.rectifiedLeft(), tracker.rectifiedRight(), corners, wrong, mp, &unguided, &counts);
  const int checked = counts.from_map + counts.check_failed;
  ASSERT_GT(checked, 100);
  EXPECT_GT(counts.check_failed, checked * 9 / 10);
  // What passed lies on another peak 6 px away: never within the map's own tolerance of the truth.
  for (double e : disparityErrors(m, f.gt_disparity)) EXPECT_GT(e, 4.0);
}

TEST(GuidedIntraMatching, OnlyAMapOfTheTrackersRectificationIsTaken) {
  static Walk w;
  StereoTracker tracker(w.head.calibration, deployedParams());
  const ips::StereoRectification& r = tracker.rectification();
  const ips::StereoRectification half = ips::scaledRectification(w.head.calibration, 0.5);
  const auto s = guideScale(r, half.f, half.cx, half.cy, half.baseline, half.size);
  ASSERT_TRUE(s.has_value());
  EXPECT_NEAR(*s, 0.5, 1e-3);
  EXPECT_FALSE(guideScale(r, half.f, half.cx + 0.5, half.cy, half.baseline, half.size));
  EXPECT_FALSE(guideScale(r, half.f, half.cx, half.cy, 1.01 * half.baseline, half.size));
  EXPECT_FALSE(guideScale(r, half.f, half.cx, half.cy, half.baseline, r.size));
  // Another alpha moves the principal point: a map rectified with alpha 1 is not the tracker's.
  const ips::StereoRectification alpha1 = ips::computeRectification(w.head.calibration, 1.0);
  EXPECT_FALSE(guideScale(r, alpha1.f, alpha1.cx, alpha1.cy, alpha1.baseline, alpha1.size));
}
