#pragma once
// A trajectory in closed form: position, velocity, acceleration, attitude and body rate exact to machine precision
// at any time, for checks that need an exact truth and runs by the hundred (the filter's model Jacobians, Monte
// Carlo of the filter alone: ips_eval's filter test bed). The spline trajectory (trajectory.hpp) is the scenarios'
// walk through a world the renderer draws; this one has no world.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>

#include "ips/kinematic_state.hpp"

namespace ips::sim {

// An open meander (not a closed loop, so heading drift shows in the end point): x = forward_speed * s +
// amp_x sin(W s), y = amp_y (1 - cos(W s)) in the path time s, which stands still for rest_s and ramps up
// smoothly (C2) over ramp_s: ~90 m in 2 minutes of walking.
struct WalkParams {
  double duration_s = 125.0;   // rest + the paper's 2-minute walk
  double rest_s = 3.0;         // standing still at the start (static initialisation)
  double ramp_s = 2.0;         // smooth start
  double forward_speed = 0.6;  // [m/s]
  double period_s = 40.0;      // of the meander
  double amp_x = 2.0;          // [m]
  double amp_y = 4.0;          // [m]
  double step_hz = 1.8;        // gait: vertical bounce and sway
  double bounce_m = 0.025;
  double sway_m = 0.02;
  double head_yaw_rad = 0.15;  // looking around
  double head_pitch_rad = 0.05;
  double head_roll_rad = 0.03;
  bool at_rest = false;  // a still head (for the static initialisation), attitude from the fixed angles
  double rest_roll_rad = 0.0, rest_pitch_rad = 0.0, rest_yaw_rad = 0.0;
};

class AnalyticWalk {
 public:
  explicit AnalyticWalk(const WalkParams& p = {}) : p_(p) {}
  // Path time s(t) and its first two derivatives.
  void pathTime(double t, double* s, double* ds, double* dds) const;
  KinematicState at(double t_s) const;  // (utime: t_s)
  const WalkParams& params() const { return p_; }
  // Path length between t0 and t1 (numerically, 1 ms steps).
  double distance(double t0_s, double t1_s) const;

 private:
  WalkParams p_;
};

}  // namespace ips::sim
