#include "ips/framework/validate.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <cctype>
#include <cmath>

#include "ips/framework/channels.hpp"

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

namespace {

// Whether the n x n row-major matrix is symmetric (to a relative 1e-6) and positive definite: its Cholesky
// factorisation succeeds. A covariance that is not would make a filter's gain meaningless (a negative variance along
// some direction passes every check of the diagonal).
bool positiveDefinite(const double* a, int n) {
  const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> m(a, n, n);
  const double scale = m.diagonal().cwiseAbs().maxCoeff();
  if (!(scale > 0) || !m.isApprox(m.transpose(), 1e-6)) return false;
  return Eigen::LLT<Eigen::MatrixXd>(m).info() == Eigen::Success;
}

double norm3(const double* v) { return Eigen::Map<const Eigen::Vector3d>(v).norm(); }
// A unit quaternion w x y z, to the rounding a message's writer may leave.
bool unitQuaternion(const double* q) { return std::fabs(Eigen::Map<const Eigen::Vector4d>(q).norm() - 1.0) <= 1e-3; }

}  // namespace

Verdict validate(const ips::tracker_delta_t& m) {
  if (m.utime <= m.utime_prev) return bad("bad_time", "tracker delta whose newer time is not after the older one");
  if (m.valid) {
    if (!finite(m.translation, 3) || !finite(m.rotation, 4) || !finite(m.covariance, 36))
      return bad("nan", "tracker delta with NaN or inf");
    if (!unitQuaternion(m.rotation)) return bad("bad_value", "tracker delta rotation is not a unit quaternion");
    if (!positiveDefinite(m.covariance, 6))
      return bad("bad_value", "tracker delta covariance not symmetric positive definite");
  }
  if (m.far_valid) {
    if (!finite(m.far_rotation, 4) || !finite(m.far_rotation_covariance, 9))
      return bad("nan", "tracker delta far rotation with NaN or inf");
    if (!unitQuaternion(m.far_rotation)) return bad("bad_value", "tracker delta far rotation is not a unit quaternion");
    if (!positiveDefinite(m.far_rotation_covariance, 3))
      return bad("bad_value", "tracker delta far rotation covariance not symmetric positive definite");
  }
  return {};
}

Verdict validate(const ips::filter_state_t& m) {
  if (!finite(m.position, 3) || !finite(m.velocity, 3) || !finite(m.orientation, 4) || !finite(m.angular_rate, 3))
    return bad("nan", "filter state with NaN or inf");
  if (!finite(m.acceleration, 3) || !finite(m.accel_bias, 3) || !finite(m.gyro_bias, 3))
    return bad("nan", "filter state with a NaN or inf bias or acceleration");
  if (m.num_calibration < 0 || m.num_calibration > 64 || static_cast<int>(m.calibration.size()) != m.num_calibration)
    return bad("bad_size", "filter state with " + std::to_string(m.num_calibration) + " calibration estimates");
  for (const ips::calibration_estimate_t& c : m.calibration) {
    if (c.name.empty() || c.dim < 1 || c.dim > 16 || static_cast<int>(c.value.size()) != c.dim ||
        static_cast<int>(c.sigma.size()) != c.dim)
      return bad("bad_size", "filter state calibration estimate '" + c.name + "' of " + std::to_string(c.dim) +
                                 " dimensions, or without a name");
    if (!finite(c.value.data(), c.dim) || !finite(c.sigma.data(), c.dim))
      return bad("nan", "filter state calibration estimate '" + c.name + "' with NaN or inf");
  }
  // A state a navigation filter can have: a unit quaternion, and position, speed, acceleration and turn rate no
  // vehicle exceeds (10 000 km from the origin, 10 km/s, 1000 m/s^2, 100 rad/s).
  const double* q = m.orientation;
  if (!unitQuaternion(q)) return bad("bad_value", "filter state orientation is not a unit quaternion");
  if (m.frame != ips::filter_state_t::FRAME_WORLD && m.frame != ips::filter_state_t::FRAME_START)
    return bad("bad_value", "filter state frame " + std::to_string(m.frame) + " is neither world nor start");
  if (!finite(m.up, 3) || std::abs(norm3(m.up) - 1.0) > 1e-3)
    return bad("bad_value", "filter state local vertical is not a unit vector");
  if (norm3(m.position) > 1e7 || norm3(m.velocity) > 1e4 || norm3(m.acceleration) > 1e3 || norm3(m.angular_rate) > 100)
    return bad("bad_value", "filter state with a position, velocity, acceleration or rate out of any vehicle's range");
  if (m.cov_dim < 0 || m.cov_dim > 64 || static_cast<int>(m.covariance.size()) != m.cov_dim)
    return bad("bad_size", "filter state covariance of size " + std::to_string(m.cov_dim));
  for (const auto& row : m.covariance) {
    if (static_cast<int>(row.size()) != m.cov_dim) return bad("bad_size", "filter state covariance row of wrong size");
    if (!finite(row.data(), m.cov_dim)) return bad("nan", "filter state covariance with NaN or inf");
  }
  for (int i = 0; i < m.cov_dim; ++i)
    if (m.covariance[i][i] < 0) return bad("bad_value", "filter state covariance with a negative variance");
  return {};
}

namespace {
constexpr size_t kMaxHealthNameLength = 64;
bool isHealthNameChar(unsigned char c) { return std::isalnum(c) || c == '_' || c == '-' || c == '.'; }
}  // namespace

bool isHealthName(const std::string& s) {
  return !s.empty() && s.size() <= kMaxHealthNameLength &&
         std::all_of(s.begin(), s.end(), [](char c) { return isHealthNameChar(static_cast<unsigned char>(c)); });
}

std::string toHealthName(const std::string& name) {
  if (isHealthName(name)) return name;
  std::string out = name.substr(0, kMaxHealthNameLength);
  for (auto& c : out)
    if (!isHealthNameChar(static_cast<unsigned char>(c))) c = '_';
  return out.empty() ? std::string("unnamed") : out;
}

namespace {
bool isPrintable(const std::string& s) {
  if (s.size() > 255) return false;
  for (unsigned char c : s)
    if (c < 0x20 || c > 0x7e) return false;
  return true;
}
}  // namespace

std::string healthChannel(const std::string& process_name) {
  std::string ch = process_name;
  for (auto& c : ch) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return channels::kHealthPrefix + ch;
}

Verdict validate(const ips::health_t& m, const std::string& channel) {
  if (!isHealthName(m.process)) return bad("bad_value", "health message with an impossible process name");
  if (!isPrintable(m.host)) return bad("bad_value", "health message with an unprintable host name");
  if (channel != healthChannel(m.process))
    return bad("bad_value", "health of '" + m.process + "' received on " + channel);
  if (m.received < 0 || m.published < 0 || m.dropped < 0 || m.bad < 0 || m.queue_length < 0)
    return bad("bad_value", "health message with a negative count");
  if (!std::isfinite(m.input_rate_hz) || !std::isfinite(m.output_rate_hz) || !std::isfinite(m.latency_ms))
    return bad("nan", "health message with NaN or inf");
  if (m.num_counters < 0 || static_cast<size_t>(m.num_counters) != m.counter_names.size() ||
      m.counter_values.size() != m.counter_names.size())
    return bad("bad_size", "health message with counters of wrong size");
  for (const auto& n : m.counter_names)
    if (!isHealthName(n)) return bad("bad_value", "health message with an impossible counter name");
  return {};
}

Verdict validate(const ips::keyframe_t& m) {
  if (m.utime < 0 || m.seq < 0) return bad("bad_value", "keyframe with a negative stamp or sequence number");
  return {};
}

Verdict validate(const ips::stereo_time_t& m) {
  if (m.utime < 0 || m.seq < 0) return bad("bad_value", "stereo time with a negative stamp or sequence number");
  return {};
}

Verdict validate(const ips::integrity_t& m) {
  if (m.state < ips::integrity_t::STATE_NO_DATA || m.state > ips::integrity_t::STATE_ALARM)
    return bad("bad_value", "integrity message with unknown state " + std::to_string(m.state));
  if (!finite(m.correction, 4) || !finite(m.correction_covariance, 16) || !finite(m.applied, 4))
    return bad("nan", "integrity message with NaN or inf");
  constexpr double kMaxRotationRad = 5 * M_PI / 180, kMaxFocalScale = 0.1;
  if (std::sqrt(m.applied[0] * m.applied[0] + m.applied[1] * m.applied[1] + m.applied[2] * m.applied[2]) >
          kMaxRotationRad ||
      std::fabs(m.applied[3]) > kMaxFocalScale)
    return bad("bad_value", "integrity message with an applied correction beyond 5 deg or 10 % of focal length");
  if (m.applied_utime < 0 || m.applied_utime > m.utime)
    return bad("bad_time", "integrity message whose correction was decided after its own pair");
  constexpr double kMaxDisparityOffsetPx = 20;  // a principal point tens of pixels off is no calibration at all
  if (!std::isfinite(m.disparity_offset_px) || std::fabs(m.disparity_offset_px) > kMaxDisparityOffsetPx)
    return bad("bad_value", "integrity message with a disparity offset beyond 20 px or not finite");
  if (m.disparity_offset_utime < 0 || m.disparity_offset_utime > m.utime)
    return bad("bad_time", "integrity message whose disparity offset was applied after its own pair");
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

const char* StreamOrder::reason(Outcome o) {
  switch (o) {
    case Outcome::jump:
      return "time_jump";
    case Outcome::backwards:
      return "time_backwards";
    case Outcome::ahead_of_host:
      return "time_ahead_of_host";
    default:
      return "";
  }
}

int64_t StreamOrder::maxStep() const {
  if (num_steps_ < kSteps) return limits_.max_forward_step_us;
  int64_t sorted[kSteps];
  std::copy(steps_, steps_ + kSteps, sorted);
  std::nth_element(sorted, sorted + kSteps / 2, sorted + kSteps);
  const int64_t median = sorted[kSteps / 2];
  const int64_t by_rhythm = median > limits_.max_forward_step_us / limits_.gap_intervals
                                ? limits_.max_forward_step_us
                                : median * limits_.gap_intervals;
  return std::clamp(by_rhythm, limits_.min_forward_step_us, limits_.max_forward_step_us);
}

void StreamOrder::recordStep(int64_t step) {
  steps_[next_step_] = step;
  next_step_ = (next_step_ + 1) % kSteps;
  num_steps_ = std::min(num_steps_ + 1, kSteps);
}

StreamOrder::Result StreamOrder::check(int64_t utime, int64_t seq, int64_t arrival_us) {
  Result r;
  const bool ahead_of_host = aheadOfHost(utime, arrival_us);
  if (!first_ && (ahead_of_host || !(fitsAfter(utime, last_utime_) || pauseConfirmedByHost(utime, arrival_us)))) {
    // Not on the current time line: a candidate for a new one, adopted only once confirmed. A line that has not
    // itself been confirmed (fewer than `confirm` messages on it: the stream's first messages) is no reference: a
    // forged first stamp far ahead must not make the real ones that follow, far behind it, look late, so they start
    // a line at once. (A repeat, or a stamp a little back, is still refused.)
    if (on_line_ < limits_.confirm && utime < last_utime_ - maxStep()) {
      r.clock_step = r.rebased = true;
      first_ = true;
      num_steps_ = 0;
      have_delivery_ = false;
      candidate_count_ = 0;
    } else if (candidate_count_ > 0 && fitsAfter(utime, candidate_utime_))
      ++candidate_count_;
    else
      candidate_count_ = 1;
    if (!r.rebased) candidate_utime_ = utime;
    if (!r.rebased && candidate_count_ < limits_.confirm) {
      r.accept = false;
      r.outcome = utime <= last_utime_ ? Outcome::backwards : ahead_of_host ? Outcome::ahead_of_host : Outcome::jump;
      return r;
    }
    if (!r.rebased) r.clock_step = true;
    first_ = true;           // the new line starts here: no sequence gap is counted across the step
    num_steps_ = 0;          // and its rhythm is learnt again,
    have_delivery_ = false;  // and its delivery
  }
  candidate_count_ = 0;
  if (!first_) {
    int64_t diff = 0;
    const bool overflow = __builtin_sub_overflow(seq, last_seq_, &diff);
    if (overflow || diff < 0) {
      r.seq_reset = true;
    } else if (diff > 1) {
      // At most max_rate_hz messages fit in the elapsed time (plus one for rounding).
      const double possible = (utime - last_utime_) * 1e-6 * limits_.max_rate_hz + 1.0;
      if (static_cast<double>(diff - 1) <= possible)
        r.gap = diff - 1;
      else
        r.seq_reset = true;
    }
  }
  if (!first_) recordStep(utime - last_utime_);
  last_arrival_us_ = arrival_us;
  if (arrival_us != 0) {
    const int64_t delivery = arrival_us - utime;
    fastest_delivery_us_ = have_delivery_ ? std::min(fastest_delivery_us_, delivery) : delivery;
    have_delivery_ = true;
  }
  on_line_ = first_ ? 1 : on_line_ + 1;
  first_ = false;
  last_utime_ = utime;
  last_seq_ = seq;
  return r;
}

bool StereoAdmission::admit(const ips::stereo_pair_t& m, Health& health, int64_t arrival_us) {
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
  return admitInOrder(order_, m.utime, m.seq, health, "stereo", arrival_us);
}

bool admitInOrder(StreamOrder& order, int64_t utime, int64_t seq, Health& health, const std::string& what,
                  int64_t arrival_us) {
  const StreamOrder::Result r = order.check(utime, seq, arrival_us);
  if (!r.accept) {
    health.bad(StreamOrder::reason(r.outcome),
               what + " stamp " + std::to_string(utime) + " us " +
                   (r.outcome == StreamOrder::Outcome::jump            ? "implausibly far ahead of"
                    : r.outcome == StreamOrder::Outcome::ahead_of_host ? "ahead of the host's clock, after"
                                                                       : "not after") +
                   " the stream's last one (" + std::to_string(order.lastUtime()) + " us)");
    return false;
  }
  if (r.rebased) {
    health.count(what + "_time_rebased");
    health.restartClock(utime);
    IPS_WARN(what << ": the stream's first stamps did not hold (one far off, or a restart); following it from " << utime
                  << " us");
  } else if (r.clock_step) {
    health.count(what + "_clock_step");
    IPS_WARN(what << ": the stream's clock stepped; following it from " << utime << " us");
  }
  if (r.seq_reset) health.count(what + "_seq_reset");
  if (r.gap > 0) health.dropped(what + "_seq_gap", r.gap);
  return true;
}

}  // namespace ips::fw
