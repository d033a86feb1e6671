#pragma once
// The filter's LCM side: IMU, TILT, STEREO_TIME (image times), TRACKER_DELTA, KEYFRAME and CLOUD_DELTA in, checked and
// converted to the estimator's plain types; FILTER_STATE and FILTER_PRIOR out; the estimator's counters as health.
#include <chrono>
#include <deque>
#include <ips/imu_sample_t.hpp>
#include <ips/keyframe_t.hpp>
#include <ips/stereo_time_t.hpp>
#include <ips/tilt_sample_t.hpp>
#include <ips/tracker_delta_t.hpp>
#include <string>

#include "ips/filter/estimator.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/validate.hpp"

namespace ips::filter_app {

class FilterProcess {
 public:
  // prior_channel empty: no a-priori states published.
  FilterProcess(fw::Node& node, filter::Estimator& estimator, std::string state_channel, std::string prior_channel);

  // End of input: applies what the reordering window still holds and publishes it, paced, because LCM
  // receivers drop a burst of hundreds of messages sent back to back (their receive queue overflows).
  void flush();
  // The estimator's new states join the queue, and what the pace allows goes out now (kStatesPerMs, bursts of
  // kStateBurst): a start in motion or a late delta gives hundreds at once, and a receiver that keeps LCM's
  // 30-message queue (lcm-logger) drops most of a burst sent back to back. The steady rate is one state per IMU
  // sample (200 Hz), so a backlog drains within a fraction of a second; the pace is the wall clock's (transport
  // only: what is published does not depend on it).
  void publishOutputs();  // also between inputs (Node::run's tick)

 private:
  template <class Msg>
  bool check(const Msg& m, fw::StreamOrder& order, const char* what);
  void onImu(const imu_sample_t& m);
  void onTilt(const tilt_sample_t& m);
  void onStereo(const stereo_time_t& m);
  void onDelta(const tracker_delta_t& m);
  void onKeyframe(const keyframe_t& m);
  void onCloudDelta(const tracker_delta_t& m);
  void publishOldest();  // the queue's oldest state, counted
  // The estimator's counters into the health message, once per report.
  void reportCounters(fw::Health& health) const;

  fw::Node& node_;
  filter::Estimator& est_;
  std::string state_channel_, prior_channel_;
  std::string prior_none_channel_;  // image times without a prior (channels::kFilterPriorNone for the default)
  fw::StreamOrder imu_order_, tilt_order_, stereo_order_, delta_order_, cloud_order_;
  std::deque<filter::FilterOutput> pending_;
  double send_budget_ = 0;  // states that may go out now
  std::chrono::steady_clock::time_point budget_time_ = std::chrono::steady_clock::now();
  int64_t published_ = 0;  // states sent on state_channel_ (the report counts what its recording holds against it)
};

}  // namespace ips::filter_app
