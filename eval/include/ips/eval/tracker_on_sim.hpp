#pragma once
// The tracker on the simulated sensor head (ips_sim): renders a scenario's stereo pairs (raw, distorted, with
// noise and gain as the cameras deliver them), tracks them with the head's calibration and compares each delta
// with the ground-truth motion of camera 0 between the two exposure times. Shared by tracker_sim_eval and the
// simulation test.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <chrono>
#include <functional>
#include <string>
#include <vector>

#include "ips/sim/rig.hpp"
#include "ips/sim/scenario.hpp"
#include "ips/sim/sensors.hpp"
#include "ips/sim/trajectory.hpp"
#include "ips/tracker/epipolar_integrity.hpp"
#include "ips/tracker/stereo_tracker.hpp"

namespace ips::eval {

enum class SimPrior { None, ConstantVelocity, Imu };

struct SimFrameError {
  int64_t frame = 0;
  tracker::TrackResult result;
  double step_m = 0, step_deg = 0;                          // true motion of camera 0 since the previous pair
  double rot_err_deg = 0, trans_err_m = 0;                  // of the estimate against it
  Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();  // that true motion (camera 0 now in camera 0 before)
};

// A disparity map of a rendered pair for the tracker's intra-matching (nullptr: the tracker's own search).
using SimGuide = std::function<const tracker::DisparityGuide*(const tracker::StereoTracker&, const sim::StereoFrame&)>;

// Frames 0 .. floor(duration * rate); `each` sees every frame after the first.
inline std::vector<SimFrameError> runTrackerOnSimulation(const std::string& scenario_path, double duration_s,
                                                         const tracker::TrackerParams& params, SimPrior prior_mode,
                                                         const std::function<void(const SimFrameError&)>& each = {},
                                                         const SimGuide& guide = {}) {
  const sim::Scenario sc = scenario_path.empty() ? sim::Scenario::defaults() : sim::Scenario::load(scenario_path);
  const sim::Rig rig(sc);
  sim::ImuSimulator imu(sc.imu, rig.trajectory, sc.start_utime, sc.seed);
  sim::ImuMeasurement next_imu = imu.next();

  tracker::StereoTracker tracker(rig.head.calibration, params);
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

// One pair of the epipolar integrity monitor on the simulated head (runIntegrityOnSimulation).
struct SimIntegrityFrame {
  int64_t frame = 0;
  double t = 0;                                      // [s] since the scenario start
  const sim::StereoFrame* pair = nullptr;            // the raw pair (with its true disparity when asked for)
  const tracker::IntegrityStatus* status = nullptr;  // the monitor after this pair
  const StereoCalibration* told = nullptr;           // the calibration the tracker was given
  Eigen::Vector3d truth = Eigen::Vector3d::Zero();   // the rotation the right camera's turn needs (monitor's frame)
  double monitor_ms = 0;                             // the row search and the monitor's update of this pair (one core)
};

// The tracker and its epipolar integrity monitor on a scenario whose right camera may turn (CameraFigures::
// relative_rotation_step_deg, _drift_deg_per_min), frames 0 .. floor(duration * rate) with the constant-velocity
// prior; the monitor's corrections go to the tracker as in the tracker process. The truth is the turn alone, in the
// rectified right frame of the calibration the tracker got (with a perturbed one, the calibration's own error is on
// top of it). `with_disparity(k)`: render frame k's true disparity too.
inline void runIntegrityOnSimulation(const sim::Scenario& sc, double duration_s, const tracker::TrackerParams& params,
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
