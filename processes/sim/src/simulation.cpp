#include "ips/sim/simulation.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ips::sim {

Simulation::Simulation(const Scenario& scenario, const SimulationOptions& options)
    : rig_(scenario),
      options_(options),
      imu_(rig_.scenario.imu, rig_.trajectory, rig_.scenario.start_utime, rig_.scenario.seed),
      tilt_(rig_.scenario.tilt, rig_.trajectory, rig_.head.R_tilt_imu, rig_.scenario.start_utime, rig_.scenario.gravity,
            rig_.scenario.seed) {
  if (!(options.duration_s >= 0) || options.duration_s > 1e6)
    throw std::invalid_argument("Simulation: duration must be in [0, 1e6] s");
  if (options.gt_disparity_every < 0) throw std::invalid_argument("Simulation: gt_disparity_every must be >= 0");
  end_utime_ = rig_.scenario.start_utime + std::llround(options.duration_s * 1e6);
  frame_count_ = static_cast<int64_t>(std::floor(options.duration_s * rig_.scenario.camera.rate_hz + 1e-9)) + 1;
  next_imu_ = imu_.next();
  next_tilt_ = tilt_.next();
}

InertialState groundTruthAt(const Trajectory& trajectory, int64_t start_utime, int64_t utime,
                            const Eigen::Vector3d& gyro_bias, const Eigen::Vector3d& accel_bias) {
  InertialState g;
  static_cast<KinematicState&>(g) = trajectory.state((utime - start_utime) * 1e-6);
  g.utime = utime;
  g.gyro_bias = gyro_bias;
  g.accel_bias = accel_bias;
  return g;
}

InertialState Simulation::truthAt(int64_t utime, const Eigen::Vector3d& bg, const Eigen::Vector3d& ba) const {
  return groundTruthAt(rig_.trajectory, rig_.scenario.start_utime, utime, bg, ba);
}

void Simulation::push(SimEvent e) { pending_.push_back(std::move(e)); }

bool Simulation::next(std::vector<SimEvent>& out) {
  if (finished_) return false;
  const bool last = next_frame_ >= frame_count_;
  // Everything sampled up to the next frame time (or the end).
  const int64_t horizon =
      last ? end_utime_
           : std::min(end_utime_, sampleUtime(rig_.scenario.start_utime, next_frame_, rig_.scenario.camera.rate_hz));
  auto addTruth = [&](int64_t utime) {
    if (!truth_times_.insert(utime).second) return;
    SimEvent e;
    e.kind = SimEvent::kGtPose;
    e.log_utime = utime;
    e.truth = truthAt(utime, last_gyro_bias_, last_accel_bias_);
    push(std::move(e));
  };
  // IMU first: it carries the biases that the ground truth at the other sensors' times reports.
  while (next_imu_.utime_true <= horizon) {
    last_gyro_bias_ = next_imu_.gyro_bias;
    last_accel_bias_ = next_imu_.accel_bias;
    SimEvent e;
    e.kind = SimEvent::kImu;
    e.log_utime = next_imu_.utime_arrival;
    e.seq = next_imu_.seq;
    e.imu = next_imu_;
    push(std::move(e));
    addTruth(next_imu_.utime_true);
    next_imu_ = imu_.next();
  }
  while (next_tilt_.utime_true <= horizon) {
    SimEvent e;
    e.kind = SimEvent::kTilt;
    e.log_utime = next_tilt_.utime_arrival;
    e.seq = next_tilt_.seq;
    e.tilt = next_tilt_;
    push(std::move(e));
    addTruth(next_tilt_.utime_true);
    next_tilt_ = tilt_.next();
  }
  if (!last) {
    const bool gt = options_.gt_disparity_every > 0 && next_frame_ % options_.gt_disparity_every == 0;
    auto frame = std::make_shared<const StereoFrame>(rig_.renderer.render(next_frame_, gt));
    // A lost pair (camera/frame_loss) is not published: its sequence number is skipped, as a camera driver's would be.
    if (!frame->lost) {
      SimEvent e;
      e.kind = SimEvent::kStereo;
      e.log_utime = frame->utime_arrival;
      e.seq = frame->seq;
      e.frame = frame;
      push(e);
      if (gt) {
        e.kind = SimEvent::kGtDisparity;
        push(e);
      }
      addTruth(frame->utime_true);
    }
    ++next_frame_;
  }
  // Later samples have later true times, and arrival >= true time: what arrives up to the horizon is final.
  std::stable_sort(pending_.begin(), pending_.end(), [](const SimEvent& a, const SimEvent& b) {
    if (a.log_utime != b.log_utime) return a.log_utime < b.log_utime;
    if (a.kind != b.kind) return a.kind < b.kind;
    return a.seq < b.seq;
  });
  const bool done = last;
  size_t n = 0;
  while (n < pending_.size() && (done || pending_[n].log_utime <= horizon)) ++n;
  out.insert(out.end(), std::make_move_iterator(pending_.begin()), std::make_move_iterator(pending_.begin() + n));
  pending_.erase(pending_.begin(), pending_.begin() + n);
  while (!truth_times_.empty() && *truth_times_.begin() < horizon - 1'000'000) truth_times_.erase(truth_times_.begin());
  if (done) finished_ = true;
  return true;
}

}  // namespace ips::sim
