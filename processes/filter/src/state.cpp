#include "ips/filter/state.hpp"

#include <cmath>
#include <stdexcept>
#include <type_traits>

#include "ips/filter/optional_states.hpp"

namespace ips::filter {

Eigen::Matrix<double, 22, 1> NavState::toVector() const {
  Eigen::Matrix<double, 22, 1> x;
  x << position, velocity, acceleration, accel_bias, angular_rate, gyro_bias, orientation.w(), orientation.x(),
      orientation.y(), orientation.z();
  return x;
}

NavState NavState::fromVector(const Eigen::Matrix<double, 22, 1>& x, int64_t t) {
  NavState s;
  s.utime = t;
  s.position = x.segment<3>(0);
  s.velocity = x.segment<3>(3);
  s.acceleration = x.segment<3>(6);
  s.accel_bias = x.segment<3>(9);
  s.angular_rate = x.segment<3>(12);
  s.gyro_bias = x.segment<3>(15);
  s.orientation = Eigen::Quaterniond(x(18), x(19), x(20), x(21)).normalized();
  return s;
}

int FullState::findClone(int64_t t) const {
  for (size_t i = 0; i < clones.size(); ++i)
    if (clones[i].utime == t) return static_cast<int>(i);
  return -1;
}

int FullState::offset(OptionalState id) const {
  int o = kCoreErrorDim;
  forEachOptionalState([&](const auto& spec) {
    if (spec.id < id && (this->*spec.value)) o += spec.kDim;
  });
  return o;
}

int FullState::optionalDim() const { return offset(kOptionalStateCount) - kCoreErrorDim; }

NavState toStartFrame(const NavState& nav, const PoseClone& anchor, const PoseClone& start) {
  const Eigen::Quaterniond c = start.orientation * anchor.orientation.conjugate();
  NavState s = nav;
  s.position = c * (nav.position - anchor.position) + start.position;
  s.velocity = c * nav.velocity;
  s.acceleration = c * nav.acceleration;
  s.orientation = (c * nav.orientation).normalized();
  return s;
}

Eigen::MatrixXd startFrameJacobian(const FullState& x, int anchor, const PoseClone& start) {
  // With the anchor's errors dp_a, dth_a (world, from the left): C_true = C Exp(-dth_a), so a world vector u maps to
  // C u + C [u]x dth_a to first order, and an attitude error dth to C (dth - dth_a).
  const PoseClone& a = x.clones.at(static_cast<size_t>(anchor));
  const Eigen::Matrix3d c = (start.orientation * a.orientation.conjugate()).toRotationMatrix();
  const int pa = x.cloneOffset(anchor), tha = pa + 3;
  Eigen::MatrixXd j = Eigen::MatrixXd::Zero(kCoreErrorDim, x.errorDim());
  j.block<3, 3>(kErrP, kErrP) = c;
  j.block<3, 3>(kErrP, pa) = -c;
  j.block<3, 3>(kErrP, tha) = c * skew(x.nav.position - a.position);
  j.block<3, 3>(kErrV, kErrV) = c;
  j.block<3, 3>(kErrV, tha) = c * skew(x.nav.velocity);
  j.block<3, 3>(kErrA, kErrA) = c;
  j.block<3, 3>(kErrA, tha) = c * skew(x.nav.acceleration);
  for (int body : {kErrBa, kErrW, kErrBg}) j.block<3, 3>(body, body).setIdentity();
  j.block<3, 3>(kErrTh, kErrTh) = c;
  j.block<3, 3>(kErrTh, tha) = -c;
  return j;
}

NavState boxplus(const NavState& x, const Eigen::Ref<const Vector21d>& dx) {
  NavState n = x;
  n.position += dx.segment<3>(kErrP);
  n.velocity += dx.segment<3>(kErrV);
  n.acceleration += dx.segment<3>(kErrA);
  n.accel_bias += dx.segment<3>(kErrBa);
  n.angular_rate += dx.segment<3>(kErrW);
  n.gyro_bias += dx.segment<3>(kErrBg);
  n.orientation = (expQuat(dx.segment<3>(kErrTh)) * n.orientation).normalized();
  return n;
}

Vector21d boxminus(const NavState& a, const NavState& b) {
  Vector21d d;
  d.segment<3>(kErrP) = a.position - b.position;
  d.segment<3>(kErrV) = a.velocity - b.velocity;
  d.segment<3>(kErrA) = a.acceleration - b.acceleration;
  d.segment<3>(kErrBa) = a.accel_bias - b.accel_bias;
  d.segment<3>(kErrW) = a.angular_rate - b.angular_rate;
  d.segment<3>(kErrBg) = a.gyro_bias - b.gyro_bias;
  d.segment<3>(kErrTh) = logQuat(a.orientation * b.orientation.conjugate());
  return d;
}

void boxplusInto(const FullState& x, const Eigen::Ref<const Eigen::VectorXd>& dx, FullState& out) {
  if (dx.size() != x.errorDim() || out.clones.size() != x.clones.size())
    throw std::invalid_argument("boxplus: error vector size does not match the state");
  out.nav = boxplus(x.nav, dx.head<kCoreErrorDim>());
  int o = kCoreErrorDim;  // the next present state's offset
  forEachOptionalState([&](const auto& spec) {
    using Value = typename std::decay_t<decltype(spec)>::Value;
    auto& value = out.*spec.value;
    value = x.*spec.value;
    if (!value) return;
    Value::add(*value, dx.segment(o, spec.kDim));
    o += spec.kDim;
  });
  for (size_t i = 0; i < x.clones.size(); ++i) {
    const int o = x.cloneOffset(static_cast<int>(i));
    out.clones[i].utime = x.clones[i].utime;
    out.clones[i].position = x.clones[i].position + dx.segment<3>(o);
    out.clones[i].orientation = (expQuat(dx.segment<3>(o + 3)) * x.clones[i].orientation).normalized();
  }
}

FullState boxplus(const FullState& x, const Eigen::Ref<const Eigen::VectorXd>& dx) {
  FullState y = x;
  boxplusInto(x, dx, y);
  return y;
}

Eigen::VectorXd boxminus(const FullState& a, const FullState& b) {
  bool same_layout = a.clones.size() == b.clones.size();
  forEachOptionalState([&](const auto& spec) {
    same_layout = same_layout && (a.*spec.value).has_value() == (b.*spec.value).has_value();
  });
  if (!same_layout) throw std::invalid_argument("boxminus: state layouts differ");
  Eigen::VectorXd d(a.errorDim());
  d.head<kCoreErrorDim>() = boxminus(a.nav, b.nav);
  int o = kCoreErrorDim;
  forEachOptionalState([&](const auto& spec) {
    using Value = typename std::decay_t<decltype(spec)>::Value;
    if (!(a.*spec.value)) return;
    d.segment(o, spec.kDim) = Value::minus(*(a.*spec.value), *(b.*spec.value));
    o += spec.kDim;
  });
  for (size_t i = 0; i < a.clones.size(); ++i) {
    const int o = a.cloneOffset(static_cast<int>(i));
    d.segment<3>(o) = a.clones[i].position - b.clones[i].position;
    d.segment<3>(o + 3) = logQuat(a.clones[i].orientation * b.clones[i].orientation.conjugate());
  }
  return d;
}

}  // namespace ips::filter
