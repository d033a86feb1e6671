#pragma once
// The whole simulated head as one stream of time-ordered events, in the order a receiver would see them
// (by arrival time = true sample time + the sensor's latency): stereo pairs, IMU and tilt samples, ground truth
// at every sensor time, and ground-truth disparity when asked for. Plain types, no LCM: the `sim` process turns
// the events into messages; tests and tools use them directly.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <deque>
#include <memory>
#include <set>
#include <vector>

#include "ips/kinematic_state.hpp"
#include "ips/sim/rig.hpp"

namespace ips::sim {

// The truth at `utime` (true sensor time) of a trajectory that starts at `start_utime`, with the sensors' biases.
InertialState groundTruthAt(const Trajectory& trajectory, int64_t start_utime, int64_t utime,
                            const Eigen::Vector3d& gyro_bias, const Eigen::Vector3d& accel_bias);

struct SimEvent {
  enum Kind { kStereo = 0, kGtDisparity = 1, kImu = 2, kTilt = 3, kGtPose = 4 };
  Kind kind = kGtPose;
  int64_t log_utime = 0;  // arrival time (what a logger would record)
  int64_t seq = 0;
  std::shared_ptr<const StereoFrame> frame;  // kStereo and kGtDisparity (same frame)
  ImuMeasurement imu;
  TiltMeasurement tilt;
  InertialState truth;  // kGtPose: ground_truth_t one to one
};

struct SimulationOptions {
  double duration_s = 10;      // sensor samples with true time in [0, duration]
  int gt_disparity_every = 0;  // ground-truth disparity for every N-th pair (0: never)
};

class Simulation {
 public:
  Simulation(const Scenario& scenario, const SimulationOptions& options);

  const Rig& rig() const { return rig_; }
  const Scenario& scenario() const { return rig_.scenario; }
  const SensorHead& head() const { return rig_.head; }
  const Trajectory& trajectory() const { return rig_.trajectory; }
  const World& world() const { return rig_.world; }
  const StereoRenderer& renderer() const { return rig_.renderer; }
  int64_t frameCount() const { return frame_count_; }

  // Appends the next events (those up to the next camera frame) in arrival order; false when all were given.
  bool next(std::vector<SimEvent>& out);

  InertialState truthAt(int64_t utime, const Eigen::Vector3d& gyro_bias, const Eigen::Vector3d& accel_bias) const;

 private:
  void push(SimEvent e);

  Rig rig_;
  SimulationOptions options_;
  ImuSimulator imu_;
  TiltSimulator tilt_;
  int64_t end_utime_;
  int64_t frame_count_;
  int64_t next_frame_ = 0;
  ImuMeasurement next_imu_;
  TiltMeasurement next_tilt_;
  Eigen::Vector3d last_gyro_bias_ = Eigen::Vector3d::Zero(), last_accel_bias_ = Eigen::Vector3d::Zero();
  std::set<int64_t> truth_times_;  // recent ground-truth times, so that none is given twice
  std::vector<SimEvent> pending_;
  bool finished_ = false;
};

}  // namespace ips::sim
