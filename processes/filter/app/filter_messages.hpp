#pragma once
// The filter's messages to and from ips_filter's plain types: one place for the process and for the tools that run
// the estimator over a recording (navigate_log), so that both publish the same states.
#include <ips/filter_state_t.hpp>
#include <ips/imu_sample_t.hpp>
#include <ips/tracker_delta_t.hpp>

#include "ips/filter/estimator.hpp"

namespace ips::filter_app {

ips::filter_state_t toMessage(const ips::filter::FilterOutput& out);
ips::filter::TrackerDelta toDelta(const ips::tracker_delta_t& m);
ips::filter::ImuSample toImuSample(const ips::imu_sample_t& m);

}  // namespace ips::filter_app
