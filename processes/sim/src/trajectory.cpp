#include "ips/sim/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ips::sim {

Trajectory::Trajectory(const TrajectoryConfig& config, double gravity) : cfg_(config), gravity_(gravity) {
  if (cfg_.waypoints.empty()) throw std::invalid_argument("Trajectory: no waypoints");
  if (!(cfg_.speed_mps > 0) || !(cfg_.knot_spacing_s > 0))
    throw std::invalid_argument("Trajectory: speed and knot spacing must be positive");
  const auto& wp = cfg_.waypoints;
  for (size_t i = 1; i < wp.size(); ++i) path_length_ += (wp[i] - wp[i - 1]).norm();
  if (cfg_.type == "stations") {
    const double n = static_cast<double>(cfg_.stations.size());
    path_length_ = 0;
    motion_duration_ = n * cfg_.station_hold_s + (n - 1) * cfg_.station_move_s;
    duration_ = motion_duration_;
    return;
  }
  if (cfg_.type == "still" || cfg_.type == "wave" || path_length_ < 1e-6) {
    // Held in place: at the first waypoint (still) or after start_still_s of rest turned about all axes (wave).
    path_length_ = 0;
    motion_duration_ = cfg_.type == "still" || cfg_.type == "wave" ? cfg_.still_duration_s : 0;
    duration_ = motion_duration_ + (cfg_.type == "wave" ? cfg_.start_still_s : 0);
    return;
  }
  // Resample the polyline at equal arc length so that the walker keeps its speed; tripled end points make the
  // spline start and stop at rest (zero velocity and acceleration).
  const double h = cfg_.knot_spacing_s;
  const int n = std::max(1, static_cast<int>(std::ceil(path_length_ / (cfg_.speed_mps * h))));
  const double step = path_length_ / n;
  std::vector<Eigen::Vector2d> pts{wp.front(), wp.front()};
  size_t seg = 0;
  double seg_start = 0;
  for (int k = 0; k <= n; ++k) {
    const double s = std::min(k * step, path_length_);
    while (seg + 2 < wp.size() && seg_start + (wp[seg + 1] - wp[seg]).norm() < s) {
      seg_start += (wp[seg + 1] - wp[seg]).norm();
      ++seg;
    }
    const double len = (wp[seg + 1] - wp[seg]).norm();
    const double a = len > 0 ? std::clamp((s - seg_start) / len, 0.0, 1.0) : 0.0;
    pts.push_back(wp[seg] + a * (wp[seg + 1] - wp[seg]));
  }
  pts.push_back(wp.back());
  pts.push_back(wp.back());
  const int m = static_cast<int>(pts.size());
  // Heading of each control point from its neighbours, unwrapped.
  std::vector<double> heading(m, NAN);
  for (int i = 0; i < m; ++i) {
    const Eigen::Vector2d d = pts[std::min(i + 1, m - 1)] - pts[std::max(i - 1, 0)];
    if (d.norm() > 1e-9) heading[i] = std::atan2(d.y(), d.x());
  }
  // The repeated end points have no direction of their own: they take the nearest one along the path.
  for (int i = 0; i < m; ++i) {
    if (!std::isnan(heading[i])) continue;
    const int dir = i < m / 2 ? 1 : -1;
    for (int j = i + dir; j >= 0 && j < m; j += dir)
      if (!std::isnan(heading[j])) {
        heading[i] = heading[j];
        break;
      }
    if (std::isnan(heading[i])) heading[i] = cfg_.yaw_deg * M_PI / 180;
  }
  for (int i = 1; i < m; ++i) {
    while (heading[i] - heading[i - 1] > M_PI) heading[i] -= 2 * M_PI;
    while (heading[i] - heading[i - 1] < -M_PI) heading[i] += 2 * M_PI;
  }
  for (int i = 0; i < m; ++i) {
    cx_.push_back(pts[i].x());
    cy_.push_back(pts[i].y());
    cyaw_.push_back(heading[i]);
  }
  motion_duration_ = (m - 3) * h;
  duration_ = cfg_.start_still_s + motion_duration_;
}

Jet2 Trajectory::spline(const std::vector<double>& c, double t) const {
  const double h = cfg_.knot_spacing_s;
  const int nseg = static_cast<int>(c.size()) - 3;
  const double tc = std::clamp(t, 0.0, motion_duration_);
  int i = std::min(static_cast<int>(tc / h), nseg - 1);
  const double s = tc / h - i;
  const double s2 = s * s, s3 = s2 * s, r = 1 - s;
  const double b[4] = {r * r * r / 6, (3 * s3 - 6 * s2 + 4) / 6, (-3 * s3 + 3 * s2 + 3 * s + 1) / 6, s3 / 6};
  const double db[4] = {-r * r / 2, (3 * s2 - 4 * s) / 2, (-3 * s2 + 2 * s + 1) / 2, s2 / 2};
  const double ddb[4] = {r, 3 * s - 2, -3 * s + 1, s};
  Jet2 out;
  for (int k = 0; k < 4; ++k) {
    out.v += b[k] * c[i + k];
    out.d += db[k] * c[i + k];
    out.dd += ddb[k] * c[i + k];
  }
  if (t < 0 || t > motion_duration_) return {out.v, 0, 0};  // at rest before start and after stop
  out.d /= h;
  out.dd /= h * h;
  return out;
}

// Gait amplitude: 0 at rest, ramping up after the start and down before the stop with a C2 smootherstep.
Jet2 Trajectory::envelope(double t) const {
  if (cfg_.type == "still" || t <= 0 || t >= motion_duration_) return {0, 0, 0};
  auto smooth = [](double x, double dxdt) -> Jet2 {
    if (x >= 1) return {1, 0, 0};
    const double v = x * x * x * (x * (6 * x - 15) + 10);
    const double d = 30 * x * x * (x - 1) * (x - 1);
    const double dd = 60 * x * (2 * x - 1) * (x - 1);
    return {v, d * dxdt, dd * dxdt * dxdt};
  };
  const double ramp = std::max(1e-3, std::min(cfg_.ramp_s, motion_duration_ / 2));
  return smooth(t / ramp, 1 / ramp) * smooth((motion_duration_ - t) / ramp, -1 / ramp);
}

namespace {

// C2 smootherstep of x = (t - t0) / span in [0, 1]: at rest (zero rate and acceleration) at both ends.
Jet2 smootherstep(double t, double t0, double span) {
  const double x = std::clamp((t - t0) / span, 0.0, 1.0);
  if (x <= 0 || x >= 1) return {x, 0, 0};
  return {x * x * x * (x * (6 * x - 15) + 10), 30 * x * x * (x - 1) * (x - 1) / span,
          60 * x * (2 * x - 1) * (x - 1) / (span * span)};
}

}  // namespace

KinematicState Trajectory::state(double t_scenario) const {
  if (cfg_.type == "stations") return stationsState(t_scenario);
  constexpr double kDeg = M_PI / 180;
  // The path and the gait run on the motion's own clock, which starts after the still start.
  const double t = cfg_.type == "still" ? t_scenario : t_scenario - cfg_.start_still_s;
  Jet2 x, y, yaw_path;
  if (cx_.empty()) {
    x = Jet2(cfg_.waypoints.front().x());
    y = Jet2(cfg_.waypoints.front().y());
    yaw_path = Jet2(cfg_.yaw_deg * kDeg);
  } else {
    x = spline(cx_, t);
    y = spline(cy_, t);
    yaw_path = spline(cyaw_, t);
  }
  const Jet2 e = envelope(t);
  const Jet2 T = Jet2::time(t);
  const double w = 2 * M_PI * cfg_.step_frequency_hz;
  const Jet2 lateral = cfg_.sway_m * e * sin(0.5 * w * T);
  x = x - lateral * sin(yaw_path);
  y = y + lateral * cos(yaw_path);
  Jet2 z = Jet2(cfg_.height_m) + cfg_.bounce_m * e * sin(w * T);
  if (cfg_.floor_ramp.any()) z = z + cfg_.floor_ramp.walkerFloor(x, y);  // up and down the ramp with the floor
  Jet2 psi = yaw_path + cfg_.yaw_sway_deg * kDeg * e * sin(0.5 * w * T + 1.0);
  Jet2 theta = Jet2(cfg_.pitch_down_deg * kDeg) + cfg_.nod_deg * kDeg * e * sin(w * T + 0.5);
  Jet2 phi = Jet2(cfg_.roll_deg * kDeg) + cfg_.roll_sway_deg * kDeg * e * sin(0.5 * w * T + 0.3);
  if (cfg_.type == "wave") {
    auto turn = [&](int axis) {
      return cfg_.wave_amplitude_deg[axis] * kDeg * e * sin((2 * M_PI / cfg_.wave_period_s[axis]) * T);
    };
    phi = phi + turn(0);
    theta = theta + turn(1);
    psi = psi + turn(2);
  }

  return fromJets(t_scenario, x, y, z, phi, theta, psi);
}

KinematicState Trajectory::stationsState(double t) const {
  constexpr double kDeg = M_PI / 180;
  const auto& st = cfg_.stations;
  const double cycle = cfg_.station_hold_s + cfg_.station_move_s;
  // Station k is held over [k cycle, k cycle + hold], then the head moves to k + 1.
  const size_t k = std::min(st.size() - 1, static_cast<size_t>(std::max(0.0, t) / cycle));
  const size_t next = std::min(st.size() - 1, k + 1);
  const Jet2 a = smootherstep(t, k * cycle + cfg_.station_hold_s, cfg_.station_move_s);
  auto blend = [&](double from, double to) { return Jet2(from) + (to - from) * a; };
  const auto& p0 = st[k].position;
  const auto& p1 = st[next].position;
  const auto& r0 = st[k].roll_pitch_yaw_deg;
  const auto& r1 = st[next].roll_pitch_yaw_deg;
  return fromJets(t, blend(p0.x(), p1.x()), blend(p0.y(), p1.y()), blend(p0.z(), p1.z()),
                  blend(r0.x() * kDeg, r1.x() * kDeg), blend(r0.y() * kDeg, r1.y() * kDeg),
                  blend(r0.z() * kDeg, r1.z() * kDeg));
}

KinematicState Trajectory::fromJets(double t_scenario, const Jet2& x, const Jet2& y, const Jet2& z, const Jet2& phi,
                                    const Jet2& theta, const Jet2& psi) const {
  KinematicState s;
  s.utime = std::llround(t_scenario * 1e6);  // since the scenario's start
  s.position = {x.v, y.v, z.v};
  s.velocity = {x.d, y.d, z.d};
  s.acceleration = {x.dd, y.dd, z.dd};
  // R = Rz(psi) Ry(theta) Rx(phi); theta > 0 turns the nose (x) down.
  s.orientation = Eigen::AngleAxisd(psi.v, Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(theta.v, Eigen::Vector3d::UnitY()) *
                  Eigen::AngleAxisd(phi.v, Eigen::Vector3d::UnitX());
  const double sf = std::sin(phi.v), cf = std::cos(phi.v), st = std::sin(theta.v), ct = std::cos(theta.v);
  s.angular_rate = {phi.d - psi.d * st, theta.d * cf + psi.d * sf * ct, -theta.d * sf + psi.d * cf * ct};
  return s;
}

}  // namespace ips::sim
