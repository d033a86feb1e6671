#pragma once
// The tracker on the simulated sensor head (ips_sim): renders a scenario's stereo pairs (raw, distorted, with
// noise and gain as the cameras deliver them), tracks them with the head's calibration and compares each delta
// with the ground-truth motion of camera 0 between the two exposure times. Shared by tracker_sim_eval and the
// simulation test.
#include <Eigen/Core>
#include <Eigen/Geometry>
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
// `told`: the calibration the tracker gets (default: the head's true one).
std::vector<SimFrameError> runTrackerOnSimulation(const std::string& scenario_path, double duration_s,
                                                  const tracker::TrackerParams& params, SimPrior prior_mode,
                                                  const std::function<void(const SimFrameError&)>& each = {},
                                                  const SimGuide& guide = {}, const StereoCalibration* told = nullptr);

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
void runIntegrityOnSimulation(const sim::Scenario& sc, double duration_s, const tracker::TrackerParams& params,
                              const tracker::IntegrityParams& integrity,
                              const std::function<bool(int64_t)>& with_disparity,
                              const std::function<void(const SimIntegrityFrame&)>& each);

}  // namespace ips::eval
