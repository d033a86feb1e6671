#pragma once
// Pieces the simulator's tests share: a scenario without image noise, and the strapdown integration that is the
// reference for the simulated IMU.
#include <Eigen/Geometry>

#include "ips/sim/scenario.hpp"
#include "ips/sim/sensors.hpp"
#include "ips/sim/trajectory.hpp"

namespace ips::sim::test_support {

// The default scenario with the camera's noise off, so that renderings compare exactly.
inline Scenario quietScenario() {
  Scenario sc = Scenario::defaults();
  sc.camera.noise_sigma = 0;
  return sc;
}

// Strapdown navigation from a true state on an ideal IMU's samples: rates linear over each interval (the rotation
// vector with its coning term), specific force linear in the world frame.
struct Strapdown {
  Eigen::Quaterniond q;
  Eigen::Vector3d v, p, g;

  Strapdown(const KinematicState& start, double gravity)
      : q(start.orientation), v(start.velocity), p(start.position), g(0, 0, -gravity) {}

  void step(const ImuMeasurement& prev, const ImuMeasurement& cur) {
    const double dt = (cur.utime_true - prev.utime_true) * 1e-6;
    const Eigen::Vector3d w0 = prev.angular_rate, w1 = cur.angular_rate;
    const Eigen::Vector3d phi = 0.5 * (w0 + w1) * dt + (dt * dt / 12.0) * w0.cross(w1);
    const Eigen::Quaterniond dq(
        Eigen::AngleAxisd(phi.norm(), phi.norm() > 0 ? phi.normalized() : Eigen::Vector3d::UnitX()));
    const Eigen::Quaterniond q1 = (q * dq).normalized();
    const Eigen::Vector3d a0 = q * prev.specific_force + g, a1 = q1 * cur.specific_force + g;
    p += v * dt + dt * dt / 6.0 * (2 * a0 + a1);
    v += 0.5 * (a0 + a1) * dt;
    q = q1;
  }
};

}  // namespace ips::sim::test_support
