// Trajectory, IMU and tilt sensor of the simulated head against analytic references.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <numeric>

#include "ips/config.hpp"
#include "ips/rotation.hpp"
#include "ips/sim/sensors.hpp"
#include "ips/sim/trajectory.hpp"
#include "ips/sim/world.hpp"
#include "sim_test_support.hpp"

using namespace ips::sim;
using ips::KinematicState;

namespace {

constexpr double kDeg = M_PI / 180;

double stddev(const std::vector<double>& v) {
  const double mean = std::accumulate(v.begin(), v.end(), 0.0) / v.size();
  double acc = 0;
  for (double x : v) acc += (x - mean) * (x - mean);
  return std::sqrt(acc / (v.size() - 1));
}

}  // namespace

TEST(SimTrajectory, DefaultWalkIsAbout90mInAbout2Minutes) {
  const Scenario sc = Scenario::defaults();
  const Trajectory traj(sc.trajectory, sc.gravity);
  EXPECT_NEAR(traj.pathLength(), 90, 5);
  EXPECT_NEAR(traj.duration(), 120, 10);
  // At rest at both ends, walking speed in between.
  EXPECT_LT(traj.state(0).velocity.norm(), 1e-9);
  EXPECT_LT(traj.state(traj.duration() + 1).velocity.norm(), 1e-9);
  EXPECT_NEAR(traj.state(30).velocity.head<2>().norm(), sc.trajectory.speed_mps, 0.25);
}

// Velocity, acceleration and angular rate are the exact derivatives of position and attitude (central
// differences agree to their own truncation error).
TEST(SimTrajectory, DerivativesMatchFiniteDifferences) {
  const Scenario sc = Scenario::defaults();
  const Trajectory traj(sc.trajectory, sc.gravity);
  const double h = 1e-4;
  for (double t : {0.7, 3.3, 11.9, 14.2, 40.05, 77.7}) {
    const KinematicState s = traj.state(t), a = traj.state(t - h), b = traj.state(t + h);
    const Eigen::Vector3d v_fd = (b.position - a.position) / (2 * h);
    const Eigen::Vector3d a_fd = (b.velocity - a.velocity) / (2 * h);
    EXPECT_LT((v_fd - s.velocity).norm(), 1e-6) << "t=" << t;
    EXPECT_LT((a_fd - s.acceleration).norm(), 1e-5) << "t=" << t;
    // Body rate: R(t)^T R(t+h) = exp(w h)
    const Eigen::Vector3d w_fd = ips::logQuat(a.orientation.conjugate() * b.orientation) / (2 * h);
    EXPECT_LT((w_fd - s.angular_rate).norm(), 1e-5) << "t=" << t;
  }
}

// The waved head (config/sim_imu_calib.yaml): still at the start, then turned about all three axes by the configured
// amplitudes while it stays within a few centimetres of its place; its derivatives exact as the walk's.
TEST(SimTrajectory, WaveTurnsAboutAllAxesInPlace) {
  const Scenario sc = Scenario::load(std::string(IPS_CONFIG_DIR) + "/sim_imu_calib.yaml");
  const Trajectory traj(sc.trajectory, sc.gravity);
  EXPECT_DOUBLE_EQ(traj.duration(), sc.trajectory.start_still_s + sc.trajectory.still_duration_s);
  EXPECT_LT(traj.state(1.0).angular_rate.norm(), 1e-12);  // still start: the filter and the tracker settle
  Eigen::Vector3d peak_rate = Eigen::Vector3d::Zero();
  double farthest_m = 0;
  const Eigen::Vector3d place(sc.trajectory.waypoints.front().x(), sc.trajectory.waypoints.front().y(),
                              sc.trajectory.height_m);
  const double h = 1e-4;
  for (double t = sc.trajectory.start_still_s; t < traj.duration(); t += 0.01) {
    const KinematicState s = traj.state(t);
    peak_rate = peak_rate.cwiseMax(s.angular_rate.cwiseAbs());
    farthest_m = std::max(farthest_m, (s.position - place).norm());
    if (std::fmod(t, 7.0) < 0.01) {
      const KinematicState a = traj.state(t - h), b = traj.state(t + h);
      const Eigen::Vector3d w_fd = ips::logQuat(a.orientation.conjugate() * b.orientation) / (2 * h);
      EXPECT_LT((w_fd - s.angular_rate).norm(), 1e-5) << "t=" << t;
      EXPECT_LT(((b.velocity - a.velocity) / (2 * h) - s.acceleration).norm(), 1e-5) << "t=" << t;
    }
  }
  // Each axis at least 2 pi A / P of its own turn less what the others take away (about 10 deg/s here).
  for (int axis = 0; axis < 3; ++axis)
    EXPECT_GT(peak_rate[axis],
              0.5 * 2 * M_PI * sc.trajectory.wave_amplitude_deg[axis] * kDeg / sc.trajectory.wave_period_s[axis])
        << "axis " << axis;
  EXPECT_LT(farthest_m, 0.1);
}

// Strapdown integration of the ideal IMU (200 Hz) reproduces the trajectory.
TEST(SimImu, NoiseFreeIntegrationReproducesTrajectory) {
  const Scenario sc = Scenario::defaults();
  const Trajectory traj(sc.trajectory, sc.gravity);
  ImuSimulator imu(ImuFigures::ideal(), traj, sc.start_utime, 7);
  const double duration = 20.0;  // start, corridor, turn into the room
  KinematicState s0 = traj.state(0);
  test_support::Strapdown nav(s0, sc.gravity);
  ImuMeasurement prev = imu.next();
  double max_pos_err = 0, max_att_err = 0;
  while (true) {
    const ImuMeasurement cur = imu.next();
    const double t = (cur.utime_true - sc.start_utime) * 1e-6;
    if (t > duration) break;
    nav.step(prev, cur);
    const KinematicState s = traj.state(t);
    max_pos_err = std::max(max_pos_err, (nav.p - s.position).norm());
    max_att_err = std::max(max_att_err, ips::logQuat(s.orientation.conjugate() * nav.q).norm());
    prev = cur;
  }
  const KinematicState end = traj.state(duration);
  EXPECT_GT((end.position - s0.position).norm(), 8.0);  // it really moved
  std::cout << "ideal IMU integrated over " << duration << " s: max position error " << max_pos_err
            << " m, max attitude error " << max_att_err / kDeg << " deg\n";
  EXPECT_LT(max_pos_err, 0.005) << "max position error [m]";
  EXPECT_LT(max_att_err, 0.003 * kDeg) << "max attitude error [rad]";
}

// Standing still: measured - true - bias is white noise with the configured density; the biases walk as
// configured; the constant biases have the configured spread over seeds.
TEST(SimImu, NoiseStatisticsMatchFigures) {
  Scenario sc = Scenario::defaults();
  sc.trajectory.type = "still";
  sc.trajectory.still_duration_s = 100;
  const Trajectory traj(sc.trajectory, sc.gravity);
  ImuSimulator imu(sc.imu, traj, sc.start_utime, 3);
  std::vector<double> gyro_err[3], accel_err[3], dbg, dba;
  Eigen::Vector3d last_bg = Eigen::Vector3d::Zero(), last_ba = Eigen::Vector3d::Zero();
  for (int k = 0; k < 20000; ++k) {
    const ImuMeasurement m = imu.next();
    const KinematicState s = traj.state((m.utime_true - sc.start_utime) * 1e-6);
    for (int i = 0; i < 3; ++i) {
      gyro_err[i].push_back(m.angular_rate[i] - s.angular_rate[i] - m.gyro_bias[i]);
      accel_err[i].push_back(m.specific_force[i] - s.specificForce(sc.gravity)[i] - m.accel_bias[i]);
      if (k > 0) {
        dbg.push_back(m.gyro_bias[i] - last_bg[i]);
        dba.push_back(m.accel_bias[i] - last_ba[i]);
      }
    }
    last_bg = m.gyro_bias;
    last_ba = m.accel_bias;
  }
  // Expected: 0.3 deg/sqrt(h) and 0.5 mg/sqrt(Hz) at 200 Hz (quantisation adds lsb^2/12, under 1 %).
  const double gyro_sigma = 0.3 * kDeg / 60 * std::sqrt(200.0);
  const double accel_sigma = 0.5e-3 * 9.80665 * std::sqrt(200.0);
  EXPECT_NEAR(imu.gyroNoiseSigma(), gyro_sigma, 1e-12);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(stddev(gyro_err[i]) / gyro_sigma, 1.0, 0.03) << "axis " << i;
    EXPECT_NEAR(stddev(accel_err[i]) / accel_sigma, 1.0, 0.03) << "axis " << i;
    const double mean = std::accumulate(gyro_err[i].begin(), gyro_err[i].end(), 0.0) / gyro_err[i].size();
    EXPECT_LT(std::abs(mean), 4 * gyro_sigma / std::sqrt(20000.0));
  }
  EXPECT_NEAR(stddev(dbg) / (sc.imu.gyro_bias_walk_deg_s_sqrt_s * kDeg / std::sqrt(200.0)), 1.0, 0.03);
  EXPECT_NEAR(stddev(dba) / (sc.imu.accel_bias_walk_mg_sqrt_s * 9.80665e-3 / std::sqrt(200.0)), 1.0, 0.03);
  // Turn-on biases over many seeds.
  std::vector<double> b0;
  for (uint64_t seed = 0; seed < 400; ++seed) {
    ImuSimulator other(sc.imu, traj, sc.start_utime, seed);
    b0.push_back(other.next().gyro_bias.x());
  }
  EXPECT_NEAR(stddev(b0) / (sc.imu.gyro_bias_deg_s * kDeg), 1.0, 0.12);
}

TEST(SimImu, QuantisationAndSaturation) {
  Scenario sc = Scenario::defaults();
  const Trajectory traj(sc.trajectory, sc.gravity);
  ImuFigures f = sc.imu;
  f.gyro_range_deg_s = 5;  // the walk turns faster than that
  ImuSimulator imu(f, traj, sc.start_utime, 1);
  const double lsb = f.gyro_lsb_deg_s * kDeg;
  double max_rate = 0;
  for (int k = 0; k < 200 * 30; ++k) {
    const ImuMeasurement m = imu.next();
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(m.angular_rate[i] / lsb, std::round(m.angular_rate[i] / lsb), 1e-6);
      max_rate = std::max(max_rate, std::abs(m.angular_rate[i]));
    }
  }
  EXPECT_LE(max_rate, 5 * kDeg + lsb);
  EXPECT_GT(max_rate, 4.9 * kDeg);
}

// Tilt sensor standing still: error = constant offset + noise, quantised to the resolution; offsets spread
// with the configured accuracy over seeds. Under acceleration it reads the specific force's inclination.
TEST(SimTilt, StatisticsAndResponseToAcceleration) {
  Scenario sc = Scenario::defaults();
  sc.trajectory.type = "still";
  const Trajectory still(sc.trajectory, sc.gravity);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(2 * kDeg, Eigen::Vector3d::UnitY()).toRotationMatrix();
  TiltSimulator tilt(sc.tilt, still, R, sc.start_utime, sc.gravity, 5);
  std::vector<double> ex, ey;
  const double res = sc.tilt.resolution_deg * kDeg;
  for (int k = 0; k < 800; ++k) {
    const TiltMeasurement m = tilt.next();
    EXPECT_NEAR(m.angle_x / res, std::round(m.angle_x / res), 1e-6);
    ex.push_back(m.angle_x - m.true_angle_x);
    ey.push_back(m.angle_y - m.true_angle_y);
  }
  // The head is pitched nose down by pitch_down_deg; R_tilt_imu = Ry(2 deg) turns the sensor's x axis 2 deg
  // back up (v_tilt = R v_imu), so it reads 2 deg less.
  EXPECT_NEAR(tilt.next().true_angle_x, -(sc.trajectory.pitch_down_deg - 2) * kDeg, 1e-9);
  const double expected = std::sqrt(std::pow(sc.tilt.noise_deg * kDeg, 2) + res * res / 12);
  EXPECT_NEAR(stddev(ex) / expected, 1.0, 0.12);
  EXPECT_NEAR(stddev(ey) / expected, 1.0, 0.12);
  const double mean_x = std::accumulate(ex.begin(), ex.end(), 0.0) / ex.size();
  EXPECT_NEAR(mean_x, tilt.offset().x(), 0.01 * kDeg);
  std::vector<double> offsets;
  for (uint64_t seed = 0; seed < 400; ++seed)
    offsets.push_back(TiltSimulator(sc.tilt, still, R, sc.start_utime, sc.gravity, seed).offset().y());
  EXPECT_NEAR(stddev(offsets) / (sc.tilt.accuracy_deg * kDeg), 1.0, 0.12);

  // Walking: an ideal sensor without lag reads the inclination of the specific force, not of gravity.
  const Scenario walk = Scenario::defaults();
  const Trajectory traj(walk.trajectory, walk.gravity);
  TiltSimulator ideal(TiltFigures::ideal(), traj, Eigen::Matrix3d::Identity(), walk.start_utime, walk.gravity, 1);
  double max_diff_from_gravity = 0;
  for (int k = 0; k < 14 * 20; ++k) {
    const TiltMeasurement m = ideal.next();
    const KinematicState s = traj.state((m.utime_true - walk.start_utime) * 1e-6);
    const Eigen::Vector2d expect = inclination(s.specificForce(walk.gravity));
    EXPECT_NEAR(m.angle_x, expect.x(), 1e-12);
    EXPECT_NEAR(m.angle_y, expect.y(), 1e-12);
    max_diff_from_gravity = std::max(max_diff_from_gravity, std::abs(m.angle_x - m.true_angle_x));
  }
  EXPECT_GT(max_diff_from_gravity, 0.5 * kDeg);  // the bounce of walking shows
}

TEST(SimScenario, ConfigFilesLoadAndBadValuesAreNamed) {
  for (const char* name :
       {"sim_walk.yaml", "sim_vehicle.yaml", "sim_still.yaml", "sim_imu_calib.yaml", "sim_imu_calib_askew.yaml",
        "sim_tilt_calib.yaml", "sim_stereo_calib.yaml", "sim_hard.yaml"}) {
    const Scenario sc = Scenario::load(std::string(IPS_CONFIG_DIR) + "/" + name);
    const Trajectory traj(sc.trajectory, sc.gravity);
    EXPECT_GT(traj.duration(), 10) << name;
  }
  const Scenario walk = Scenario::load(std::string(IPS_CONFIG_DIR) + "/sim_walk.yaml");
  const Scenario def = Scenario::defaults();
  EXPECT_EQ(walk.trajectory.waypoints.size(), def.trajectory.waypoints.size());
  EXPECT_DOUBLE_EQ(walk.imu.gyro_arw_deg_sqrt_h, def.imu.gyro_arw_deg_sqrt_h);
  const std::string bad = testing::TempDir() + "/bad_scenario.yaml";
  {
    cv::FileStorage fs(bad, cv::FileStorage::WRITE);
    fs << "camera"
       << "{"
       << "rate_hz" << -3 << "}";
  }
  try {
    Scenario::load(bad);
    FAIL() << "no exception";
  } catch (const ips::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("rate_hz"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("bad_scenario.yaml"), std::string::npos) << e.what();
  }
  EXPECT_THROW(Scenario::load("/nonexistent/sim.yaml"), ips::ConfigError);

  // A variant names its base and says only what differs.
  const Scenario askew = Scenario::load(std::string(IPS_CONFIG_DIR) + "/sim_imu_calib_askew.yaml");
  const Scenario waved = Scenario::load(std::string(IPS_CONFIG_DIR) + "/sim_imu_calib.yaml");
  EXPECT_EQ(askew.trajectory.type, "wave");
  EXPECT_EQ(askew.trajectory.wave_period_s, waved.trajectory.wave_period_s);
  EXPECT_EQ(askew.camera.stamp_offset_us, 3700);
  EXPECT_EQ(waved.camera.stamp_offset_us, def.camera.stamp_offset_us);
  EXPECT_EQ(askew.name, "imu_calib_askew");
  // A base that names itself nests without end: refused, naming the file.
  const std::string looping = testing::TempDir() + "/looping_scenario.yaml";
  {
    FILE* f = std::fopen(looping.c_str(), "w");
    ASSERT_NE(f, nullptr);
    std::fputs("%YAML:1.0\n---\nbase: looping_scenario.yaml\n", f);
    std::fclose(f);
  }
  try {
    Scenario::load(looping);
    FAIL() << "no exception";
  } catch (const ips::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("base"), std::string::npos) << e.what();
  }
}

// The walk and the vehicle stay clear of every surface of the building (walls, door frame, cabinets): the head
// never enters an object, and the cameras always see the building from inside.
TEST(SimTrajectory, RoutesStayClearOfTheBuilding) {
  for (const char* name : {"sim_walk.yaml", "sim_vehicle.yaml", "sim_hard.yaml"}) {  // the hard one over its ramp
    const Scenario sc = Scenario::load(std::string(IPS_CONFIG_DIR) + "/" + name);
    const World world = World::build(sc.world, sc.seed);
    const Trajectory traj(sc.trajectory, sc.gravity);
    double min_dist = 1e9;
    for (double t = 0; t <= traj.duration(); t += 0.05) {
      const Eigen::Vector3d p = traj.state(t).position;
      for (const Quad& q : world.quads) {
        const Eigen::Vector3d r = p - q.origin;
        const double s = std::clamp(r.dot(q.axis_s), 0.0, q.size_s), u = std::clamp(r.dot(q.axis_t), 0.0, q.size_t);
        min_dist = std::min(min_dist, (r - s * q.axis_s - u * q.axis_t).norm());
      }
    }
    std::cout << name << ": nearest surface " << min_dist << " m\n";
    EXPECT_GT(min_dist, 0.3) << name;
  }
}

// The calibration the processes are told: the truth by default; with calibration_errors the truth moved by
// errors whose spread over many seeds is the configured one (per axis for rotations: the mean squared angle of
// a rotation with three independent axes of standard deviation s is 3 s^2), the same for one seed every time,
// and written with its source so that a run can say what it ran on.
// The head as designed, where the calibration tools start: nominal pinhole cameras, parallel at the nominal baseline,
// IMU and tilt sensor on the head's axes at the drawn lever arm; the true head is within its drawn errors of it.
TEST(SimHead, DesignIsTheNominalHead) {
  const Scenario sc = Scenario::defaults();
  const ips::StereoCalibration design = SensorHead::design(sc);
  const SensorHead head = SensorHead::make(sc);
  EXPECT_EQ(design.source, "design");
  EXPECT_DOUBLE_EQ(design.cam0.K(0, 0), sc.camera.focal_px);
  EXPECT_DOUBLE_EQ(design.cam1.K(1, 2), (sc.camera.height - 1) * 0.5);
  EXPECT_TRUE(design.cam0.distortion.isZero());
  EXPECT_TRUE(design.R_cam1_cam0.isIdentity());
  EXPECT_DOUBLE_EQ(design.baseline(), sc.camera.baseline_m);
  EXPECT_EQ(design.T_imu_cam0.translation(), head.calibration.T_imu_cam0.translation());
  // The IMU's misalignment (5 mrad per axis) and the tilt sensor's (1 deg per axis) separate the truth from it.
  const double imu_deg =
      Eigen::AngleAxisd(design.T_imu_cam0.linear().transpose() * head.calibration.T_imu_cam0.linear()).angle() / kDeg;
  const double tilt_deg =
      Eigen::AngleAxisd(design.R_tilt_cam0.transpose() * head.calibration.R_tilt_cam0).angle() / kDeg;
  EXPECT_GT(imu_deg, 0.01);
  EXPECT_LT(imu_deg, 5 * std::sqrt(3.0) * sc.imu.misalignment_mrad * 1e-3 / kDeg);
  EXPECT_GT(tilt_deg, 0.05);
  EXPECT_LT(tilt_deg, 5 * std::sqrt(3.0) * sc.tilt.misalignment_deg);
}

TEST(SimHead, CalibrationForProcessesCarriesTheConfiguredErrors) {
  Scenario sc = Scenario::defaults();
  const SensorHead head = SensorHead::make(sc);
  const ips::StereoCalibration same = head.calibrationForProcesses(sc);
  EXPECT_EQ(same.source, "true");
  EXPECT_EQ(same.cam0.K, head.calibration.cam0.K);
  EXPECT_EQ(same.R_cam1_cam0, head.calibration.R_cam1_cam0);

  CalibrationErrors& e = sc.calibration_errors;
  e.focal_rel = 5e-4;
  e.principal_px = 0.3;
  e.stereo_rotation_deg = 0.01;
  e.imu_rotation_deg = 0.05;
  e.tilt_rotation_deg = 0.05;
  std::vector<double> focal, principal;
  double stereo_sq = 0, imu_sq = 0, tilt_sq = 0;
  const int seeds = 400;
  for (int seed = 1; seed <= seeds; ++seed) {
    sc.seed = seed;
    const SensorHead h = SensorHead::make(sc);
    const ips::StereoCalibration told = h.calibrationForProcesses(sc);
    ASSERT_EQ(told.source, "perturbed");
    for (auto [t, c] : {std::pair{&told.cam0, &h.calibration.cam0}, std::pair{&told.cam1, &h.calibration.cam1}}) {
      focal.push_back(t->K(0, 0) / c->K(0, 0) - 1);
      EXPECT_NEAR(t->K(1, 1) / c->K(1, 1), t->K(0, 0) / c->K(0, 0), 1e-12) << "one focal length, both axes";
      principal.push_back(t->K(0, 2) - c->K(0, 2));
      principal.push_back(t->K(1, 2) - c->K(1, 2));
    }
    const auto angle = [](const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
      return Eigen::AngleAxisd(a * b.transpose()).angle() / kDeg;
    };
    stereo_sq += std::pow(angle(told.R_cam1_cam0, h.calibration.R_cam1_cam0), 2);
    imu_sq += std::pow(angle(told.T_imu_cam0.linear(), h.calibration.T_imu_cam0.linear()), 2);
    tilt_sq += std::pow(angle(told.R_tilt_cam0, h.calibration.R_tilt_cam0), 2);
    // The right camera turns about its own centre: its position in camera 0 stays.
    EXPECT_NEAR((told.R_cam1_cam0.transpose() * told.t_cam1_cam0 -
                 h.calibration.R_cam1_cam0.transpose() * h.calibration.t_cam1_cam0)
                    .norm(),
                0, 1e-12);
    EXPECT_EQ(told.T_imu_cam0.translation(), h.calibration.T_imu_cam0.translation());
  }
  // 800 focal samples, 1600 principal ones, 400 rotations: the spread within 10 % (about 3 standard errors).
  EXPECT_NEAR(stddev(focal), e.focal_rel, 0.1 * e.focal_rel);
  EXPECT_NEAR(stddev(principal), e.principal_px, 0.1 * e.principal_px);
  EXPECT_NEAR(std::sqrt(stereo_sq / seeds / 3), e.stereo_rotation_deg, 0.1 * e.stereo_rotation_deg);
  EXPECT_NEAR(std::sqrt(imu_sq / seeds / 3), e.imu_rotation_deg, 0.1 * e.imu_rotation_deg);
  EXPECT_NEAR(std::sqrt(tilt_sq / seeds / 3), e.tilt_rotation_deg, 0.1 * e.tilt_rotation_deg);

  // One seed gives one perturbation, and the file keeps it with its source.
  sc.seed = 7;
  const SensorHead h7 = SensorHead::make(sc);
  const ips::StereoCalibration a = h7.calibrationForProcesses(sc), b = h7.calibrationForProcesses(sc);
  EXPECT_EQ(a.cam1.K, b.cam1.K);
  const std::string file = testing::TempDir() + "/perturbed.calib.yaml";
  ips::saveCalibration(file, a);
  const ips::StereoCalibration loaded = ips::loadCalibration(file);
  EXPECT_EQ(loaded.source, "perturbed");
  EXPECT_NEAR((loaded.cam0.K - a.cam0.K).norm(), 0, 1e-9);
  EXPECT_NEAR((loaded.R_tilt_cam0 - a.R_tilt_cam0).norm(), 0, 1e-9);
}

TEST(SimScenario, EffectsAreNamedForTheReport) {
  EXPECT_TRUE(simEffects(Scenario::defaults()).empty());
  EXPECT_TRUE(simEffects(Scenario::load(std::string(IPS_CONFIG_DIR) + "/sim_walk.yaml")).empty());
  const Scenario hard = Scenario::load(std::string(IPS_CONFIG_DIR) + "/sim_hard.yaml");
  EXPECT_EQ(simEffects(hard),
            (std::vector<std::string>{"motion_blur", "auto_exposure", "vignetting", "frame_loss", "stamp_offsets",
                                      "perturbed_calibration", "people", "lighting_zones", "ramp", "weak_stretch"}));
  EXPECT_EQ(simEffects(Scenario::load(std::string(IPS_CONFIG_DIR) + "/sim_knock.yaml")),
            std::vector<std::string>{"camera_knock"});
  EXPECT_EQ(simEffects(Scenario::load(std::string(IPS_CONFIG_DIR) + "/sim_weak.yaml")),
            std::vector<std::string>{"weak_texture"});
}
