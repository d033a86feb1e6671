#pragma once
// The motion of the head's body (IMU) frame: a uniform cubic B-spline through the waypoints (C2, so velocity,
// acceleration and angular rate are exact), plus the bounce, sway and wobble of a walker or the vibration of a
// vehicle. World: local level, z up. Body: x forward, y left, z up (nominally; the IMU frame).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "ips/kinematic_state.hpp"
#include "ips/sim/jet.hpp"
#include "ips/sim/scenario.hpp"

namespace ips::sim {

class Trajectory {
 public:
  explicit Trajectory(const TrajectoryConfig& config, double gravity = 9.81);

  // The body's motion at t [s] since the scenario's start (its utime likewise). Any t: before start_still_s and after
  // duration() the head stands still at the start / end. An ideal IMU measures state(t).specificForce(gravity()).
  KinematicState state(double t) const;
  Eigen::Isometry3d pose(double t) const { return state(t).pose(); }
  double gravity() const { return gravity_; }    // [m/s^2]
  double duration() const { return duration_; }  // time until the head comes to rest
  double pathLength() const { return path_length_; }

 private:
  Jet2 spline(const std::vector<double>& ctrl, double t) const;
  KinematicState stationsState(double t) const;
  // The state from the position and the roll, pitch, yaw (R = Rz(psi) Ry(theta) Rx(phi)) with their derivatives.
  KinematicState fromJets(double t_scenario, const Jet2& x, const Jet2& y, const Jet2& z, const Jet2& phi,
                          const Jet2& theta, const Jet2& psi) const;
  Jet2 envelope(double t) const;

  TrajectoryConfig cfg_;
  double gravity_;
  double duration_ = 0;         // start_still_s + motion
  double motion_duration_ = 0;  // from leaving the start to coming to rest
  double path_length_ = 0;
  std::vector<double> cx_, cy_, cyaw_;  // control points
};

}  // namespace ips::sim
