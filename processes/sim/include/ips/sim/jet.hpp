#pragma once
// A scalar with its first and second time derivative (forward-mode differentiation), so that the trajectory is
// written once and velocity, acceleration and angular rate come out exact, not by finite differences.
#include <cmath>

namespace ips::sim {

struct Jet2 {
  double v = 0;   // value
  double d = 0;   // first derivative
  double dd = 0;  // second derivative

  Jet2() = default;
  Jet2(double value, double d1 = 0, double d2 = 0) : v(value), d(d1), dd(d2) {}
  static Jet2 time(double t) { return {t, 1, 0}; }
};

inline Jet2 operator+(const Jet2& a, const Jet2& b) { return {a.v + b.v, a.d + b.d, a.dd + b.dd}; }
inline Jet2 operator-(const Jet2& a, const Jet2& b) { return {a.v - b.v, a.d - b.d, a.dd - b.dd}; }
inline Jet2 operator-(const Jet2& a) { return {-a.v, -a.d, -a.dd}; }
inline Jet2 operator*(const Jet2& a, const Jet2& b) {
  return {a.v * b.v, a.d * b.v + a.v * b.d, a.dd * b.v + 2 * a.d * b.d + a.v * b.dd};
}
inline Jet2 operator*(double s, const Jet2& a) { return {s * a.v, s * a.d, s * a.dd}; }
inline Jet2 operator*(const Jet2& a, double s) { return s * a; }
inline Jet2 operator+(const Jet2& a, double s) { return {a.v + s, a.d, a.dd}; }
inline Jet2 sin(const Jet2& a) {
  const double s = std::sin(a.v), c = std::cos(a.v);
  return {s, c * a.d, c * a.dd - s * a.d * a.d};
}
inline Jet2 cos(const Jet2& a) {
  const double s = std::sin(a.v), c = std::cos(a.v);
  return {c, -s * a.d, -s * a.dd - c * a.d * a.d};
}

}  // namespace ips::sim
