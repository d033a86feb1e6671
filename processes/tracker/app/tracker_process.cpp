#include "tracker_process.hpp"

#include <cmath>
#include <ips/integrity_t.hpp>
#include <ips/tracker_delta_t.hpp>
#include <optional>

#include "ips/framework/channels.hpp"
#include "ips/framework/filter_state_layout.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/message_arrays.hpp"
#include "ips/framework/message_poses.hpp"
#include "ips/log.hpp"
#include "tracker_messages.hpp"

namespace ips::tracker_app {

namespace {

// A DISPARITY message as the tracker's guide, at the scale guideScale found for it.
tracker::DisparityGuide fromMessage(const disparity_map_t& m, double scale) {
  tracker::DisparityGuide guide;
  guide.scale = scale;
  guide.subpixel_scale = m.subpixel_scale;
  guide.invalid_value = m.invalid_value;
  guide.disparity.create(m.height, m.width, CV_16SC1);
  for (int r = 0; r < m.height; ++r) std::copy(m.data[r].begin(), m.data[r].end(), guide.disparity.ptr<int16_t>(r));
  return guide;
}

integrity_t toMessage(const tracker::IntegrityStatus& s, int64_t seq, double disparity_offset_px,
                      int64_t disparity_offset_utime) {
  integrity_t m{};
  m.utime = s.utime;
  m.seq = seq;
  m.state = static_cast<int8_t>(s.state);
  m.num_probes = s.num_probes;
  m.num_points = s.num_points;
  m.num_outliers = s.num_outliers;
  m.dy_median_px = static_cast<float>(s.dy_median_px);
  m.dy_rms_px = static_cast<float>(s.dy_rms_px);
  m.pair_valid = s.pair_valid;
  m.pair_offset_px = static_cast<float>(s.pair_offset_px);
  m.pair_chi2 = static_cast<float>(s.pair_chi2);
  const Eigen::Vector4d estimate = tracker::toVector(s.estimate), applied = tracker::toVector(s.applied);
  for (int i = 0; i < 4; ++i) {
    m.correction[i] = estimate[i];
    m.applied[i] = applied[i];
  }
  fw::matrixToArray<4>(s.covariance, m.correction_covariance);
  m.estimate_offset_px = static_cast<float>(s.estimate_offset_px);
  m.estimate_sigma_px = static_cast<float>(s.estimate_sigma_px);
  m.certain = s.certain;
  m.applied_utime = s.applied_utime;
  m.disparity_offset_px = static_cast<float>(disparity_offset_px);
  m.disparity_offset_utime = disparity_offset_utime;
  m.alarms = static_cast<int32_t>(s.alarms);
  m.steps = static_cast<int32_t>(s.steps);
  m.corrections = static_cast<int32_t>(s.corrections);
  return m;
}

}  // namespace

TrackerProcess::TrackerProcess(fw::Node& node, const StereoCalibration& calib, const tracker::TrackerParams& params,
                               const tracker::IntegrityParams& integrity,
                               const tracker::PriorBuilderParams& prior_builder, const tracker::DisparityWait& wait)
    : node_(node),
      tracker_(calib, params),
      monitor_(tracker_.rectification(), integrity),
      priors_(calib.T_imu_cam0, prior_builder, params.prior),
      admission_(calib.cam0.width, calib.cam0.height),
      pairs_(wait) {
  node_.subscribe<stereo_pair_t>(channels::kStereo, [this](const stereo_pair_t& m) { onStereo(m); });
  if (wait.enabled)
    node_.subscribe<disparity_map_t>(channels::kDisparity, [this](const disparity_map_t& m) { onDisparity(m); });
  node_.subscribe<filter_state_t>(channels::kFilterPrior, [this](const filter_state_t& m) { onPrior(m); });
  node_.subscribe<stereo_time_t>(channels::kFilterPriorNone, [this](const stereo_time_t& m) { onPriorNone(m); });
  node_.subscribe<imu_sample_t>(channels::kImu, [this](const imu_sample_t& m) { onImu(m); });
}

void TrackerProcess::flush() {
  while (!pairs_.empty()) processOldest();
}

void TrackerProcess::onStereo(const stereo_pair_t& m) {
  if (!admission_.admit(m, node_.health(), node_.arrivalUs())) return;
  node_.health().accepted();
  pairs_.addPair({m.utime, m.seq, fw::mono8Copy(fw::leftImage(m)), fw::mono8Copy(fw::rightImage(m))});
  node_.health().queueLength(static_cast<int>(pairs_.size()));
  drain();
}

void TrackerProcess::onPrior(const filter_state_t& m) {
  fw::Verdict v = fw::validate(m);
  if (!v.ok() || m.cov_dim < 21) return node_.health().bad(v.ok() ? "bad_size" : v.reason, "filter prior: " + v.detail);
  priors_.addFilterState(fromMessage(m));
  drain();
}

void TrackerProcess::onDisparity(const disparity_map_t& m) {
  const fw::Verdict v = fw::validate(m);
  if (!v.ok()) return node_.health().bad(v.reason, "disparity: " + v.detail);
  const auto scale =
      tracker::guideScale(tracker_.rectification(), m.focal_px, m.cx, m.cy, m.baseline_m, cv::Size(m.width, m.height));
  if (!scale)
    return node_.health().bad("disparity_geometry", "a DISPARITY map of another rectification (f " +
                                                        std::to_string(m.focal_px) + ", cx " + std::to_string(m.cx) +
                                                        "): E3D must run on the tracker's calibration, alpha 0");
  // Stamps checked against the stream's rhythm: a forged stamp far ahead would end every pair's wait.
  if (!fw::admitInOrder(disparity_order_, m.utime, 0, node_.health(), "disparity", node_.arrivalUs())) return;
  // Maps of pairs already tracked, or far ahead of what the tracker holds, are of no use.
  if (!pairs_.acceptsMap(m.utime)) {
    node_.health().count("disparity_unused");
    return;
  }
  pairs_.addMap(m.utime, m.seq, fromMessage(m, *scale));
  drain();
}

void TrackerProcess::onPriorNone(const stereo_time_t& m) {
  const fw::Verdict v = fw::validate(m);
  if (!v.ok()) return node_.health().bad(v.reason, "filter prior none: " + v.detail);
  priors_.addFilterNone(m.utime);
  drain();
}

void TrackerProcess::onImu(const imu_sample_t& m) {
  if (!fw::validate(m).ok()) return;  // the filter counts bad IMU input; here it only places windows
  priors_.addGyro(m.utime, fw::vectorFromArray(m.angular_rate));
  if (!pairs_.empty()) drain();
}

void TrackerProcess::drain() {
  // Messages that have piled up in the socket are read first (cheap: copies), so that a tracker behind the
  // camera skips the pairs it cannot catch up with instead of working through a backlog whose deltas come too
  // late for the filter. Without a backlog this changes nothing: each pair is the only one pending.
  if (const int stale = pairs_.dropStale()) node_.health().dropped("stale_pair", stale);
  // Read again after each pair (the socket's buffer holds a few pairs only); a bus that never falls silent (a flood)
  // must not hold more than max_pending pairs back.
  const auto reads_first = [this]() {
    return node_.inputWaiting() && pairs_.size() < static_cast<size_t>(pairs_.wait().max_pending);
  };
  while (!pairs_.empty() && !reads_first() && pairs_.oldestGoesOn(tracker::priorReady(priors_, pairs_.oldestUtime())))
    processOldest();
  node_.health().queueLength(static_cast<int>(pairs_.size()));
}

void TrackerProcess::processOldest() {
  tracker::PendingPair p = pairs_.takeOldest();
  const int64_t last_utime = pairs_.lastTracked();
  std::optional<tracker::MotionPrior> prior;
  if (last_utime > 0) {
    if ((prior = priors_.fromFilter(last_utime, p.utime))) {
      node_.health().count("prior_filter");
    } else if ((prior = priors_.fromGyro(last_utime, p.utime))) {
      node_.health().count("prior_imu");
      if (priors_.filterSeen()) node_.health().count("filter_prior_missing");
    } else {
      node_.health().count("prior_constant_velocity");
    }
  }
  // E3D's map of this pair, if it came (same seq and stamp).
  const tracker::DisparityGuide* guide = pairs_.mapFor(p);
  if (guide)
    node_.health().count("intra_from_disparity");
  else if (pairs_.expectsMap(p.seq))
    node_.health().count("intra_without_disparity");
  tracker::TrackResult r;
  try {
    r = tracker_.process(p.utime, p.left, p.right, prior ? &*prior : nullptr, guide);
  } catch (const std::exception& e) {
    node_.health().bad("tracker_error", e.what());
    return;
  }
  node_.health().latency(r.times.total);
  // The monitor probes pairs at its own rate (integrity/max_rate_hz); the others are counted.
  if (monitor_.due(p.utime))
    checkIntegrity(p);
  else if (monitor_.params().enabled)
    node_.health().count("integrity_decimated");
  pairs_.tracked(p.utime);
  if (r.intra_guided) {
    node_.health().count("intra_matches_from_disparity", r.guided_intra.from_map);
    node_.health().count("intra_disparity_check_failed", r.guided_intra.check_failed);
  }
  if (r.utime_prev == 0) return;  // the first pair only becomes the reference
  if (r.far_valid) node_.health().count("far_rotation");
  if (!r.valid) node_.health().count("invalid_delta");
  if (r.retry_around_own_motion) node_.health().count("prior_overruled_by_own_motion");
  // The disparity offset (DisparityOffsetParams) in thousandths of a pixel: in use, the running estimate, its sigma.
  if (r.disparity_offset_rejected) node_.health().count("disparity_offset_refused");
  if (r.disparity_offset_applied) {
    node_.health().count("disparity_offset_applied");
    IPS_INFO("tracker: disparity offset " << r.disparity_offset_px << " px (sigma " << r.disparity_offset_sigma_px
                                          << ") applied from the pair after " << r.utime);
  }
  node_.health().set("disparity_offset_mpx", std::llround(1000 * tracker_.disparityOffset()));
  node_.health().set("disparity_offset_estimate_mpx", std::llround(1000 * r.disparity_offset_px));
  if (std::isfinite(r.disparity_offset_sigma_px))
    node_.health().set("disparity_offset_sigma_mpx", std::llround(1000 * r.disparity_offset_sigma_px));
  const auto& st = tracker_.predictionStats();
  node_.health().set("prediction_ok_permille",
                     st.frames_with_prior ? 1000 * st.frames_prior_ok / st.frames_with_prior : 0);
  node_.publish(channels::kTrackerDelta, toMessage(r, p.seq));
}

void TrackerProcess::checkIntegrity(const tracker::PendingPair& p) {
  const tracker::IntegrityStatus& s = tracker::monitorPair(monitor_, tracker_, p.utime);
  fw::Health& h = node_.health();
  h.set("integrity_state", static_cast<int64_t>(s.state));
  h.set("integrity_alarms", s.alarms);
  h.set("integrity_steps", s.steps);
  h.set("integrity_corrections", s.corrections);
  h.set("integrity_offset_mpx", std::llround(1000 * s.estimate_offset_px));
  if (!s.pair_valid) h.count("integrity_without_measurement");
  if (s.applied_now)
    IPS_WARN("epipolar integrity: the right camera has turned; pairs after "
             << s.utime << " are rectified with the new correction (corrections so far: " << s.corrections << ")");
  node_.publish(channels::kIntegrity,
                toMessage(s, p.seq, tracker_.disparityOffset(), tracker_.disparityOffsetAppliedUtime()));
}

}  // namespace ips::tracker_app
