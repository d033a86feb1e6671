#include "ips/sim/analytic_walk.hpp"

#include <cmath>

namespace ips::sim {

namespace {
constexpr double kTwoPi = 6.283185307179586;

struct Angle {
  double v, d, dd;  // value and first two derivatives
};
Angle sine(double amp, double freq_hz, double t, double phase = 0) {
  const double w = kTwoPi * freq_hz;
  return {amp * std::sin(w * t + phase), amp * w * std::cos(w * t + phase), -amp * w * w * std::sin(w * t + phase)};
}
}  // namespace

void AnalyticWalk::pathTime(double t, double* s, double* ds, double* dds) const {
  const double u = t - p_.rest_s, T = p_.ramp_s;
  if (u <= 0) {
    *s = *ds = *dds = 0;
  } else if (u < T) {
    const double x = u / T;
    *s = T * (x * x * x - 0.5 * x * x * x * x);  // integral of the smoothstep 3x^2 - 2x^3
    *ds = 3 * x * x - 2 * x * x * x;
    *dds = (6 * x - 6 * x * x) / T;
  } else {
    *s = 0.5 * T + (u - T);
    *ds = 1;
    *dds = 0;
  }
}

KinematicState AnalyticWalk::at(double t) const {
  KinematicState s;
  s.utime = static_cast<int64_t>(std::llround(t * 1e6));
  double roll, pitch, yaw, droll, dpitch, dyaw;
  if (p_.at_rest) {
    s.position = Eigen::Vector3d::Zero();
    s.velocity = Eigen::Vector3d::Zero();
    s.acceleration = Eigen::Vector3d::Zero();
    roll = p_.rest_roll_rad, pitch = p_.rest_pitch_rad, yaw = p_.rest_yaw_rad;
    droll = dpitch = dyaw = 0;
  } else {
    // Everything is a function of the path time tau; d/dt = tau' d/dtau.
    double tau, dtau, ddtau;
    pathTime(t, &tau, &dtau, &ddtau);
    const double W = kTwoPi / p_.period_s;
    const double A = p_.amp_x, B = p_.amp_y, V = p_.forward_speed;
    const Angle sway = sine(p_.sway_m, 0.5 * p_.step_hz, tau);
    const Angle bounce = sine(p_.bounce_m, p_.step_hz, tau, 0.3);
    const Eigen::Vector3d P(V * tau + A * std::sin(W * tau), B * (1 - std::cos(W * tau)) + sway.v, bounce.v);
    const Eigen::Vector3d dP(V + A * W * std::cos(W * tau), B * W * std::sin(W * tau) + sway.d, bounce.d);
    const Eigen::Vector3d ddP(-A * W * W * std::sin(W * tau), B * W * W * std::cos(W * tau) + sway.dd, bounce.dd);
    s.position = P;
    s.velocity = dP * dtau;
    s.acceleration = ddP * dtau * dtau + dP * ddtau;
    // Heading along the meander's tangent (without the sway) plus looking around.
    const double vx = dP.x(), vy = B * W * std::sin(W * tau);
    const double ax = ddP.x(), ay = B * W * W * std::cos(W * tau);
    const Angle look = sine(p_.head_yaw_rad, 0.13, tau);
    yaw = std::atan2(vy, vx) + look.v;
    dyaw = ((vx * ay - vy * ax) / (vx * vx + vy * vy) + look.d) * dtau;
    const Angle pt = sine(p_.head_pitch_rad, p_.step_hz, tau, 1.0);
    const Angle rl = sine(p_.head_roll_rad, 0.5 * p_.step_hz, tau, 0.5);
    pitch = pt.v, dpitch = pt.d * dtau, roll = rl.v, droll = rl.d * dtau;
  }
  s.orientation = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                  Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX());
  // Body rate of R = Rz(yaw) Ry(pitch) Rx(roll).
  const double sr = std::sin(roll), cr = std::cos(roll), sp = std::sin(pitch), cp = std::cos(pitch);
  s.angular_rate = Eigen::Vector3d(droll - dyaw * sp, dpitch * cr + dyaw * sr * cp, -dpitch * sr + dyaw * cr * cp);
  return s;
}

double AnalyticWalk::distance(double t0, double t1) const {
  double d = 0;
  Eigen::Vector3d prev = at(t0).position;
  for (double t = t0 + 1e-3; t <= t1 + 1e-12; t += 1e-3) {
    const Eigen::Vector3d p = at(t).position;
    d += (p - prev).norm();
    prev = p;
  }
  return d;
}

}  // namespace ips::sim
