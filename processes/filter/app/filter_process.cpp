#include "filter_process.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ips/filter_state_t.hpp>
#include <thread>

#include "filter_messages.hpp"
#include "ips/framework/channels.hpp"
#include "ips/framework/filter_state_layout.hpp"
#include "ips/framework/message_arrays.hpp"

namespace ips::filter_app {

namespace {

constexpr int kFlushPacingUs = 1000;  // between the held-back states published at shutdown
constexpr double kStatesPerMs = 1.0, kStateBurst = 8;

}  // namespace

FilterProcess::FilterProcess(fw::Node& node, filter::Estimator& estimator, std::string state_channel,
                             std::string prior_channel)
    : node_(node),
      est_(estimator),
      state_channel_(std::move(state_channel)),
      prior_channel_(std::move(prior_channel)),
      prior_none_channel_(prior_channel_ + "_NONE") {
  using namespace ips::channels;
  node_.subscribe<ips::imu_sample_t>(kImu, [this](const ips::imu_sample_t& m) { onImu(m); });
  node_.subscribe<ips::tilt_sample_t>(kTilt, [this](const ips::tilt_sample_t& m) { onTilt(m); });
  node_.subscribe<ips::stereo_time_t>(kStereoTime, [this](const ips::stereo_time_t& m) { onStereo(m); });
  node_.subscribe<ips::tracker_delta_t>(kTrackerDelta, [this](const ips::tracker_delta_t& m) { onDelta(m); });
  node_.subscribe<ips::keyframe_t>(kKeyframe, [this](const ips::keyframe_t& m) { onKeyframe(m); });
  node_.subscribe<ips::tracker_delta_t>(kCloudDelta, [this](const ips::tracker_delta_t& m) { onCloudDelta(m); });
  node_.onHealthReport([this](fw::Health& health) { reportCounters(health); });
}

void FilterProcess::flush() {
  est_.flush();
  for (auto& out : est_.takeOutputs()) pending_.push_back(std::move(out));
  while (!pending_.empty()) {
    publishOldest();
    std::this_thread::sleep_for(std::chrono::microseconds(kFlushPacingUs));
  }
}

void FilterProcess::publishOldest() {
  node_.publish(state_channel_, toMessage(pending_.front()));
  pending_.pop_front();
  ++published_;
}

template <class Msg>
bool FilterProcess::check(const Msg& m, ips::fw::StreamOrder& order, const char* what) {
  node_.health().received(m.utime);
  ips::fw::Verdict v = ips::fw::validate(m);
  if (!v.ok()) {
    node_.health().bad(v.reason, v.detail);
    return false;
  }
  // Across streams the estimator sorts (and counts what comes too late); within one stream a stamp that
  // does not increase, or leaps implausibly far, is a fault of the source and is never adopted.
  if (!ips::fw::admitInOrder(order, m.utime, m.seq, node_.health(), what, node_.arrivalUs())) return false;
  node_.health().accepted();
  return true;
}

void FilterProcess::onImu(const ips::imu_sample_t& m) {
  if (!check(m, imu_order_, "imu")) return;
  const ips::filter::ImuSample s = toImuSample(m);
  est_.addImu(s);
  publishOutputs();
}

void FilterProcess::onTilt(const ips::tilt_sample_t& m) {
  if (!check(m, tilt_order_, "tilt")) return;
  est_.addTilt(ips::filter::TiltSample{m.utime, m.angle_x, m.angle_y});
  publishOutputs();
}

void FilterProcess::onStereo(const ips::stereo_time_t& m) {
  if (!check(m, stereo_order_, "stereo")) return;
  auto prior = est_.addImageTime(m.utime);
  if (prior_channel_.empty()) return;
  if (prior) {
    node_.publish(prior_channel_, toMessage(*prior));
  } else {
    // Answered all the same, so that the tracker does not wait for a prior that is not coming.
    node_.publish(prior_none_channel_, m);
    node_.health().count("no_prior_yet");
  }
}

void FilterProcess::onDelta(const ips::tracker_delta_t& m) {
  // A delta repeated, or sent by a second tracker for the same pair, does not advance the stream's time
  // and is dropped here: each image interval is fused once.
  if (!check(m, delta_order_, "delta")) return;
  if (!m.valid) node_.health().count("tracker_invalid");
  if (!m.valid && !m.far_valid) return;
  est_.addTrackerDelta(toDelta(m));
  publishOutputs();
}

void FilterProcess::onKeyframe(const ips::keyframe_t& m) {
  node_.health().received(m.utime);
  const ips::fw::Verdict v = ips::fw::validate(m);
  if (!v.ok()) return node_.health().bad(v.reason, v.detail);
  node_.health().accepted();
  est_.addKeyframe(m.utime);
}

void FilterProcess::onCloudDelta(const ips::tracker_delta_t& m) {
  if (!check(m, cloud_order_, "cloud")) return;
  if (!m.valid) {
    node_.health().count("cloud_invalid");
    return;
  }
  est_.addCloudDelta(toDelta(m));
  publishOutputs();
}

void FilterProcess::publishOutputs() {
  for (auto& out : est_.takeOutputs()) pending_.push_back(std::move(out));
  const auto now = std::chrono::steady_clock::now();
  send_budget_ = std::min(
      kStateBurst, send_budget_ + kStatesPerMs * std::chrono::duration<double, std::milli>(now - budget_time_).count());
  budget_time_ = now;
  for (; send_budget_ >= 1 && !pending_.empty(); send_budget_ -= 1) publishOldest();
}

void FilterProcess::reportCounters(fw::Health& health) const {
  for (const auto& c : est_.counters()) {
    if (!c.name || !*c.name) continue;
    health.set(std::string(c.name) + "_accepted", c.accepted);
    health.set(std::string(c.name) + "_rejected", c.rejected);
    health.set(std::string(c.name) + "_too_late", c.too_late);
  }
  health.set("cloud_applied_late", est_.cloudAppliedLate());
  health.set("imu_gaps", est_.imuGaps());
  health.set("ahead_of_imu", est_.aheadOfImu());
  health.set("starts_in_motion", est_.startsInMotion());
  health.set("published_" + state_channel_, published_);
  health.set("states_queued", static_cast<int64_t>(pending_.size()));
  // The camera's delay against the IMU as estimated online [us], whether it is applied, and how often it ran.
  const filter::CameraDelayEstimator::Figures& delay = est_.cameraDelay();
  health.set("camera_delay_us", std::llround(delay.delay_us));
  health.set("camera_delay_sigma_us", std::llround(delay.sigma_us));
  health.set("camera_delay_applied", delay.applied ? 1 : 0);
  health.set("camera_delay_estimates", delay.estimates);
}

}  // namespace ips::filter_app
