// filter_sim_eval: both filters on the project simulator's sensor head (ips_sim): its default walk (~90 m in
// 2 minutes), its IMU (MMQ-50 figures incl. turn-on biases, bias walk, quantisation, misalignment) and tilt
// sensor (specific force through a lag, constant offset, quantisation), and a tracker delta per image made
// from the true relative pose of camera 0 plus noise (the renderer + tracker chain is not run here).
// Monte Carlo over seeds: end-point error as % of distance, ATE, NEES of the pose. The filter starts from a draw
// around the truth at t = 0, or with --static-start initialises itself while the head stands still.
//
//   filter_sim_eval [--runs 5] [--seed 1] [--scenario sim.yaml] [--config filter.yaml] [--no-tilt] [--static-start]
//                   [--tracker-sigma-t 0.002] [--tracker-sigma-r 1e-4] [--out-dir DIR]
// Last line: ekf_endpoint_pct=.. ekf_anees=.. ukf_endpoint_pct=.. ukf_anees=..
#include <Eigen/Cholesky>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "ips/args.hpp"
#include "ips/config.hpp"
#include "ips/eval/filter_testbed.hpp"
#include "ips/eval/trajectory.hpp"
#include "ips/filter/models.hpp"
#include "ips/log.hpp"
#include "ips/random_vector.hpp"
#include "ips/sim/scenario.hpp"
#include "ips/sim/sensors.hpp"
#include "ips/sim/simulation.hpp"
#include "ips/sim/trajectory.hpp"

using namespace ips::filter;
using namespace ips::eval;

int main(int argc, char** argv) {
  ips::setLogLevel(ips::LogLevel::Warn);
  try {
    ips::Args args(argc, argv, "both filters on the simulator's sensor head, Monte Carlo over seeds");
    args.option("--runs", "N", "runs with the seeds S..S+N-1", "5")
        .option("--seed", "S", "first seed", "1")
        .option("--scenario", "FILE.yaml", "scenario (default: built-in walk)")
        .option("--config", "FILE", "filter configuration (section filter; default: built-in)")
        .option("--out-dir", "DIR", "TUM files and plots of run 0", ".")
        .flag("--no-tilt", "without the tilt sensor")
        .flag("--static-start", "the filter initialises itself while the head stands still")
        .option("--tracker-sigma-t", "M", "noise of the tracker deltas' translation", "0.002")
        .option("--tracker-sigma-r", "RAD", "noise of the tracker deltas' rotation", "1e-4");
    if (!args.parse()) return 0;
    const int runs = static_cast<int>(args.getInt("--runs"));
    const unsigned seed = static_cast<unsigned>(args.getInt("--seed"));
    const std::string scenario_path = args.get("--scenario"), config = args.get("--config");
    const std::string out_dir = args.get("--out-dir");
    const bool use_tilt = !args.getFlag("--no-tilt"), static_start = args.getFlag("--static-start");
    const double sigma_t = args.getDouble("--tracker-sigma-t"), sigma_r = args.getDouble("--tracker-sigma-r");
    FilterParams base;
    if (!config.empty()) {
      const ips::Config cfg(config);
      base = loadFilterParams(cfg.section("filter"));
      cfg.refuseUnreadKeys();
    }
    std::filesystem::create_directories(out_dir);
    std::string summary;
    for (FilterType type : {FilterType::Ekf, FilterType::Ukf}) {
      FilterParams params = base;
      params.type = type;
      double endpoint_sum = 0, ate_sum = 0, nees_sum = 0, dist = 0;
      int nees_n = 0;
      long long tilt_rej = 0, tilt_acc = 0, imu_rej = 0, trk_rej = 0;
      for (int run = 0; run < runs; ++run) {
        ips::sim::Scenario sc =
            scenario_path.empty() ? ips::sim::Scenario::defaults() : ips::sim::Scenario::load(scenario_path);
        sc.seed = seed + static_cast<unsigned>(run);
        const ips::sim::Trajectory traj(sc.trajectory, sc.gravity);
        const ips::sim::SensorHead head = ips::sim::SensorHead::make(sc);
        ips::sim::ImuSimulator imu(sc.imu, traj, sc.start_utime, sc.seed);
        ips::sim::TiltSimulator tilt(sc.tilt, traj, head.R_tilt_imu, sc.start_utime, sc.gravity, sc.seed);
        // The drivers remove the known latency; the filter sees stamps at sensor time (+ jitter).
        params.imu_latency_us = static_cast<int64_t>(sc.imu.stamp_offset_us);
        params.tilt_latency_us = static_cast<int64_t>(sc.tilt.stamp_offset_us);
        params.gravity = sc.gravity;
        if (static_start) {
          // What a deployment's config states: where the head stands and where it looks (yaw of body x).
          const ips::KinematicState s0 = traj.state(0.0);
          const Eigen::Vector3d x_axis = s0.orientation * Eigen::Vector3d::UnitX();
          params.init.heading_rad = std::atan2(x_axis.y(), x_axis.x());
          params.init.position = s0.position;
        }
        Estimator est(params, head.calibration);
        std::mt19937 rng(sc.seed * 7919u + 17u);
        std::normal_distribution<double> n01;
        auto normal3 = [&] { return ips::drawVector3([&] { return n01(rng); }); };
        auto truthAt = [&](int64_t utime, const Eigen::Vector3d& bg, const Eigen::Vector3d& ba) {
          return ips::eval::navStateOf(ips::sim::groundTruthAt(traj, sc.start_utime, utime, bg, ba));
        };
        // Start at t = 0 (the head stands still) from a draw around the truth with the configured covariance.
        ips::sim::ImuMeasurement m = imu.next();
        const Matrix21d P0 = initialCovariance(params.init);
        if (!static_start) {
          Vector21d z;
          for (int i = 0; i < 21; ++i) z(i) = n01(rng);
          const Vector21d dx = Eigen::LLT<Matrix21d>(P0).matrixL() * z;
          est.initialize(boxplus(truthAt(m.utime_true, m.gyro_bias, m.accel_bias), dx), P0);
        }
        ips::sim::TiltMeasurement tm = tilt.next();
        const int64_t img_dt = static_cast<int64_t>(std::llround(1e6 / sc.camera.rate_hz));
        int64_t next_img = sc.start_utime + img_dt, last_img = -1;
        const int64_t end = sc.start_utime + static_cast<int64_t>((traj.duration() + 1.0) * 1e6);
        std::vector<FilterOutput> out;
        std::vector<NavState> truth;
        while (true) {
          m = imu.next();
          if (m.utime_true > end) break;
          while (use_tilt && tm.utime_true <= m.utime_true) {
            est.addTilt({tm.utime_stamp, tm.angle_x, tm.angle_y});
            tm = tilt.next();
          }
          while (next_img <= m.utime_true) {
            est.addImageTime(next_img);
            if (last_img >= 0) {
              const Eigen::Isometry3d T0 = head.cam0InWorld(traj.pose((last_img - sc.start_utime) * 1e-6));
              const Eigen::Isometry3d T1 = head.cam0InWorld(traj.pose((next_img - sc.start_utime) * 1e-6));
              const Eigen::Isometry3d T = T0.inverse() * T1;
              TrackerDelta d;
              d.utime = next_img;
              d.utime_prev = last_img;
              d.translation = T.translation() + sigma_t * normal3();
              d.rotation = Eigen::Quaterniond(expSO3(sigma_r * normal3()) * T.linear()).normalized();
              d.covariance.setZero();
              d.covariance.diagonal() << Eigen::Vector3d::Constant(sigma_t * sigma_t),
                  Eigen::Vector3d::Constant(sigma_r * sigma_r);
              est.addTrackerDelta(d);
            }
            last_img = next_img;
            next_img += img_dt;
          }
          est.addImu({m.utime_stamp, m.angular_rate, m.specific_force});
          for (FilterOutput& o : est.takeOutputs()) {
            truth.push_back(truthAt(o.state.utime, m.gyro_bias, m.accel_bias));
            out.push_back(std::move(o));
          }
        }
        est.flush();
        Trajectory e = toTrajectory(out), r;
        for (const NavState& t : truth) r.push_back({t.utime * 1e-6, t.position, t.orientation});
        const TrajectoryErrors err = evaluate(e, r, 10.0);
        endpoint_sum += err.endpoint_percent;
        ate_sum += err.ate_rmse_m;
        dist = err.distance_m;
        for (size_t i = 200; i < out.size(); i += 200) {
          nees_sum += poseNees(out[i], truth[i]);
          ++nees_n;
        }
        tilt_acc += est.counters()[kSensorTilt].accepted;
        tilt_rej += est.counters()[kSensorTilt].rejected;
        imu_rej += est.counters()[kSensorImu].rejected;
        trk_rej += est.counters()[kSensorTracker].rejected;
        if (run == 0) {
          writeTum(out_dir + "/sim_" + toString(type) + "_run0.tum", e);
          writeTum(out_dir + "/sim_ground_truth.tum", r);
          plotTopDown(out_dir + "/sim_" + toString(type) + ".png", r, {e}, {toString(type)});
        }
      }
      const double anees = nees_sum / std::max(1, nees_n);
      std::printf(
          "filter=%s runs=%d distance_m=%.1f endpoint_pct_mean=%.4f ate_rmse_m=%.4f anees_pose=%.3f "
          "tilt_accepted=%lld tilt_rejected=%lld imu_rejected=%lld tracker_rejected=%lld\n",
          toString(type).c_str(), runs, dist, endpoint_sum / runs, ate_sum / runs, anees, tilt_acc, tilt_rej, imu_rej,
          trk_rej);
      char buf[160];
      std::snprintf(buf, sizeof buf, "%s%s_endpoint_pct=%.4f %s_anees=%.3f", summary.empty() ? "" : " ",
                    toString(type).c_str(), endpoint_sum / runs, toString(type).c_str(), anees);
      summary += buf;
    }
    std::printf("%s\n", summary.c_str());
  } catch (const ips::ArgError& e) {
    std::fprintf(stderr, "%s\n", e.what());  // names the program and the option
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "filter_sim_eval: %s\n", e.what());
    return 1;
  }
  return 0;
}
