#include "filter_messages.hpp"

#include <algorithm>
#include <cmath>

#include "ips/framework/filter_state_layout.hpp"
#include "ips/framework/message_arrays.hpp"

namespace ips::filter_app {

namespace {

// A vector into the message's fixed array of the same size.
template <class Vector, int N>
void copyBlock(const Vector& from, double (&to)[N]) {
  static_assert(Vector::SizeAtCompileTime == N, "the message's array and the vector differ in size");
  for (int i = 0; i < N; ++i) to[i] = from[i];
}

}  // namespace

ips::filter_state_t toMessage(const ips::filter::FilterOutput& out) {
  ips::filter_state_t m{};
  const ips::filter::NavState& s = out.state;
  m.utime = s.utime;
  m.filter_type = static_cast<int8_t>(out.type);
  m.a_priori = out.a_priori;
  for (int i = 0; i < 3; ++i) {
    m.position[i] = s.position[i];
    m.velocity[i] = s.velocity[i];
    m.acceleration[i] = s.acceleration[i];
    m.accel_bias[i] = s.accel_bias[i];
    m.angular_rate[i] = s.angular_rate[i];
    m.gyro_bias[i] = s.gyro_bias[i];
  }
  const Eigen::Vector4d q_wxyz(s.orientation.w(), s.orientation.x(), s.orientation.y(), s.orientation.z());
  for (int i = 0; i < 4; ++i) m.orientation[i] = q_wxyz[i];
  m.frame = out.frame == ips::filter::OutputFrame::Start ? ips::filter_state_t::FRAME_START
                                                         : ips::filter_state_t::FRAME_WORLD;
  copyBlock(out.up, m.up);
  namespace layout = ips::fw::filter_state_layout;
  static_assert(layout::kVelocity == ips::filter::kErrV && layout::kAngularRate == ips::filter::kErrW &&
                layout::kGyroBias == ips::filter::kErrBg && layout::kDim == ips::filter::kCoreErrorDim);
  m.cov_dim = layout::kDim;
  m.covariance.assign(layout::kDim, std::vector<double>(layout::kDim));
  for (int r = 0; r < layout::kDim; ++r)
    for (int c = 0; c < layout::kDim; ++c) m.covariance[r][c] = out.covariance(r, c);
  for (const auto& estimate : out.calibration) {
    if (!estimate) continue;
    ips::calibration_estimate_t c;
    c.name = estimate->name;
    c.unit = estimate->unit;
    c.dim = static_cast<int32_t>(estimate->value.size());
    const Eigen::VectorXd sigma = estimate->sigma();
    c.value.assign(estimate->value.data(), estimate->value.data() + c.dim);
    c.sigma.assign(sigma.data(), sigma.data() + c.dim);
    m.calibration.push_back(std::move(c));
  }
  m.num_calibration = static_cast<int32_t>(m.calibration.size());
  for (const auto& sensor : out.sensors) {
    if (!sensor.name || !*sensor.name) continue;
    m.sensor_names.push_back(sensor.name);
    m.accepted.push_back(sensor.accepted);
    m.rejected.push_back(sensor.rejected);
    m.too_late.push_back(sensor.too_late);
  }
  m.num_sensors = static_cast<int32_t>(m.sensor_names.size());
  return m;
}

ips::filter::ImuSample toImuSample(const ips::imu_sample_t& m) {
  return {m.utime, ips::fw::vectorFromArray(m.angular_rate), ips::fw::vectorFromArray(m.specific_force)};
}

ips::filter::TrackerDelta toDelta(const ips::tracker_delta_t& m) {
  ips::filter::TrackerDelta d;
  d.utime = m.utime;
  d.utime_prev = m.utime_prev;
  d.valid = m.valid;
  d.far_valid = m.far_valid;
  d.far_rotation = ips::fw::quaternionFromArray(m.far_rotation).normalized();
  d.far_covariance = ips::fw::matrixFromArray<3>(m.far_rotation_covariance);
  d.translation = ips::fw::vectorFromArray(m.translation);
  d.rotation = ips::fw::quaternionFromArray(m.rotation).normalized();
  d.covariance = ips::fw::matrixFromArray<6>(m.covariance);
  return d;
}

}  // namespace ips::filter_app
