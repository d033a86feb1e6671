// The mapper's library against the simulator's ground truth and analytic results: points of a true disparity
// map placed with the true pose lie on the world's surfaces (and a wrong pose is seen); the pose buffer
// interpolates and says when it cannot; the range cut follows the depth precision; the voxel map fuses,
// stays within its bound and round-trips through PLY and PCD.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include "ips/mapper/map_eval.hpp"
#include "ips/mapper/params.hpp"
#include "ips/mapper/stereo_points.hpp"
#include "ips/mapper/voxel_map.hpp"
#include "ips/sim/renderer.hpp"
#include "ips/sim/scenario.hpp"
#include "ips/sim/sensors.hpp"
#include "ips/sim/trajectory.hpp"
#include "ips/sim/world.hpp"

using namespace ips::mapper;

namespace {

struct SimHead {
  ips::sim::Scenario sc = ips::sim::Scenario::defaults();
  ips::sim::World world;
  ips::sim::SensorHead head;
  ips::sim::Trajectory traj;
  std::unique_ptr<ips::sim::StereoRenderer> renderer;
  SimHead()
      : world(ips::sim::World::build(sc.world, sc.seed)),
        head(ips::sim::SensorHead::make(sc)),
        traj(sc.trajectory, sc.gravity) {
    renderer = std::make_unique<ips::sim::StereoRenderer>(sc, world, head, traj);
  }
};

SimHead& simHead() {
  static SimHead h;
  return h;
}

// The simulator's true disparity of the rectified left image at time t, with its camera.
DisparityImage trueDisparity(double t) {
  const auto& h = simHead();
  DisparityImage img;
  img.disparity = h.renderer->disparityFromDepth(h.renderer->rectifiedDepth(t, 0));
  const auto& rect = h.renderer->rectification();
  img.focal_px = rect.f, img.cx = rect.cx, img.cy = rect.cy, img.baseline_m = rect.baseline;
  return img;
}

HeadGeometry trueGeometry() {
  HeadGeometry g;
  g.R_rect0_cam0 = simHead().renderer->rectification().R_rect0_cam0;
  g.T_body_cam0 = simHead().head.calibration.T_imu_cam0;
  return g;
}

}  // namespace

TEST(MapperGeometry, TrueDisparityWithTheTruePoseLiesOnTheWorldsSurfaces) {
  MapperParams params;
  params.pixel_step = 4;
  for (double t : {10.0, 45.0, 80.0}) {
    const Eigen::Isometry3d T_world_body = simHead().traj.pose(t);
    const PointSet set = triangulate(trueDisparity(t), trueGeometry(), T_world_body, params);
    ASSERT_GT(set.points.size(), 1000u) << "t = " << t;
    const SurfaceErrors e = surfaceErrors(set.points, simHead().world);
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
    const SurfaceErrors off =
        surfaceErrors(triangulate(trueDisparity(t), trueGeometry(), wrong, params).points, simHead().world);
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
  const SelfConsistency c = selfConsistency(early, late, 0.2);
  EXPECT_EQ(c.overlapping, 101u * 101u) << "only the wall seen twice";
  EXPECT_NEAR(c.median_m, 0.04, 1e-9);
  EXPECT_NEAR(c.p90_m, 0.04, 1e-9);
  EXPECT_EQ(selfConsistency(early, {}, 0.2).overlapping, 0u);
}
