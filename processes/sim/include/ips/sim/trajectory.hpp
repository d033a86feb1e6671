#pragma once
// The motion of the head's body (IMU) frame: a uniform cubic B-spline through the waypoints (C2, so velocity,
// acceleration and angular rate are exact), plus the bounce, sway and wobble of a walker or the vibration of a
// vehicle. World: local level, z up. Body: x forward, y left, z up (nominally; the IMU frame).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "ips/sim/jet.hpp"
#include "ips/sim/scenario.hpp"

namespace ips::sim {

struct TrajectoryState {
  double t = 0;                    // [s] since the start of the scenario
  Eigen::Vector3d position;        // body in world [m]
  Eigen::Vector3d velocity;        // [m/s] in world
  Eigen::Vector3d acceleration;    // [m/s^2] in world (kinematic, gravity not included)
  Eigen::Quaterniond orientation;  // body to world
  Eigen::Vector3d angular_rate;    // [rad/s] of body against world, in body
  Eigen::Vector3d specific_force;  // [m/s^2] in body: R^T (a - g), what an ideal accelerometer measures
  Eigen::Isometry3d pose() const;  // T_world_body
};

class Trajectory {
 public:
  explicit Trajectory(const TrajectoryConfig& config, double gravity = 9.81);

  // Any t: before start_still_s and after duration() the head stands still at the start / end.
  TrajectoryState state(double t) const;
  Eigen::Isometry3d pose(double t) const { return state(t).pose(); }
  double duration() const { return duration_; }  // time until the head comes to rest
  double pathLength() const { return path_length_; }

 private:
  Jet2 spline(const std::vector<double>& ctrl, double t) const;
  TrajectoryState stationsState(double t) const;
  // The state from the position and the roll, pitch, yaw (R = Rz(psi) Ry(theta) Rx(phi)) with their derivatives.
  TrajectoryState fromJets(double t_scenario, const Jet2& x, const Jet2& y, const Jet2& z, const Jet2& phi,
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
