#include "ips/eval/tracker_on_sim.hpp"

#include <chrono>
#include <cmath>

#include "ips/sim/rig.hpp"

namespace ips::eval {

std::vector<SimFrameError> runTrackerOnSimulation(const std::string& scenario_path, double duration_s,
                                                  const tracker::TrackerParams& params, SimPrior prior_mode,
                                                  const std::function<void(const SimFrameError&)>& each,
                                                  const SimGuide& guide, const StereoCalibration* told) {
  const sim::Scenario sc = scenario_path.empty() ? sim::Scenario::defaults() : sim::Scenario::load(scenario_path);
  const sim::Rig rig(sc);
  sim::ImuSimulator imu(sc.imu, rig.trajectory, sc.start_utime, sc.seed);
  sim::ImuMeasurement next_imu = imu.next();

  tracker::StereoTracker tracker(told ? *told : rig.head.calibration, params);
  const int64_t frames = int64_t(std::floor(duration_s * sc.camera.rate_hz)) + 1;
  std::vector<SimFrameError> out;
  Eigen::Isometry3d prev_cam = Eigen::Isometry3d::Identity();
  int64_t prev_utime = 0;
  for (int64_t k = 0; k < frames; ++k) {
    const sim::StereoFrame f = rig.renderer.render(k);
    // Gyro rates between the two pairs (bias-free as a calibrated filter would give them).
    Eigen::Vector3d omega_sum = Eigen::Vector3d::Zero();
    int n_imu = 0;
    while (next_imu.utime_true <= f.utime_true) {
      if (next_imu.utime_true > prev_utime) {
        omega_sum += next_imu.angular_rate - next_imu.gyro_bias;
        ++n_imu;
      }
      next_imu = imu.next();
    }
    const Eigen::Isometry3d cam = rig.head.cam0InWorld(rig.trajectory.pose((f.utime_true - sc.start_utime) * 1e-6));
    tracker::MotionPrior prior;
    const tracker::MotionPrior* prior_ptr = nullptr;
    if (k > 0 && prior_mode == SimPrior::Imu && n_imu > 0) {
      const double dt = (f.utime_stamp - prev_utime) * 1e-6;
      prior =
          tracker::MotionPrior::fromImuRates(omega_sum / n_imu, rig.head.T_imu_cam0.linear(), dt, 0.01, params.prior);
      prior_ptr = &prior;
    } else if (prior_mode == SimPrior::None) {
      prior_ptr = &prior;  // source None: widest windows every time
    }
    const tracker::TrackResult r =
        tracker.process(f.utime_stamp, f.left, f.right, prior_ptr, guide ? guide(tracker, f) : nullptr);
    if (k > 0) {
      SimFrameError e;
      e.frame = k;
      e.result = r;
      const Eigen::Isometry3d truth = prev_cam.inverse() * cam;
      e.truth = truth;
      e.step_m = truth.translation().norm();
      e.step_deg = tracker::logSO3(truth.linear()).norm() * 180.0 / M_PI;
      if (r.valid) {
        e.rot_err_deg =
            tracker::logSO3(r.rotation.toRotationMatrix().transpose() * truth.linear()).norm() * 180.0 / M_PI;
        e.trans_err_m = (r.translation - truth.translation()).norm();
      }
      if (each) each(e);
      out.push_back(e);
    }
    prev_cam = cam;
    prev_utime = f.utime_stamp;
  }
  return out;
}

void runIntegrityOnSimulation(const sim::Scenario& sc, double duration_s, const tracker::TrackerParams& params,
                              const tracker::IntegrityParams& integrity,
                              const std::function<bool(int64_t)>& with_disparity,
                              const std::function<void(const SimIntegrityFrame&)>& each) {
  const sim::Rig rig(sc);
  const StereoCalibration told = rig.head.calibrationForProcesses(sc);
  tracker::StereoTracker tracker(told, params);
  tracker::EpipolarMonitor monitor(tracker.rectification(), integrity);
  const Eigen::Matrix3d R_rect1_cam1 = tracker.rectification().R_rect1_cam1;
  const int64_t frames = int64_t(std::floor(duration_s * sc.camera.rate_hz)) + 1;
  for (int64_t k = 0; k < frames; ++k) {
    const sim::StereoFrame f = rig.renderer.render(k, with_disparity && with_disparity(k));
    SimIntegrityFrame out;
    out.frame = k;
    out.t = (f.utime_true - sc.start_utime) * 1e-6;
    tracker.process(f.utime_stamp, f.left, f.right);
    const auto t0 = std::chrono::steady_clock::now();
    out.status = &tracker::monitorPair(monitor, tracker, f.utime_stamp);
    out.monitor_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    out.pair = &f;
    out.told = &told;
    out.truth = R_rect1_cam1 * tracker::logSO3(rig.head.cam1Turn(out.t));
    each(out);
  }
}

}  // namespace ips::eval
