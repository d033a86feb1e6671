// The world of the hard walk (world/people, lighting_zones, ramp_*, weak_stretch_m) against ground truth: a person's
// rendered depth against the analytic distance to its box and its motion against its speed; the walker's height on
// the ramp against the floor, its derivatives and the ideal IMU integrated over the ramp; the rendered floor on the
// ramp; a lighting zone's radiance against its ratio and the auto exposure following it; the weak stretch plain from
// wall to wall.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>

#include "ips/sim/rig.hpp"
#include "sim_test_support.hpp"

using namespace ips::sim;
using ips::KinematicState;

namespace {

Scenario quiet() { return test_support::quietScenario(); }

// The head held still at the walk's first waypoint, looking along +x down the south corridor, and two people in
// front of it: one crossing the corridor 3 m ahead (standing a second at each wall), one walking to and from the head
// on a lane beside it.
Scenario standingBeforePeople() {
  Scenario sc = quiet();
  sc.trajectory.type = "still";
  sc.world.people = {{{6.0, 0.4}, {6.0, 2.0}, 1.2, 1.0}, {{9.0, 1.75}, {4.5, 1.75}, 1.4, 0.0}};
  return sc;
}

// The wheelchair ramp of config/sim_hard.yaml: 0.5 m up at 1:12 in the north corridor, 4 m level, down again.
Ramp northCorridorRamp() {
  Ramp r;
  r.start_m = {22.0, 12.8};
  r.heading_deg = 180;
  r.width_m = 2.4;
  r.rise_m = 0.5;
  r.slope = 1.0 / 12;
  r.plateau_m = 4.0;
  r.blend_m = 1.0;
  return r;
}

Scenario walkOverTheRamp() {
  Scenario sc = quiet();
  sc.world.ramp = sc.trajectory.floor_ramp = northCorridorRamp();
  return sc;
}

// The rectified left camera (pinhole, its rays exact) of the rig at time t, in world.
struct RectifiedCamera {
  View view;
  Eigen::Isometry3d T_world_cam;
  double f, cx, cy;
};
RectifiedCamera rectifiedLeft(const Rig& rig, double t) {
  const ips::StereoRectification& rect = rig.renderer.rectification();
  Eigen::Matrix3d K;
  K << rect.f, 0, rect.cx, 0, rect.f, rect.cy, 0, 0, 1;
  Eigen::Isometry3d T_cam_rect = Eigen::Isometry3d::Identity();
  T_cam_rect.linear() = rect.R_rect0_cam0.transpose();
  return {View::pinhole(K, rect.size), rig.head.cam0InWorld(rig.trajectory.pose(t)) * T_cam_rect, rect.f, rect.cx,
          rect.cy};
}

// Where the ray o + lambda d first enters the person's box at time t (slabs along, across and up), if it does.
std::optional<double> rayIntoPerson(const Person& person, double t, double floor_z, const Eigen::Vector3d& o,
                                    const Eigen::Vector3d& d) {
  const Eigen::Vector2d c = person.centre(t), f = person.forward();
  const Eigen::Vector3d axes[3] = {{f.x(), f.y(), 0}, {-f.y(), f.x(), 0}, {0, 0, 1}};
  const Eigen::Vector3d centre(c.x(), c.y(), floor_z + 0.5 * person.size_m.z());
  const double half[3] = {0.5 * person.size_m.y(), 0.5 * person.size_m.x(), 0.5 * person.size_m.z()};
  double enter = 0, leave = INFINITY;
  for (int k = 0; k < 3; ++k) {
    const double p = (o - centre).dot(axes[k]), v = d.dot(axes[k]);
    if (std::abs(v) < 1e-12) {
      if (std::abs(p) > half[k]) return std::nullopt;
      continue;
    }
    const double a = (-half[k] - p) / v, b = (half[k] - p) / v;
    enter = std::max(enter, std::min(a, b));
    leave = std::min(leave, std::max(a, b));
  }
  if (enter > leave || enter <= 0) return std::nullopt;
  return enter;
}

// A time in [from, to) at which person k walks (neither stands at an end nor turns) for at least `span` seconds.
double walkingTime(const Person& person, double from, double to, double span) {
  const double step = 0.01;
  for (double t = from; t < to; t += step) {
    bool walking = true;
    for (double s = 0; s <= span + 1e-9 && walking; s += step) {
      const double moved = (person.centre(t + s + step) - person.centre(t + s)).norm();
      walking = std::abs(moved - person.lane.speed_mps * step) < 1e-9;
    }
    if (walking) return t;
  }
  ADD_FAILURE() << "the person does not walk for " << span << " s";
  return from;
}

struct StrapdownErrors {
  double max_error = 0, max_vertical_error = 0, climb = 0;  // [m]; climb: highest integrated height over the start's
};

// The ideal IMU of the scenario integrated (strapdown, as SimImu.NoiseFreeIntegrationReproducesTrajectory does) from
// the true state at t0 to t1, against the trajectory.
StrapdownErrors integrateIdealImu(const Scenario& sc, double t0, double t1) {
  const Trajectory traj(sc.trajectory, sc.gravity);
  ImuSimulator imu(ImuFigures::ideal(), traj, sc.start_utime, 7);
  ImuMeasurement prev = imu.next();
  while ((prev.utime_true - sc.start_utime) * 1e-6 < t0) prev = imu.next();
  const KinematicState s0 = traj.state((prev.utime_true - sc.start_utime) * 1e-6);
  test_support::Strapdown nav(s0, sc.gravity);
  StrapdownErrors out;
  while (true) {
    const ImuMeasurement cur = imu.next();
    const double t = (cur.utime_true - sc.start_utime) * 1e-6;
    if (t > t1) break;
    nav.step(prev, cur);
    const KinematicState s = traj.state(t);
    out.max_error = std::max(out.max_error, (nav.p - s.position).norm());
    out.max_vertical_error = std::max(out.max_vertical_error, std::abs(nav.p.z() - s.position.z()));
    out.climb = std::max(out.climb, nav.p.z() - s0.position.z());
    prev = cur;
  }
  return out;
}

}  // namespace

// The ground truth's depth (StereoRenderer::rectifiedDepth, whose disparity GT_DISPARITY carries) sees the people:
// where a pixel's ray enters a person's box before any static surface, its depth is the analytic distance to the box.
TEST(SimPeople, RenderedDepthIsTheDistanceToTheirBoxes) {
  const Rig rig(standingBeforePeople());
  ASSERT_EQ(rig.world.people.size(), 2u);
  const Person& crossing = rig.world.people[0];
  const double t = walkingTime(crossing, 0.0, 30.0, 0.3) + 0.15;
  const RectifiedCamera cam = rectifiedLeft(rig, t);
  const cv::Mat depth = rig.renderer.rectifiedDepth(t, 0);
  cv::Mat own, static_depth;
  SceneRenderer(rig.world, rig.scenario.camera.near_m).render(cam.view, cam.T_world_cam, t, nullptr, &own);
  SceneRenderer(rig.world, rig.scenario.camera.near_m).render(cam.view, cam.T_world_cam, nullptr, &static_depth);
  EXPECT_EQ(cv::norm(depth, own, cv::NORM_INF), 0.0);  // the ground truth is the scene at that time
  const Eigen::Vector3d o = cam.T_world_cam.translation();
  size_t on_people = 0, disagree = 0;
  double worst = 0;
  for (int y = 0; y < depth.rows; y += 2)
    for (int x = 0; x < depth.cols; x += 2) {
      const Eigen::Vector3d ray((x - cam.cx) / cam.f, (y - cam.cy) / cam.f, 1.0);  // lambda along it = depth z
      const Eigen::Vector3d d = cam.T_world_cam.linear() * ray;
      double nearest = INFINITY;
      for (const Person& p : rig.world.people)
        if (auto lambda = rayIntoPerson(p, t, rig.world.ramp.floorHeight(p.centre(t)), o, d))
          nearest = std::min(nearest, *lambda);
      const float z = depth.at<float>(y, x), z_static = static_depth.at<float>(y, x);
      const bool person_in_front = nearest < (z_static > 0 ? z_static : INFINITY);
      if (!person_in_front) {
        if (z != z_static) ++disagree;  // a pixel the analytic box misses by float rounding at its edge
        continue;
      }
      ++on_people;
      if (std::abs(z - nearest) > 1e-3) {
        ++disagree;
        continue;
      }
      worst = std::max(worst, std::abs(z - nearest));
    }
  std::printf(
      "[ PEOPLE   ] t=%.2f s: %zu pixels on people, %zu at odds with the boxes (their edges), worst depth "
      "difference %.2e m\n",
      t, on_people, disagree, worst);
  EXPECT_GT(on_people, 5000u);  // the crossing person 3 m ahead covers ~150 x 400 pixels, sampled every 2nd
  EXPECT_LT(disagree, on_people / 100);
  EXPECT_LT(worst, 1e-4);
}

// A person seen at two times has moved by its speed times the interval: the extent of its pixels along its lane, back
// in the world through the ground truth's depth, moves with its centre.
TEST(SimPeople, SeenAtTwoTimesTheyMoveBySpeedTimesInterval) {
  const Rig rig(standingBeforePeople());
  const Person& crossing = rig.world.people[0];
  const Person& approaching = rig.world.people[1];
  const double dt = 0.5;
  // Both times while the crossing person walks and the other one is well away from its lane.
  double t1 = 0;
  for (double from = 0; from < 60; from = t1 + 0.05) {
    t1 = walkingTime(crossing, from, 60, dt);
    if (std::abs(approaching.centre(t1).x() - 6.0) > 1.0 && std::abs(approaching.centre(t1 + dt).x() - 6.0) > 1.0)
      break;
  }
  auto extentAlongLane = [&](double t) {
    const RectifiedCamera cam = rectifiedLeft(rig, t);
    const cv::Mat depth = rig.renderer.rectifiedDepth(t, 0);
    cv::Mat static_depth;
    SceneRenderer(rig.world).render(cam.view, cam.T_world_cam, nullptr, &static_depth);
    double lo = INFINITY, hi = -INFINITY;
    size_t n = 0;
    for (int y = 0; y < depth.rows; ++y)
      for (int x = 0; x < depth.cols; ++x) {
        const float z = depth.at<float>(y, x), z_static = static_depth.at<float>(y, x);
        if (!(z > 0) || !(z < z_static - 0.01f)) continue;  // only what stands in front of the building
        const Eigen::Vector3d p =
            cam.T_world_cam * Eigen::Vector3d(z * (x - cam.cx) / cam.f, z * (y - cam.cy) / cam.f, z);
        if (std::abs(p.x() - 6.0) > 0.4) continue;  // the crossing person's, not the other one's
        lo = std::min(lo, p.y());
        hi = std::max(hi, p.y());
        ++n;
      }
    EXPECT_GT(n, 10000u) << "t=" << t;
    return std::make_pair(lo, hi);
  };
  const auto [lo1, hi1] = extentAlongLane(t1);
  const auto [lo2, hi2] = extentAlongLane(t1 + dt);
  const double moved = 0.5 * (lo2 + hi2) - 0.5 * (lo1 + hi1);
  const double direction = (crossing.centre(t1 + dt) - crossing.centre(t1)).y() > 0 ? 1 : -1;
  std::printf(
      "[ PEOPLE   ] t=%.2f s and %.1f s later: seen %.4f m apart along the lane, speed x interval %.4f m; "
      "seen depth along the lane %.4f m (box %.2f m)\n",
      t1, dt, moved, crossing.lane.speed_mps * dt, hi1 - lo1, crossing.size_m.y());
  EXPECT_NEAR(moved, direction * crossing.lane.speed_mps * dt, 0.01);
  EXPECT_NEAR(0.5 * (lo1 + hi1), crossing.centre(t1).y(), 0.01);
  EXPECT_NEAR(hi1 - lo1, crossing.size_m.y(), 0.01);
}

// Motion blur sees the people's own motion: with the head still, a person walking across the view takes several
// sub-images (one standing takes one), and the blurred image is the mean of renderings over the exposure.
TEST(SimPeople, MotionBlurFollowsTheirMotion) {
  Scenario sc = standingBeforePeople();
  sc.world.people.resize(1);  // the crossing one alone
  sc.camera.motion_blur = true;
  sc.camera.exposure_us = 12000;
  const Rig rig(sc);
  const Person& crossing = rig.world.people[0];
  const double frame_s = 1.0 / sc.camera.rate_hz;
  auto frameAt = [&](double t) { return static_cast<int64_t>(std::ceil(t / frame_s)); };
  const int64_t walking = frameAt(walkingTime(crossing, 0.0, 30.0, 2 * frame_s));
  int64_t standing = walking;
  // A frame at which it stands at one end of its lane.
  while ((crossing.centre(standing * frame_s + 0.01) - crossing.centre(standing * frame_s - 0.01)).norm() > 0)
    ++standing;
  const StereoFrame moving = rig.renderer.render(walking), still = rig.renderer.render(standing);
  const double t = (moving.utime_true - sc.start_utime) * 1e-6, exposure_s = sc.camera.exposure_us * 1e-6;
  const int n = moving.blur_samples[0];
  // The streak: 1.2 m/s x 12 ms at 3 m is 3.6 px; in steps of blur_step_px 1 px, 9 sub-images (a power of 3) in the
  // tiles the person crosses.
  EXPECT_GE(n, 3);
  EXPECT_EQ(still.blur_samples[0], 1);
  const SceneRenderer scene(rig.world, sc.camera.near_m);
  const View view = View::distorted(rig.head.calibration.cam0);
  cv::Mat reference = cv::Mat::zeros(view.height, view.width, CV_32F), radiance;
  for (int j = 0; j < n; ++j) {
    const double t_sub = t + exposure_s * ((j + 0.5) / n - 0.5);
    scene.render(view, rig.head.cam0InWorld(rig.trajectory.pose(t_sub)), t_sub, &radiance, nullptr);
    reference += radiance * rig.renderer.camera().gain(0) / n;
  }
  reference = cv::min(reference, 255.0);
  cv::Mat blurred;
  moving.left.convertTo(blurred, CV_32F);
  const double error = cv::mean(cv::abs(blurred - reference))[0];
  std::printf(
      "[ PEOPLE   ] a person crossing at frame %ld: %d sub-images (standing at frame %ld: %d); against the mean "
      "of renderings over the exposure %.3f grey levels\n",
      static_cast<long>(walking), n, static_cast<long>(standing), still.blur_samples[0], error);
  EXPECT_LT(error, 0.27);  // the 8-bit rounding alone
}

// No one walks into the head: a lane across the walk gets a phase that keeps its person clear of the walker; a lane
// across the walk without a pause at its ends has none and is refused.
TEST(SimPeople, KeepClearOfTheWalkerOrAreRefused) {
  Scenario sc = quiet();
  // Across the south corridor, wall to wall, standing 3 s at each wall.
  sc.world.people = {{{8.0, 0.4}, {8.0, 2.0}, 1.2, 3.0}};
  const Rig rig(sc);
  double closest = INFINITY;
  for (double t = 0; t < rig.trajectory.duration(); t += 0.01) {
    const Eigen::Vector2d head = rig.trajectory.state(t).position.head<2>();
    const Person& p = rig.world.people[0];
    const Eigen::Vector2d d = head - p.centre(t), f = p.forward();
    const double along = std::max(0.0, std::abs(d.dot(f)) - 0.5 * p.size_m.y());
    const double across = std::max(0.0, std::abs(f.x() * d.y() - f.y() * d.x()) - 0.5 * p.size_m.x());
    closest = std::min(closest, std::hypot(along, across));
  }
  std::printf("[ PEOPLE   ] closest approach of the crossing person to the head: %.3f m (clearance %.2f m)\n", closest,
              sc.world.person_clearance_m);
  // Checked every 50 ms when placed: in between the two close in by at most (1.2 + 0.75 m/s) x 25 ms.
  EXPECT_GT(closest, sc.world.person_clearance_m - 0.05);
  sc.world.people[0].dwell_s = 0;
  EXPECT_THROW(Rig{sc}, std::invalid_argument);
}

// The walker's height follows the floor: height_m above the ramp wherever the floor is straight, within
// 0.078 slope blend_m where the body rounds a kink; up to the plateau and down again.
TEST(SimRamp, WalkerFollowsTheFloor) {
  Scenario sc = walkOverTheRamp();
  sc.trajectory.bounce_m = 0;  // the gait's bounce off: the height is the floor's alone
  const Trajectory traj(sc.trajectory, sc.gravity);
  const Ramp& ramp = sc.world.ramp;
  double worst_straight = 0, worst = 0, highest = 0;
  size_t on_slopes = 0;
  for (double t = 0; t < traj.duration(); t += 0.02) {
    const KinematicState s = traj.state(t);
    const double floor = ramp.floorHeight(s.position.head<2>());
    const double off = std::abs(s.position.z() - sc.trajectory.height_m - floor);
    worst = std::max(worst, off);
    highest = std::max(highest, s.position.z() - sc.trajectory.height_m);
    const double u = ramp.local(s.position.head<2>()).x();
    bool near_kink = false;
    for (double kink : {0.0, ramp.run(), ramp.run() + ramp.plateau_m, ramp.length()})
      near_kink |= std::abs(u - kink) < 0.5 * ramp.blend_m + 1e-6;
    if (!near_kink) worst_straight = std::max(worst_straight, off);
    if (floor > 0.05 && floor < ramp.rise_m - 0.05) ++on_slopes;
  }
  std::printf(
      "[ RAMP     ] head above floor + height_m: within %.1e m on straight floor, %.4f m at the kinks; "
      "highest %.4f m\n",
      worst_straight, worst, highest);
  EXPECT_GT(on_slopes, 500u);  // 2 x 4.8 m of slope at 0.75 m/s, every 20 ms
  EXPECT_LT(worst_straight, 1e-9);
  EXPECT_LT(worst, 0.0782 * ramp.slope * ramp.blend_m);
  EXPECT_NEAR(highest, ramp.rise_m, 1e-9);
}

// Over the ramp the motion stays smooth for the IMU: velocity and acceleration are the exact derivatives (central
// differences agree at the kinks' roundings), the vertical specific force is the vertical acceleration plus gravity,
// and the ideal IMU integrated across the whole ramp (up, level, down) reproduces the walk, height included.
TEST(SimRamp, ImuFollowsTheWalkerUpAndDown) {
  const Scenario sc = walkOverTheRamp();
  const Trajectory traj(sc.trajectory, sc.gravity);
  const Ramp& ramp = sc.world.ramp;
  // When the walker is at distance u along the ramp (first time).
  auto timeAt = [&](double u) {
    for (double t = 0; t < traj.duration(); t += 0.005) {
      const Eigen::Vector2d q = ramp.local(traj.state(t).position.head<2>());
      if (std::abs(q.y()) < 0.5 * ramp.width_m && q.x() >= u) return t;
    }
    return std::numeric_limits<double>::quiet_NaN();
  };
  const double h = 1e-4;
  for (double kink : {0.0, ramp.run(), ramp.run() + ramp.plateau_m, ramp.length()})
    for (double offset : {-0.3, 0.0, 0.3}) {
      const double t = timeAt(kink + offset);
      ASSERT_FALSE(std::isnan(t));
      const KinematicState s = traj.state(t), a = traj.state(t - h), b = traj.state(t + h);
      EXPECT_LT(((b.position - a.position) / (2 * h) - s.velocity).norm(), 1e-6) << "t=" << t;
      EXPECT_LT(((b.velocity - a.velocity) / (2 * h) - s.acceleration).norm(), 1e-5) << "t=" << t;
      const double z_dd = (b.position.z() - 2 * s.position.z() + a.position.z()) / (h * h);
      EXPECT_NEAR((s.orientation * s.specificForce(sc.gravity)).z() - sc.gravity, z_dd, 1e-3) << "t=" << t;
    }
  // Strapdown from 3 m before the ramp to 3 m after it, beside the same on the walk without the ramp: the ramp adds
  // nothing to the integrator's own error (which grows with the gait's sway over half a minute).
  const double t0 = timeAt(-3.0), t1 = timeAt(ramp.length() + 3.0);
  ASSERT_FALSE(std::isnan(t0) || std::isnan(t1));
  Scenario flat = sc;
  flat.world.ramp = flat.trajectory.floor_ramp = Ramp();
  const StrapdownErrors over_ramp = integrateIdealImu(sc, t0, t1), on_flat = integrateIdealImu(flat, t0, t1);
  std::printf(
      "[ RAMP     ] ideal IMU over the ramp (%.1f s): max position error %.2e m (flat walk %.2e m), vertical "
      "%.2e m (flat %.2e m); integrated climb %.3f m\n",
      t1 - t0, over_ramp.max_error, on_flat.max_error, over_ramp.max_vertical_error, on_flat.max_vertical_error,
      over_ramp.climb);
  EXPECT_GT(t1 - t0, 20.0);
  EXPECT_LT(over_ramp.max_error, on_flat.max_error + 0.001);
  EXPECT_LT(over_ramp.max_vertical_error, on_flat.max_vertical_error + 0.001);
  EXPECT_NEAR(over_ramp.climb, ramp.rise_m, 0.06);  // the rise, give or take the gait's bounce at both ends
  EXPECT_NEAR(on_flat.climb, 0.0, 0.06);
}

// The images show the floor the walker walks on: on the up slope, the ground truth's depth puts the floor's points
// on the ramp's surface.
TEST(SimRamp, RenderedFloorIsTheRamp) {
  const Rig rig(walkOverTheRamp());
  const Ramp& ramp = rig.world.ramp;
  double t = 0;
  for (; t < rig.trajectory.duration(); t += 0.05)
    if (ramp.local(rig.trajectory.state(t).position.head<2>()).x() > 1.5 &&
        std::abs(ramp.local(rig.trajectory.state(t).position.head<2>()).y()) < 0.5 * ramp.width_m)
      break;
  const RectifiedCamera cam = rectifiedLeft(rig, t);
  const cv::Mat depth = rig.renderer.rectifiedDepth(t, 0);
  size_t on_ramp = 0, raised = 0;
  double worst = 0;
  for (int y = depth.rows / 2; y < depth.rows; y += 2)
    for (int x = 0; x < depth.cols; x += 2) {
      const float z = depth.at<float>(y, x);
      if (!(z > 0)) continue;
      const Eigen::Vector3d p =
          cam.T_world_cam * Eigen::Vector3d(z * (x - cam.cx) / cam.f, z * (y - cam.cy) / cam.f, z);
      const Eigen::Vector2d q = ramp.local(p.head<2>());
      if (q.x() < 0.05 || q.x() > ramp.length() - 0.05 || std::abs(q.y()) > 0.5 * ramp.width_m - 0.05) continue;
      if (p.z() > ramp.rise_m + 0.3) continue;  // the walls above the floor
      ++on_ramp;
      raised += ramp.floorHeight(p.head<2>()) > 0.2;
      worst = std::max(worst, std::abs(p.z() - ramp.floorHeight(p.head<2>())));
    }
  std::printf(
      "[ RAMP     ] t=%.2f s on the up slope: %zu floor pixels on the ramp (%zu above 0.2 m), worst height "
      "off its surface %.2e m\n",
      t, on_ramp, raised, worst);
  EXPECT_GT(on_ramp, 20000u);
  EXPECT_GT(raised, 5000u);
  EXPECT_LT(worst, 0.003);
}

// A lighting zone scales the light of what lies in it: each pixel's radiance by the zone's factor at the point it
// sees (exactly), and with the auto exposure off the image's mean grey by the ratio where the zone takes in all the
// view.
TEST(SimLighting, RenderedGreyFollowsTheZone) {
  Scenario sc = quiet();
  const Rig plain(sc);
  const double t = 8.0;  // walking east down the south corridor
  const RectifiedCamera cam = rectifiedLeft(plain, t);
  cv::Mat radiance, depth;
  SceneRenderer(plain.world).render(cam.view, cam.T_world_cam, t, &radiance, &depth);
  for (double ratio : {0.3, 2.0}) {
    // A zone that the view ends in: the corridor ahead of the head.
    const Eigen::Vector2d head = plain.trajectory.state(t).position.head<2>();
    sc.world.lighting_zones = {{{head.x() + 3.0, -7.0}, {head.x() + 9.0, 4.0}, ratio}};
    const Rig lit(sc);
    cv::Mat lit_radiance;
    SceneRenderer(lit.world).render(cam.view, cam.T_world_cam, t, &lit_radiance, nullptr);
    double worst = 0;
    size_t dimmed = 0;
    for (int y = 0; y < depth.rows; y += 2)
      for (int x = 0; x < depth.cols; x += 2) {
        const float z = depth.at<float>(y, x), r = radiance.at<float>(y, x);
        if (!(z > 0) || r < 10) continue;
        const Eigen::Vector3d p =
            cam.T_world_cam * Eigen::Vector3d(z * (x - cam.cx) / cam.f, z * (y - cam.cy) / cam.f, z);
        const double expected = lit.world.lighting.at(static_cast<float>(p.x()), static_cast<float>(p.y()));
        worst = std::max(worst, std::abs(lit_radiance.at<float>(y, x) / r - expected));
        dimmed += std::abs(expected - ratio) < 1e-6;
      }
    std::printf("[ LIGHTING ] zone at %.1f: %zu pixels see its full ratio, worst |radiance ratio - zone factor| %.1e\n",
                ratio, dimmed, worst);
    EXPECT_GT(dimmed, 5000u);
    EXPECT_LT(worst, 1e-3);  // the point seen from float depth: a few mm off at the zone's edges
  }
  // The whole view in a dim zone: the mean grey of the image (no auto exposure) by its ratio.
  const double ratio = 0.3;
  sc.world.lighting_zones = {{{-100, -100}, {100, 100}, ratio}};
  const Rig dim(sc);
  const int64_t k = 64;
  const double grey = cv::mean(plain.renderer.render(k).left)[0], dim_grey = cv::mean(dim.renderer.render(k).left)[0];
  std::printf("[ LIGHTING ] all in a zone at %.1f: mean grey %.2f -> %.2f (x %.4f)\n", ratio, grey, dim_grey,
              dim_grey / grey);
  EXPECT_NEAR(dim_grey / grey, ratio, 0.01);
}

// With the auto exposure on, exposure times gain follows the light: by 1 / ratio when the whole view is in a zone, and
// along the hard walk up in its dim stretch and down in its bright one.
TEST(SimLighting, AutoExposureFollowsTheZone) {
  Scenario sc = quiet();
  sc.camera.auto_exposure = true;
  sc.camera.exposure_us = 10000;  // as the hard walk: the exposure at which the building gives its grey levels
  const Rig plain(sc);
  const double ratio = 0.3;
  sc.world.lighting_zones = {{{-100, -100}, {100, 100}, ratio}};
  const Rig dim(sc);
  auto exposed = [](const Rig& rig, int64_t k) {
    const Exposure e = rig.renderer.exposureFor(k, 0);
    return e.exposure_us * e.gain;
  };
  const int64_t k = 160;
  std::printf("[ LIGHTING ] auto exposure x gain: %.0f us plain, %.0f us in a zone at %.1f (x %.3f)\n",
              exposed(plain, k), exposed(dim, k), ratio, exposed(dim, k) / exposed(plain, k));
  EXPECT_NEAR(exposed(dim, k) / exposed(plain, k), 1 / ratio, 0.01 / ratio);

  // The hard walk's zones: exposure x gain along the walk against that of the same walk without them.
  Scenario hard = Scenario::load(std::string(IPS_CONFIG_DIR) + "/sim_hard.yaml");
  ASSERT_FALSE(hard.world.lighting_zones.empty());
  hard.world.people.clear();  // the light alone
  Scenario unlit = hard;
  unlit.world.lighting_zones.clear();
  const Rig zoned(hard), reference(unlit);
  double lowest = INFINITY, highest = 0;
  for (int64_t frame = 8; frame < static_cast<int64_t>(zoned.trajectory.duration() * hard.camera.rate_hz); frame += 8) {
    const double r = exposed(zoned, frame) / exposed(reference, frame);
    lowest = std::min(lowest, r);
    highest = std::max(highest, r);
  }
  double dimmest = INFINITY, brightest = 0;
  for (const LightingZone& z : hard.world.lighting_zones) {
    dimmest = std::min(dimmest, z.ratio);
    brightest = std::max(brightest, z.ratio);
  }
  std::printf(
      "[ LIGHTING ] hard walk: exposure x gain against the unlit walk's from x %.3f to x %.3f (zones %.1f .. "
      "%.1f)\n",
      lowest, highest, dimmest, brightest);
  // Deep in a zone most of the view is in it; the far end of the corridor less so.
  EXPECT_GT(highest, 0.8 / dimmest);
  EXPECT_LT(lowest, 1.25 / brightest);
}

// The weak stretch is plain from wall to wall: every surface that reaches into it lies within it and is weak plaster
// (walls cut at its ends, floor and ceiling patched), and nothing else stands in it.
TEST(SimWeakStretch, IsPlainFromWallToWall) {
  Scenario sc = quiet();
  sc.world.weak_stretch_m << -1.0, 5.0, 3.4, 10.0;  // the west corridor, 5 m of it
  const World world = World::build(sc.world, sc.seed);
  const World normal = World::build(quiet().world, sc.seed);
  const Eigen::Matrix<double, 4, 1>& r = sc.world.weak_stretch_m;
  const double eps = 1e-6;
  size_t inside = 0, walls = 0, horizontals = 0;
  for (const Quad& q : world.quads) {
    Eigen::Vector2d lo(INFINITY, INFINITY), hi(-INFINITY, -INFINITY);
    for (double s : {0.0, q.size_s})
      for (double u : {0.0, q.size_t}) {
        const Eigen::Vector3d c = q.origin + s * q.axis_s + u * q.axis_t;
        lo = lo.cwiseMin(c.head<2>());
        hi = hi.cwiseMax(c.head<2>());
      }
    const bool reaches_in = hi.x() > r[0] + eps && lo.x() < r[2] - eps && hi.y() > r[1] + eps && lo.y() < r[3] - eps;
    if (!reaches_in) continue;
    ++inside;
    EXPECT_GE(lo.x(), r[0] - eps);
    EXPECT_LE(hi.x(), r[2] + eps);
    EXPECT_GE(lo.y(), r[1] - eps);
    EXPECT_LE(hi.y(), r[3] + eps);
    EXPECT_EQ(world.textures[q.texture].name, "weak plaster");
    (std::abs(q.normal().z()) > 0.5 ? horizontals : walls)++;
  }
  std::printf("[ WEAK     ] %zu surfaces in the stretch: %zu wall pieces, %zu floor and ceiling\n", inside, walls,
              horizontals);
  EXPECT_GE(walls, 2u);  // the outer wall and the inner block's, each in pieces of up to 5 m
  EXPECT_EQ(horizontals, 2u);
  // Outside the stretch the building keeps its posters and objects.
  EXPECT_GT(world.quads.size(), normal.quads.size() / 2);
}
