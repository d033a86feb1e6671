// tracker: the IPS stereo tracker as a process. STEREO pairs in, TRACKER_DELTA out.
// The search windows of the inter-matching are placed by the best motion prior on the bus: the filter's
// a-priori state at the new image time (FILTER_PRIOR) when a filter runs, else the gyro (IMU), else constant
// velocity. When a filter has been seen, a pair waits for its prior (the filter publishes one for every image
// time), else for the IMU to cover its time, so that a replayed log gives the same deltas as the live run.
// With process/intra_from_disparity, a pair E3D matches (seq % disparity_every_nth == 0) also waits for its
// DISPARITY map and takes its intra-matches from it: live until disparity_wait_pairs newer pairs are pending,
// with --queue-disparity (replay) until the map or a later one arrives, so that the replay repeats itself.
// With integrity/enabled, every pair also goes through the epipolar integrity monitor: INTEGRITY out, and the right
// camera's correction, once certain, used for the following pairs (and by E3D).
#include <ips/disparity_map_t.hpp>
#include <ips/filter_state_t.hpp>
#include <ips/imu_sample_t.hpp>
#include <ips/integrity_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <ips/tracker_delta_t.hpp>
#include <map>
#include <opencv2/imgproc.hpp>
#include <optional>

#include "ips/calibration.hpp"
#include "ips/config.hpp"
#include "ips/framework/channels.hpp"
#include "ips/framework/filter_state_layout.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/message_arrays.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/process.hpp"
#include "ips/framework/validate.hpp"
#include "ips/tracker/epipolar_integrity.hpp"
#include "ips/tracker/params.hpp"
#include "ips/tracker/prior_builder.hpp"
#include "ips/tracker/stereo_tracker.hpp"

namespace {

struct Pending {
  int64_t utime = 0;
  int64_t seq = 0;
  cv::Mat left, right;  // 8-bit copies (the message buffer is gone after the handler)
};

// The filter's a-priori state in the prior builder's plain type.
ips::tracker::FilterPriorState fromMessage(const ips::filter_state_t& s) {
  namespace layout = ips::fw::filter_state_layout;
  ips::tracker::FilterPriorState p;
  p.utime = s.utime;
  p.T_world_body.linear() = Eigen::Quaterniond(s.orientation[0], s.orientation[1], s.orientation[2], s.orientation[3])
                                .normalized()
                                .toRotationMatrix();
  p.T_world_body.translation() = Eigen::Vector3d(s.position[0], s.position[1], s.position[2]);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      p.velocity_cov(r, c) = s.covariance[layout::kVelocity + r][layout::kVelocity + c];
      p.angular_rate_cov(r, c) = s.covariance[layout::kAngularRate + r][layout::kAngularRate + c];
    }
  p.gyro_bias = Eigen::Vector3d(s.gyro_bias[0], s.gyro_bias[1], s.gyro_bias[2]);
  return p;
}

ips::tracker::PriorBuilderParams priorBuilderParams(const ips::Config& cfg) {
  ips::tracker::PriorBuilderParams p;
  p.gyro_rate_sigma = cfg.getDouble("process/gyro_rate_sigma", p.gyro_rate_sigma);
  p.filter_rotation_floor = cfg.getDouble("process/filter_prior_rotation_floor", p.filter_rotation_floor);
  p.filter_translation_floor = cfg.getDouble("process/filter_prior_translation_floor", p.filter_translation_floor);
  p.max_filter_states = cfg.getInt("process/max_filter_priors", p.max_filter_states);
  p.gyro_window_s = cfg.getDouble("process/gyro_window_s", p.gyro_window_s);
  if (!(p.gyro_rate_sigma > 0 && p.filter_rotation_floor >= 0 && p.filter_translation_floor >= 0 &&
        p.max_filter_states >= 2 && p.gyro_window_s > 0))
    throw ips::ConfigError(cfg.path() +
                           ": process/ prior keys out of range (sigmas and floors >= 0, "
                           "max_filter_priors >= 2, gyro_window_s > 0)");
  return p;
}

// Intra-matching from E3D's maps: which pairs wait for one, and how long.
struct DisparityWait {
  bool enabled = false;
  int every_nth = 1;     // E3D's process/every_nth: the pairs it matches
  int wait_pairs = 2;    // live: newer pairs pending before a pair goes on without its map
  bool queue = false;    // replay: wait until the map (or a later one) arrives
  int max_pending = 64;  // the bound on pairs held in either mode (two images each)
};

DisparityWait disparityWait(const ips::Config& cfg, bool queue) {
  DisparityWait w;
  w.enabled = cfg.getBool("process/intra_from_disparity", w.enabled);
  w.every_nth = cfg.getInt("process/disparity_every_nth", w.every_nth);
  w.wait_pairs = cfg.getInt("process/disparity_wait_pairs", w.wait_pairs);
  w.max_pending = cfg.getInt("process/disparity_max_pending", w.max_pending);
  w.queue = queue;
  if (w.every_nth < 1 || w.wait_pairs < 0 || w.max_pending < 2)
    throw ips::ConfigError(
        cfg.path() +
        ": process/ disparity keys out of range (disparity_every_nth >= 1, disparity_wait_pairs >= 0, "
        "disparity_max_pending >= 2)");
  return w;
}

ips::integrity_t integrityMessage(const ips::tracker::IntegrityStatus& s, int64_t seq) {
  ips::integrity_t m{};
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
  const Eigen::Vector4d estimate = ips::tracker::toVector(s.estimate), applied = ips::tracker::toVector(s.applied);
  for (int i = 0; i < 4; ++i) {
    m.correction[i] = estimate[i];
    m.applied[i] = applied[i];
  }
  ips::fw::matrixToArray<4>(s.covariance, m.correction_covariance);
  m.estimate_offset_px = static_cast<float>(s.estimate_offset_px);
  m.estimate_sigma_px = static_cast<float>(s.estimate_sigma_px);
  m.certain = s.certain;
  m.applied_utime = s.applied_utime;
  m.alarms = static_cast<int32_t>(s.alarms);
  m.steps = static_cast<int32_t>(s.steps);
  m.corrections = static_cast<int32_t>(s.corrections);
  return m;
}

// A DISPARITY message as the tracker's guide (the map of the pair with this seq and stamp).
struct StoredMap {
  int64_t seq = 0;
  ips::tracker::DisparityGuide guide;
};

class TrackerProcess {
 public:
  TrackerProcess(ips::fw::Node& node, const ips::StereoCalibration& calib, const ips::tracker::TrackerParams& params,
                 const ips::Config& cfg, const DisparityWait& wait)
      : node_(node),
        tracker_(calib, params),
        monitor_(tracker_.rectification(), ips::tracker::loadIntegrityParams(cfg)),
        priors_(calib.T_imu_cam0, priorBuilderParams(cfg), params.prior),
        admission_(calib.cam0.width, calib.cam0.height),
        wait_(wait) {
    node_.subscribe<ips::stereo_pair_t>(ips::channels::kStereo, [this](const ips::stereo_pair_t& m) { onStereo(m); });
    if (wait_.enabled)
      node_.subscribe<ips::disparity_map_t>(ips::channels::kDisparity,
                                            [this](const ips::disparity_map_t& m) { onDisparity(m); });
    node_.subscribe<ips::filter_state_t>(ips::channels::kFilterPrior,
                                         [this](const ips::filter_state_t& m) { onPrior(m); });
    node_.subscribe<ips::imu_sample_t>(ips::channels::kImu, [this](const ips::imu_sample_t& m) { onImu(m); });
  }

  // End of input: whatever still waits for a prior is tracked with the fallback.
  void flush() {
    while (!pending_.empty()) processOldest();
  }

 private:
  void onStereo(const ips::stereo_pair_t& m) {
    if (!admission_.admit(m, node_.health(), node_.arrivalUs())) return;
    node_.health().accepted();
    Pending p{m.utime, m.seq, ips::fw::mono8Copy(ips::fw::leftImage(m)), ips::fw::mono8Copy(ips::fw::rightImage(m))};
    pending_.emplace(m.utime, std::move(p));
    node_.health().queueLength(static_cast<int>(pending_.size()));
    drain();
  }

  void onPrior(const ips::filter_state_t& m) {
    ips::fw::Verdict v = ips::fw::validate(m);
    if (!v.ok() || m.cov_dim < 21)
      return node_.health().bad(v.ok() ? "bad_size" : v.reason, "filter prior: " + v.detail);
    priors_.addFilterState(fromMessage(m));
    drain();
  }

  void onDisparity(const ips::disparity_map_t& m) {
    const ips::fw::Verdict v = ips::fw::validate(m);
    if (!v.ok()) return node_.health().bad(v.reason, "disparity: " + v.detail);
    const auto scale = ips::tracker::guideScale(tracker_.rectification(), m.focal_px, m.cx, m.cy, m.baseline_m,
                                                cv::Size(m.width, m.height));
    if (!scale)
      return node_.health().bad("disparity_geometry", "a DISPARITY map of another rectification (f " +
                                                          std::to_string(m.focal_px) + ", cx " + std::to_string(m.cx) +
                                                          "): E3D must run on the tracker's calibration, alpha 0");
    // Stamps checked against the stream's rhythm: a forged stamp far ahead would end every pair's wait.
    if (!ips::fw::admitInOrder(disparity_order_, m.utime, 0, node_.health(), "disparity", node_.arrivalUs())) return;
    // Maps of pairs already tracked, or far ahead of what the tracker holds, are of no use.
    if (m.utime <= last_utime_ || maps_.size() >= static_cast<size_t>(wait_.max_pending)) {
      node_.health().count("disparity_unused");
      return;
    }
    StoredMap stored;
    stored.seq = m.seq;
    stored.guide.scale = *scale;
    stored.guide.subpixel_scale = m.subpixel_scale;
    stored.guide.invalid_value = m.invalid_value;
    stored.guide.disparity.create(m.height, m.width, CV_16SC1);
    for (int r = 0; r < m.height; ++r)
      std::copy(m.data[r].begin(), m.data[r].end(), stored.guide.disparity.ptr<int16_t>(r));
    newest_map_utime_ = std::max(newest_map_utime_, m.utime);
    maps_[m.utime] = std::move(stored);
    drain();
  }

  // Whether the oldest pending pair waits for a map that may still come.
  bool waitsForMap(const Pending& p) const {
    if (!wait_.enabled || p.seq % wait_.every_nth != 0) return false;
    return maps_.count(p.utime) == 0 && newest_map_utime_ < p.utime;  // a later map: E3D skipped this pair
  }

  void onImu(const ips::imu_sample_t& m) {
    if (!ips::fw::validate(m).ok()) return;  // the filter counts bad IMU input; here it only places windows
    priors_.addGyro(m.utime, Eigen::Vector3d(m.angular_rate[0], m.angular_rate[1], m.angular_rate[2]));
    if (!pending_.empty()) drain();
  }

  void drain() {
    while (!pending_.empty()) {
      const int64_t t = pending_.begin()->first;
      // With a filter on the bus, wait for its prior of this image time; else, with an IMU, for gyro samples up
      // to the image time (a pair can arrive before the IMU samples of its exposure: images take longer to
      // transfer). Which prior a pair gets then depends on stamps, not on arrival, and a replay repeats the live
      // run. Never hold more than one pair back.
      const bool prior_ready =
          priors_.filterSeen() ? priors_.hasFilterState(t) : !priors_.gyroSeen() || priors_.gyroCovers(t);
      const bool map_wait = waitsForMap(pending_.begin()->second);
      const size_t hold = !map_wait ? 1 : wait_.queue ? wait_.max_pending : 1 + wait_.wait_pairs;
      if ((prior_ready && !map_wait) || pending_.size() > hold)
        processOldest();
      else
        break;
    }
    node_.health().queueLength(static_cast<int>(pending_.size()));
  }

  void processOldest() {
    Pending p = std::move(pending_.begin()->second);
    pending_.erase(pending_.begin());
    std::optional<ips::tracker::MotionPrior> prior;
    if (last_utime_ > 0) {
      if ((prior = priors_.fromFilter(last_utime_, p.utime))) {
        node_.health().count("prior_filter");
      } else if ((prior = priors_.fromGyro(last_utime_, p.utime))) {
        node_.health().count("prior_imu");
        if (priors_.filterSeen()) node_.health().count("filter_prior_missing");
      } else {
        node_.health().count("prior_constant_velocity");
      }
    }
    // E3D's map of this pair, if it came (same seq and stamp); older maps are of no further use.
    const ips::tracker::DisparityGuide* guide = nullptr;
    auto map = maps_.find(p.utime);
    if (map != maps_.end() && map->second.seq == p.seq) {
      guide = &map->second.guide;
      node_.health().count("intra_from_disparity");
    } else if (wait_.enabled && p.seq % wait_.every_nth == 0) {
      node_.health().count("intra_without_disparity");
    }
    ips::tracker::TrackResult r;
    try {
      r = tracker_.process(p.utime, p.left, p.right, prior ? &*prior : nullptr, guide);
    } catch (const std::exception& e) {
      node_.health().bad("tracker_error", e.what());
      return;
    }
    maps_.erase(maps_.begin(), maps_.upper_bound(p.utime));
    node_.health().latency(r.times.total);
    if (monitor_.params().enabled) checkIntegrity(p);
    last_utime_ = p.utime;
    if (r.intra_guided) {
      node_.health().count("intra_matches_from_disparity", r.guided_intra.from_map);
      node_.health().count("intra_disparity_check_failed", r.guided_intra.check_failed);
    }
    if (r.utime_prev == 0) return;  // the first pair only becomes the reference
    ips::tracker_delta_t d{};
    d.utime = r.utime;
    d.utime_prev = r.utime_prev;
    d.seq = p.seq;
    d.valid = r.valid;
    for (int i = 0; i < 3; ++i) d.translation[i] = r.translation[i];
    ips::fw::quaternionToArray(r.rotation, d.rotation);
    ips::fw::matrixToArray<6>(r.covariance, d.covariance);
    d.num_features = r.num_features;
    d.num_intra_matches = r.num_intra_matches;
    d.num_inter_matches = r.num_inter_matches;
    d.num_inliers = r.num_inliers;
    d.residual_rms = r.residual_rms;
    d.prior_source = static_cast<int8_t>(r.prior_source);
    d.prior_ok = r.prior_ok;
    d.far_valid = r.far_valid;
    ips::fw::quaternionToArray(r.far_rotation, d.far_rotation);
    ips::fw::matrixToArray<3>(r.far_covariance, d.far_rotation_covariance);
    d.num_far_matches = r.num_far_matches;
    d.num_far_inliers = r.num_far_inliers;
    if (r.far_valid) node_.health().count("far_rotation");
    if (!r.valid) node_.health().count("invalid_delta");
    const auto& st = tracker_.predictionStats();
    node_.health().set("prediction_ok_permille",
                       st.frames_with_prior ? 1000 * st.frames_prior_ok / st.frames_with_prior : 0);
    node_.publish(ips::channels::kTrackerDelta, d);
  }

  void checkIntegrity(const Pending& p) {
    const ips::tracker::IntegrityStatus& s = ips::tracker::monitorPair(monitor_, tracker_, p.utime);
    ips::fw::Health& h = node_.health();
    h.set("integrity_state", static_cast<int64_t>(s.state));
    h.set("integrity_alarms", s.alarms);
    h.set("integrity_steps", s.steps);
    h.set("integrity_corrections", s.corrections);
    h.set("integrity_offset_mpx", std::llround(1000 * s.estimate_offset_px));
    if (!s.pair_valid) h.count("integrity_without_measurement");
    if (s.applied_now)
      IPS_WARN("epipolar integrity: the right camera has turned; pairs after "
               << s.utime << " are rectified with the new correction (corrections so far: " << s.corrections << ")");
    node_.publish(ips::channels::kIntegrity, integrityMessage(s, p.seq));
  }

  ips::fw::Node& node_;
  ips::tracker::StereoTracker tracker_;
  ips::tracker::EpipolarMonitor monitor_;
  ips::tracker::PriorBuilder priors_;
  ips::fw::StereoAdmission admission_;
  std::map<int64_t, Pending> pending_;
  int64_t last_utime_ = 0;
  DisparityWait wait_;
  std::map<int64_t, StoredMap> maps_;  // by the pair's stamp
  int64_t newest_map_utime_ = INT64_MIN;
  ips::fw::StreamOrder disparity_order_;
};

}  // namespace

int main(int argc, char** argv) {
  return ips::fw::guardedMain("tracker", [&]() {
    ips::Args args(argc, argv, "IPS stereo tracker: STEREO pairs in, TRACKER_DELTA (relative motion) out");
    args.required("--calib", "FILE", "calibration of the stereo head (project format)")
        .flag("--queue-disparity",
              "with process/intra_from_disparity: a pair waits for its DISPARITY map however late (replay)");
    ips::fw::addCommonOptions(args, "config/tracker.yaml");
    if (!args.parse()) return 0;
    ips::fw::applyCommonOptions(args);
    const ips::StereoCalibration calib = ips::loadCalibration(args.get("--calib"));
    const ips::Config cfg(args.get("--config"));
    const ips::tracker::TrackerParams params = ips::tracker::loadTrackerParams(cfg);
    ips::fw::Node node("tracker", args.get("--lcm-url"));
    TrackerProcess process(node, calib, params, cfg, disparityWait(cfg, args.getFlag("--queue-disparity")));
    IPS_INFO("tracking " << calib.cam0.width << "x" << calib.cam0.height << " pairs");
    const int rc = node.run();
    process.flush();
    return rc;
  });
}
