// The mapper's library against the simulator's ground truth and analytic results: points of a true disparity
// map placed with the true pose lie on the world's surfaces (and a wrong pose is seen); the pose buffer
// interpolates and says when it cannot; the range cut follows the depth precision; the voxel map fuses,
// stays within its bound and round-trips through PLY and PCD.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <filesystem>

#include "ips/eval/map_errors.hpp"
#include "ips/mapper/cloud_odometry.hpp"
#include "ips/mapper/params.hpp"
#include "ips/mapper/stereo_points.hpp"
#include "ips/mapper/voxel_map.hpp"
#include "ips/rotation.hpp"
#include "ips/sim/rig.hpp"

using namespace ips::mapper;

namespace {

const ips::sim::Rig& simHead() {
  static const ips::sim::Rig h(ips::sim::Scenario::defaults());
  return h;
}

// The simulator's true disparity of the rectified left image at time t, with its camera.
DisparityImage trueDisparity(double t) {
  const auto& h = simHead();
  DisparityImage img;
  img.disparity = h.renderer.disparityFromDepth(h.renderer.rectifiedDepth(t, 0));
  const auto& rect = h.renderer.rectification();
  img.focal_px = rect.f, img.cx = rect.cx, img.cy = rect.cy, img.baseline_m = rect.baseline;
  return img;
}

HeadGeometry trueGeometry() {
  HeadGeometry g;
  g.R_rect0_cam0 = simHead().renderer.rectification().R_rect0_cam0;
  g.T_body_cam0 = simHead().head.calibration.T_imu_cam0;
  return g;
}

}  // namespace

TEST(MapperGeometry, TrueDisparityWithTheTruePoseLiesOnTheWorldsSurfaces) {
  MapperParams params;
  params.pixel_step = 4;
  for (double t : {10.0, 45.0, 80.0}) {
    const Eigen::Isometry3d T_world_body = simHead().trajectory.pose(t);
    const PointSet set = triangulate(trueDisparity(t), trueGeometry(), T_world_body, params);
    ASSERT_GT(set.points.size(), 1000u) << "t = " << t;
    const ips::eval::SurfaceErrors e = ips::eval::surfaceErrors(set.points, simHead().world);
    // Exact disparity and pose: only the rendering's depth sampling remains (millimetres).
    EXPECT_LT(e.median_m, 0.003) << "t = " << t;
    EXPECT_LT(e.p90_m, 0.01) << "t = " << t;
    EXPECT_GT(e.within_pct, 99.0) << "t = " << t;
    for (const auto& p : set.points)
      ASSERT_LE((p - T_world_body.translation()).norm(), set.max_range_m + 1.0) << "a point beyond the range cut";

    // The same points with the head 10 cm off and turned 2 degrees: the check sees it.
    Eigen::Isometry3d wrong = T_world_body;
    wrong.translation() += Eigen::Vector3d(0.1, 0, 0);
    wrong.linear() = Eigen::AngleAxisd(2 * M_PI / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix() * wrong.linear();
    const ips::eval::SurfaceErrors off =
        ips::eval::surfaceErrors(triangulate(trueDisparity(t), trueGeometry(), wrong, params).points, simHead().world);
    EXPECT_GT(off.median_m, 0.03) << "t = " << t;
  }
}

TEST(MapperGeometry, RangeCutFollowsTheDepthPrecision) {
  MapperParams params;
  params.disparity_sigma_px = 0.25;
  params.max_depth_sigma_m = 0.10;
  params.pixel_step = 1;
  // f 500 px, b 0.2 m: sigma_z = z^2 0.25 / 100 reaches 0.1 m at z = sqrt(40) = 6.32 m, i.e. d = 15.8 px.
  EXPECT_NEAR(rangeForDepthSigma(params, 500, 0.2), std::sqrt(40.0), 1e-12);
  DisparityImage img;
  img.focal_px = 500, img.cx = 10, img.cy = 5, img.baseline_m = 0.2;
  img.disparity = cv::Mat(10, 20, CV_32FC1, cv::Scalar(16.0f));  // z = 6.25 m: kept
  img.disparity.row(0).setTo(15.5f);                             // z = 6.45 m: cut
  img.disparity.at<float>(1, 3) = NAN;                           // invalid
  img.disparity.at<float>(2, 3) = 500.0f;                        // z = 0.2 m: closer than min_range_m
  const PointSet set = triangulate(img, HeadGeometry{}, Eigen::Isometry3d::Identity(), params);
  EXPECT_EQ(set.points.size(), 9u * 20u - 2u);
  // Identity head and pose: the rectified frame is the world; pixel (cx, cy) at z = f b / d.
  bool centre_found = false;
  for (const auto& p : set.points)
    if (std::abs(p.x()) < 1e-9 && std::abs(p.y()) < 1e-9) centre_found = std::abs(p.z() - 100.0 / 16) < 1e-9;
  EXPECT_TRUE(centre_found);
}

TEST(MapperGeometry, AlignmentPointsAreThoseWithTextureOfTheirOwn) {
  MapperParams params;
  params.pixel_step = 1;
  params.texture_window_px = 5;
  params.alignment_min_grey_spread = 3.0;
  DisparityImage img;
  img.focal_px = 500, img.cx = 10, img.cy = 5, img.baseline_m = 0.2;
  img.disparity = cv::Mat(10, 20, CV_32FC1, cv::Scalar(40.0f));  // z = 2.5 m everywhere
  // Columns 0-9 a plain grey (no texture), columns 10-19 a checkerboard of 90 and 110 (spread 10).
  img.grey = cv::Mat(10, 20, CV_8UC1, cv::Scalar(100));
  for (int r = 0; r < 10; ++r)
    for (int c = 10; c < 20; ++c) img.grey.at<uint8_t>(r, c) = (r + c) % 2 ? 110 : 90;
  const cv::Mat spread = greySpread(img.grey, params.texture_window_px);
  EXPECT_NEAR(spread.at<float>(5, 3), 0.0, 1e-3) << "a plain window";
  // A 5 x 5 checker window: 13 of one grey, 12 of the other, mean 0.4 off 100: sqrt(100 - 0.4^2).
  EXPECT_NEAR(spread.at<float>(5, 15), std::sqrt(100.0 - 0.16), 1e-3);
  // Column 8's window reaches one checker column: 5 pixels of +-10 among 25 (spread about 4.5 >= 3); column 7's none.
  EXPECT_GT(spread.at<float>(5, 8), 3.0);
  EXPECT_NEAR(spread.at<float>(5, 7), 0.0, 1e-3);

  EXPECT_TRUE(triangulate(img, HeadGeometry{}, Eigen::Isometry3d::Identity(), params).alignment_points.empty())
      << "selected only when asked for";
  const PointSet set = triangulate(img, HeadGeometry{}, Eigen::Isometry3d::Identity(), params, true);
  EXPECT_EQ(set.points.size(), 200u) << "the map keeps every point";
  ASSERT_EQ(set.alignment_points.size(), 10u * 12u) << "columns 8-19 have texture of their own";
  // Identity head and pose: x = (u - cx) z / f; the leftmost alignment point is column 8.
  double min_x = INFINITY;
  for (const auto& p : set.alignment_points) min_x = std::min(min_x, p.x());
  EXPECT_NEAR(min_x, (8 - 10) * 2.5 / 500, 1e-12);

  img.grey.release();
  EXPECT_EQ(triangulate(img, HeadGeometry{}, Eigen::Isometry3d::Identity(), params, true).alignment_points.size(), 200u)
      << "without its grey image a map's points all go to the alignment";
}

TEST(VoxelMap, FusesPerVoxelStaysWithinItsBoundAndRoundTrips) {
  // A 1 m x 1 m wall sampled every 1 cm: 10 000 points, 20 x 20 voxels of 5 cm.
  std::vector<Eigen::Vector3d> wall;
  std::vector<uint8_t> grey;
  for (int i = 0; i < 100; ++i)
    for (int j = 0; j < 100; ++j) {
      wall.emplace_back(0.005 + 0.01 * i, 0.005 + 0.01 * j, 2.0);
      grey.push_back(200);
    }
  VoxelMap map(0.05, 1000000);
  EXPECT_EQ(map.insert(wall, grey, Eigen::Vector3d::Zero()), 0);
  EXPECT_EQ(map.size(), 400u);
  EXPECT_EQ(map.insert(wall, grey, Eigen::Vector3d::Zero()), 0);
  EXPECT_EQ(map.size(), 400u) << "the same wall seen again adds no voxel";
  for (uint8_t g : map.intensity()) ASSERT_EQ(g, 200);
  for (const auto& p : map.points()) ASSERT_NEAR(p.z(), 2.0, 1e-9);

  VoxelMap bounded(0.05, 100);
  EXPECT_EQ(bounded.insert(wall, grey, Eigen::Vector3d(0, 0, 2)), 300);
  EXPECT_EQ(bounded.size(), 100u);
  // The voxels nearest the head stay: none kept is further than the 100th nearest of the full map.
  std::vector<double> all;
  for (const auto& p : map.points()) all.push_back((p - Eigen::Vector3d(0, 0, 2)).norm());
  std::sort(all.begin(), all.end());
  for (const auto& p : bounded.points()) EXPECT_LE((p - Eigen::Vector3d(0, 0, 2)).norm(), all[99] + 1e-9);

  const auto dir = std::filesystem::temp_directory_path() / ("ips_voxel_map_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  for (const char* name : {"map.ply", "map.pcd"}) {
    map.save((dir / name).string());
    const auto loaded = VoxelMap::load((dir / name).string());
    ASSERT_EQ(loaded.size(), map.size()) << name;
    EXPECT_TRUE(loaded[7].isApprox(map.points()[7], 1e-6)) << name;
  }
  EXPECT_THROW(map.save((dir / "missing" / "map.ply").string()), std::runtime_error);
  EXPECT_THROW(VoxelMap::load((dir / "none.ply").string()), std::runtime_error);
  std::filesystem::remove_all(dir);
}

TEST(VoxelMap, AVoxelsCentroidFollowsItsNewPointsOnALatticeAnchoredAtTheOrigin) {
  // Voxel i covers [i v, (i + 1) v): 0.049 and 0.001 share a voxel of 5 cm, 0.051 and -0.001 do not.
  VoxelMap map(0.05, 1000);
  map.insert({{0.001, 0.01, 0.01}, {0.049, 0.01, 0.01}, {0.051, 0.01, 0.01}, {-0.001, 0.01, 0.01}}, {10, 30, 50, 70},
             Eigen::Vector3d::Zero());
  ASSERT_EQ(map.size(), 3u);
  // Seen again with two points: the stored centroid counts as one point beside them.
  map.insert({{0.010, 0.02, 0.02}, {0.040, 0.02, 0.02}}, {100, 200}, Eigen::Vector3d::Zero());
  ASSERT_EQ(map.size(), 3u);
  const std::vector<Eigen::Vector3d> points = map.points();
  const std::vector<uint8_t> grey = map.intensity();
  int checked = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    if (points[i].x() <= 0.0 || points[i].x() >= 0.05) continue;
    EXPECT_TRUE(
        points[i].isApprox(Eigen::Vector3d((0.025 + 0.010 + 0.040) / 3, (0.01 + 0.04) / 3, (0.01 + 0.04) / 3), 1e-12))
        << points[i].transpose();
    EXPECT_EQ(grey[i], 107);  // (20 + 100 + 200) / 3, rounded
    ++checked;
  }
  EXPECT_EQ(checked, 1);

  // One image's points fused per voxel for POINTS, in the order their voxels first appear.
  std::vector<Eigen::Vector3d> image{{0.051, 0, 0}, {0.001, 0, 0}, {0.099, 0, 0}};
  std::vector<uint8_t> image_grey{1, 2, 3};
  VoxelMap::downsample(0.05, &image, &image_grey);
  ASSERT_EQ(image.size(), 2u);
  EXPECT_NEAR(image[0].x(), 0.075, 1e-12);
  EXPECT_EQ(image_grey[0], 2);
  EXPECT_NEAR(image[1].x(), 0.001, 1e-12);

  // Voxel indices are 32-bit: a voxel too small for them to reach 10 km is refused, not wrapped.
  EXPECT_THROW(VoxelMap(1e-6, 1000), std::invalid_argument);
  EXPECT_THROW(VoxelMap::downsample(0.0, &image, &image_grey), std::invalid_argument);
}

TEST(MapEval, SelfConsistencyMeasuresADoubledWall) {
  // The same wall (x in [0, 2], z in [0, 2] at y = 3, every 2 cm) seen early, and late 4 cm further away; plus
  // late points of another wall nobody saw early.
  std::vector<Eigen::Vector3d> early, late;
  for (int i = 0; i <= 100; ++i)
    for (int j = 0; j <= 100; ++j) {
      early.emplace_back(0.02 * i, 3.0, 0.02 * j);
      late.emplace_back(0.02 * i, 3.04, 0.02 * j);
      late.emplace_back(10 + 0.02 * i, 3.0, 0.02 * j);
    }
  const ips::eval::SelfConsistency c = ips::eval::selfConsistency(early, late, 0.2);
  EXPECT_EQ(c.overlapping, 101u * 101u) << "only the wall seen twice";
  EXPECT_NEAR(c.median_m, 0.04, 1e-9);
  EXPECT_NEAR(c.p90_m, 0.04, 1e-9);
  EXPECT_EQ(ips::eval::selfConsistency(early, {}, 0.2).overlapping, 0u);
}

namespace {

Eigen::Isometry3d trueCamera(double t) {
  const auto& h = simHead();
  return h.head.cam0InWorld(h.trajectory.pose(t));
}

}  // namespace

TEST(CloudOdometry, AlignsTwoMapsThreeSecondsApartBackToTheTruth) {
  // Two true disparity maps of the first corridor 3 s apart (2.25 m of walking, E3D's interval); the second is placed
  // with a pose whose change since the first is 3 cm and 0.3 deg off, as a drifting filter's would be.
  const double t0 = 6.0, t1 = 9.0;
  const Eigen::Isometry3d cam0 = trueCamera(t0), cam1 = trueCamera(t1);
  const Eigen::Isometry3d truth = cam0.inverse() * cam1;
  Eigen::Isometry3d prior = truth;
  prior.linear() = ips::expSO3(Eigen::Vector3d(0.003, -0.004, 0.002)) * prior.linear();
  prior.translation() += Eigen::Vector3d(0.02, -0.015, 0.015);
  const Eigen::Isometry3d placed1 = cam0 * prior;
  const HeadGeometry g = trueGeometry();
  const MapperParams mp;
  const Eigen::Isometry3d T_cam_body = g.T_body_cam0.inverse();
  const PointSet map0 = triangulate(trueDisparity(t0), g, cam0 * T_cam_body, mp);
  const PointSet map1 = triangulate(trueDisparity(t1), g, placed1 * T_cam_body, mp);

  CloudOdometry odometry{CloudOdometryParams{}};
  const auto& rect = simHead().renderer.rectification();
  const double k = mp.disparity_sigma_px / (rect.f * rect.baseline);
  const CloudDelta first = odometry.add(6'000'000, map0.points, cam0, k);
  EXPECT_FALSE(first.valid);
  EXPECT_EQ(first.reason, "first_map");
  const CloudDelta d = odometry.add(9'000'000, map1.points, placed1, k);
  ASSERT_TRUE(d.valid) << d.reason;
  EXPECT_EQ(d.utime_prev, 6'000'000);
  EXPECT_EQ(d.utime, 9'000'000);
  EXPECT_GT(d.overlap, 0.5);
  const double prior_t = (d.prior.translation() - truth.translation()).norm();
  const double prior_r = Eigen::AngleAxisd(d.prior.linear() * truth.linear().transpose()).angle();
  const double err_t = (d.T_prev_now.translation() - truth.translation()).norm();
  const double err_r = Eigen::AngleAxisd(d.T_prev_now.linear() * truth.linear().transpose()).angle();
  // A corridor: its axis is left to the prior (with the unconstrained sigma), the rest is the maps'.
  EXPECT_GE(d.constrained_directions, 4);
  EXPECT_LT(err_t, 0.75 * prior_t);
  EXPECT_LT(err_r, 0.5 * prior_r);
  // The covariance is a covariance, and the result lies within it.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(d.covariance);
  EXPECT_GT(eig.eigenvalues().minCoeff(), 0);
  Eigen::Matrix<double, 6, 1> e;
  e << d.T_prev_now.translation() - truth.translation(),
      Eigen::AngleAxisd(d.T_prev_now.linear() * truth.linear().transpose()).angle() *
          Eigen::AngleAxisd(d.T_prev_now.linear() * truth.linear().transpose()).axis();
  EXPECT_LT(e.dot(d.covariance.ldlt().solve(e)), 22.5);  // chi-square 6 dof, 99.9 %
  std::printf(
      "[ CLOUD    ] prior off by %.4f m %.3f deg; aligned %.4f m %.4f deg, %d directions fixed, %d pairs, "
      "overlap %.2f, rmse %.4f m\n",
      prior_t, prior_r * 180 / M_PI, err_t, err_r * 180 / M_PI, d.constrained_directions, d.correspondences, d.overlap,
      d.rmse_m);
}

TEST(CloudOdometry, APlaneLeavesItsOwnDirectionsToThePriorAndSaysSo) {
  // A wall 3 m ahead (a 4 x 2.5 m plane, 2 cm grid): it fixes the motion towards it and the two rotations that tilt it,
  // but neither the motion along it nor the turn about its normal. Those stay at the prior with the unconstrained
  // sigma; the constrained ones come back to the truth (identity) with a small one.
  std::vector<Eigen::Vector3d> wall;
  for (double x = -2.0; x <= 2.0; x += 0.02)
    for (double y = -1.25; y <= 1.25; y += 0.02) wall.emplace_back(x, y, 3.0);
  Eigen::Isometry3d prior = Eigen::Isometry3d::Identity();
  prior.translation() = Eigen::Vector3d(0.05, -0.04, 0.03);
  const CloudOdometryParams params;
  const CloudOdometry odometry(params);
  const CloudDelta d = odometry.align(wall, wall, prior, 1e-3);
  ASSERT_TRUE(d.valid) << d.reason;
  EXPECT_NEAR(d.T_prev_now.translation().z(), 0.0, 1e-3);
  EXPECT_NEAR(d.T_prev_now.translation().x(), 0.05, 1e-3);
  EXPECT_NEAR(d.T_prev_now.translation().y(), -0.04, 1e-3);
  const Eigen::Matrix<double, 6, 1> sigma = d.covariance.diagonal().cwiseSqrt();
  EXPECT_GT(sigma[0], 0.9 * params.unconstrained_sigma_t);
  EXPECT_GT(sigma[1], 0.9 * params.unconstrained_sigma_t);
  EXPECT_LT(sigma[2], 0.01);
  EXPECT_LT(sigma[3], 0.01);
  EXPECT_LT(sigma[4], 0.01);
  EXPECT_GT(sigma[5], 0.9 * params.unconstrained_sigma_r);
}

TEST(CloudOdometry, TooFewPointsGiveNoMeasurement) {
  const std::vector<Eigen::Vector3d> few(100, Eigen::Vector3d(0, 0, 3));
  const CloudOdometry odometry{CloudOdometryParams{}};
  const CloudDelta d = odometry.align(few, few, Eigen::Isometry3d::Identity(), 1e-3);
  EXPECT_FALSE(d.valid);
  EXPECT_EQ(d.reason, "too_few_points");
}
