#include "ips/framework/validate.hpp"

#include <cmath>

namespace ips::fw {

namespace {
bool finite(const double* v, int n) {
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(v[i])) return false;
  return true;
}
Verdict bad(const char* reason, std::string detail) { return Verdict{reason, std::move(detail)}; }
}  // namespace

Verdict validate(const ips::stereo_pair_t& m) {
  if (m.width <= 0 || m.height <= 0 || m.width > kMaxImageSide || m.height > kMaxImageSide)
    return bad("bad_size",
               "stereo pair of impossible size " + std::to_string(m.width) + "x" + std::to_string(m.height));
  int bpp = 0;
  if (m.pixel_format == ips::stereo_pair_t::PIXEL_MONO8)
    bpp = 1;
  else if (m.pixel_format == ips::stereo_pair_t::PIXEL_MONO16)
    bpp = 2;
  else
    return bad("bad_format", "unknown pixel format " + std::to_string(m.pixel_format));
  if (m.stride < m.width * bpp) return bad("bad_size", "stride " + std::to_string(m.stride) + " below the row size");
  const int64_t expect = static_cast<int64_t>(m.stride) * m.height;
  if (m.data_size != expect || static_cast<int64_t>(m.left.size()) != expect ||
      static_cast<int64_t>(m.right.size()) != expect)
    return bad("bad_size", "stereo pair data is " + std::to_string(m.data_size) + " bytes, stride*height is " +
                               std::to_string(expect));
  if (m.utime <= 0) return bad("bad_time", "stereo pair without a time stamp");
  return {};
}

Verdict validate(const ips::imu_sample_t& m) {
  if (!finite(m.angular_rate, 3) || !finite(m.specific_force, 3)) return bad("nan", "IMU sample with NaN or inf");
  // Far beyond any MEMS range (the MMQ-50: 200 deg/s, 10 g): a corrupt sample, not a measurement.
  for (int i = 0; i < 3; ++i)
    if (std::fabs(m.angular_rate[i]) > 100.0 || std::fabs(m.specific_force[i]) > 2000.0)
      return bad("bad_value", "IMU sample out of any sensor's range");
  if (m.utime <= 0) return bad("bad_time", "IMU sample without a time stamp");
  return {};
}

Verdict validate(const ips::tilt_sample_t& m) {
  if (!std::isfinite(m.angle_x) || !std::isfinite(m.angle_y)) return bad("nan", "tilt sample with NaN or inf");
  if (std::fabs(m.angle_x) > M_PI / 2 || std::fabs(m.angle_y) > M_PI / 2)
    return bad("bad_value", "tilt angle beyond 90 degrees");
  if (m.utime <= 0) return bad("bad_time", "tilt sample without a time stamp");
  return {};
}

Verdict validate(const ips::tracker_delta_t& m) {
  if (m.utime <= m.utime_prev) return bad("bad_time", "tracker delta whose newer time is not after the older one");
  if (!m.valid) return {};
  if (!finite(m.translation, 3) || !finite(m.rotation, 4) || !finite(m.covariance, 36))
    return bad("nan", "tracker delta with NaN or inf");
  const double qn = std::sqrt(m.rotation[0] * m.rotation[0] + m.rotation[1] * m.rotation[1] +
                              m.rotation[2] * m.rotation[2] + m.rotation[3] * m.rotation[3]);
  if (std::fabs(qn - 1.0) > 1e-3) return bad("bad_value", "tracker delta rotation is not a unit quaternion");
  for (int i = 0; i < 6; ++i)
    if (!(m.covariance[i * 6 + i] > 0)) return bad("bad_value", "tracker delta covariance not positive");
  return {};
}

Verdict validate(const ips::filter_state_t& m) {
  if (!finite(m.position, 3) || !finite(m.velocity, 3) || !finite(m.orientation, 4) || !finite(m.angular_rate, 3))
    return bad("nan", "filter state with NaN or inf");
  if (m.cov_dim < 0 || m.cov_dim > 64 || static_cast<int>(m.covariance.size()) != m.cov_dim)
    return bad("bad_size", "filter state covariance of size " + std::to_string(m.cov_dim));
  return {};
}

Verdict validate(const ips::disparity_map_t& m) {
  if (m.width <= 0 || m.height <= 0 || m.width > kMaxImageSide || m.height > kMaxImageSide ||
      static_cast<int>(m.data.size()) != m.height)
    return bad("bad_size", "disparity map of impossible size");
  for (const auto& row : m.data)
    if (static_cast<int>(row.size()) != m.width) return bad("bad_size", "disparity map row of wrong length");
  if (m.confidence_size != 0 && m.confidence_size != m.width * m.height)
    return bad("bad_size", "disparity confidence of wrong size");
  if (m.subpixel_scale <= 0) return bad("bad_value", "disparity subpixel scale not positive");
  return {};
}

StreamOrder::Result StreamOrder::check(int64_t utime, int64_t seq) {
  Result r;
  if (!first_) {
    if (utime <= last_utime_) {
      r.accept = false;
      return r;
    }
    if (seq > last_seq_ + 1) r.gap = seq - last_seq_ - 1;
  }
  first_ = false;
  last_utime_ = utime;
  last_seq_ = seq;
  return r;
}

bool StereoAdmission::admit(const ips::stereo_pair_t& m, Health& health) {
  health.received(m.utime);
  Verdict v = validate(m);
  if (!v.ok()) {
    health.bad(v.reason, v.detail);
    return false;
  }
  if (m.width != width_ || m.height != height_) {
    health.bad("bad_size", "stereo pair " + std::to_string(m.width) + "x" + std::to_string(m.height) +
                               " does not match the calibration (" + std::to_string(width_) + "x" +
                               std::to_string(height_) + ")");
    return false;
  }
  auto order = order_.check(m.utime, m.seq);
  if (!order.accept) {
    health.bad("time_backwards", "stereo pair stamp not after the previous one");
    return false;
  }
  if (order.gap > 0) health.dropped("seq_gap", order.gap);
  return true;
}

}  // namespace ips::fw
