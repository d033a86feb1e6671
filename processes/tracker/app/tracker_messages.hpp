#pragma once
// The tracker's messages to and from ips_tracker's plain types: one place for the process and for the tools that
// run the tracker over a recording (navigate_log), so that both publish the same deltas.
#include <ips/filter_state_t.hpp>
#include <ips/tracker_delta_t.hpp>

#include "ips/tracker/prior_builder.hpp"
#include "ips/tracker/stereo_tracker.hpp"

namespace ips::tracker_app {

// The filter's a-priori state in the prior builder's plain type.
tracker::FilterPriorState fromMessage(const filter_state_t& s);
tracker_delta_t toMessage(const tracker::TrackResult& r, int64_t seq);

}  // namespace ips::tracker_app
