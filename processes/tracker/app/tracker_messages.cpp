#include "tracker_messages.hpp"

#include "ips/framework/filter_state_layout.hpp"
#include "ips/framework/message_arrays.hpp"
#include "ips/framework/message_poses.hpp"

namespace ips::tracker_app {

tracker::FilterPriorState fromMessage(const filter_state_t& s) {
  namespace layout = fw::filter_state_layout;
  tracker::FilterPriorState p;
  p.utime = s.utime;
  p.T_world_body = fw::bodyPose(s).T_world_body;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      p.velocity_cov(r, c) = s.covariance[layout::kVelocity + r][layout::kVelocity + c];
      p.angular_rate_cov(r, c) = s.covariance[layout::kAngularRate + r][layout::kAngularRate + c];
    }
  p.gyro_bias = fw::vectorFromArray(s.gyro_bias);
  return p;
}

tracker_delta_t toMessage(const tracker::TrackResult& r, int64_t seq) {
  tracker_delta_t d{};
  d.utime = r.utime;
  d.utime_prev = r.utime_prev;
  d.seq = seq;
  d.valid = r.valid;
  fw::vectorToArray(r.translation, d.translation);
  fw::quaternionToArray(r.rotation, d.rotation);
  fw::matrixToArray<6>(r.covariance, d.covariance);
  d.num_features = r.num_features;
  d.num_intra_matches = r.num_intra_matches;
  d.num_inter_matches = r.num_inter_matches;
  d.num_inliers = r.num_inliers;
  d.residual_rms = r.residual_rms;
  d.prior_source = static_cast<int8_t>(r.prior_source);
  d.prior_ok = r.prior_ok;
  d.far_valid = r.far_valid;
  fw::quaternionToArray(r.far_rotation, d.far_rotation);
  fw::matrixToArray<3>(r.far_covariance, d.far_rotation_covariance);
  d.num_far_matches = r.num_far_matches;
  d.num_far_inliers = r.num_far_inliers;
  return d;
}

}  // namespace ips::tracker_app
