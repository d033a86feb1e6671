// The ramp's floor (WorldConfig::ramp): the kinked surface the world builds, and the rounded one a walker's body
// follows (Trajectory), from the same figures.
#include <cmath>

#include "ips/sim/scenario.hpp"

namespace ips::sim {

namespace {

// max(0, x) with its kink rounded over [-b/2, b/2]: its slope is the smootherstep s(w) of w = x / b + 1/2 (C2), so the
// function is b times the integral of s, w^6 - 3 w^5 + 5/2 w^4, which reaches b/2 = x at w = 1: beyond the rounding
// it is max(0, x) again. Value, first and second derivative with respect to x.
struct Rounded {
  double v, d, dd;
};
Rounded roundedRamp(double x, double b) {
  const double w = x / b + 0.5;
  if (w <= 0) return {0, 0, 0};
  if (w >= 1) return {x, 1, 0};
  const double w2 = w * w, w3 = w2 * w, w4 = w3 * w;
  return {b * (w4 * w2 - 3 * w4 * w + 2.5 * w4), w3 * (w * (6 * w - 15) + 10), 30 * w2 * (w - 1) * (w - 1) / b};
}

}  // namespace

Eigen::Vector2d Ramp::local(const Eigen::Vector2d& p) const {
  const double heading = heading_deg * M_PI / 180;
  const Eigen::Vector2d along(std::cos(heading), std::sin(heading)), left(-along.y(), along.x());
  const Eigen::Vector2d d = p - start_m;
  return {d.dot(along), d.dot(left)};
}

double Ramp::floorHeight(const Eigen::Vector2d& p) const {
  if (!any()) return 0;
  const Eigen::Vector2d q = local(p);
  if (std::abs(q.y()) > 0.5 * width_m || q.x() <= 0 || q.x() >= length()) return 0;
  return std::min({rise_m, slope * q.x(), slope * (length() - q.x())});
}

Jet2 Ramp::walkerFloor(const Jet2& x, const Jet2& y) const {
  if (!any()) return Jet2(0);
  const Eigen::Vector2d q = local({x.v, y.v});
  if (std::abs(q.y()) > 0.5 * width_m) return Jet2(0);
  // The distance along the ramp as a jet: the projection of the walker's motion on the ramp's direction.
  const double heading = heading_deg * M_PI / 180;
  const Jet2 u = std::cos(heading) * (x - Jet2(start_m.x())) + std::sin(heading) * (y - Jet2(start_m.y()));
  // The profile is slope * (r(u) - r(u - run) - r(u - run - plateau) + r(u - length)) with r = max(0, .), each kink
  // rounded.
  const double kinks[4] = {0, run(), run() + plateau_m, length()};
  const double signs[4] = {1, -1, -1, 1};
  double v = 0, d = 0, dd = 0;
  for (int k = 0; k < 4; ++k) {
    const Rounded r = roundedRamp(u.v - kinks[k], blend_m);
    v += signs[k] * r.v;
    d += signs[k] * r.d;
    dd += signs[k] * r.dd;
  }
  // Chain rule: d/dt f(u) = f' u', d2/dt2 f(u) = f'' u'^2 + f' u''.
  return {slope * v, slope * d * u.d, slope * (dd * u.d * u.d + d * u.dd)};
}

}  // namespace ips::sim
