// tracker: the IPS stereo tracker as a process. STEREO pairs in, TRACKER_DELTA out.
// The search windows of the inter-matching are placed by the best motion prior on the bus: the filter's
// a-priori state at the new image time (FILTER_PRIOR) when a filter runs, else the gyro (IMU), else constant
// velocity. When a filter has been seen, a pair waits for its prior (the filter publishes one for every image
// time), else for the IMU to cover its time, so that a replayed log gives the same deltas as the live run.
#include <ips/filter_state_t.hpp>
#include <ips/imu_sample_t.hpp>
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
#include "ips/framework/node.hpp"
#include "ips/framework/process.hpp"
#include "ips/framework/validate.hpp"
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

class TrackerProcess {
 public:
  TrackerProcess(ips::fw::Node& node, const ips::StereoCalibration& calib, const ips::tracker::TrackerParams& params,
                 const ips::Config& cfg)
      : node_(node),
        tracker_(calib, params),
        priors_(calib.T_imu_cam0, priorBuilderParams(cfg), params.prior),
        admission_(calib.cam0.width, calib.cam0.height) {
    node_.subscribe<ips::stereo_pair_t>(ips::channels::kStereo, [this](const ips::stereo_pair_t& m) { onStereo(m); });
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
      if (prior_ready || pending_.size() > 1)
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
    ips::tracker::TrackResult r;
    try {
      r = tracker_.process(p.utime, p.left, p.right, prior ? &*prior : nullptr);
    } catch (const std::exception& e) {
      node_.health().bad("tracker_error", e.what());
      return;
    }
    node_.health().latency(r.times.total);
    last_utime_ = p.utime;
    if (r.utime_prev == 0) return;  // the first pair only becomes the reference
    ips::tracker_delta_t d{};
    d.utime = r.utime;
    d.utime_prev = r.utime_prev;
    d.seq = p.seq;
    d.valid = r.valid;
    for (int i = 0; i < 3; ++i) d.translation[i] = r.translation[i];
    d.rotation[0] = r.rotation.w();
    d.rotation[1] = r.rotation.x();
    d.rotation[2] = r.rotation.y();
    d.rotation[3] = r.rotation.z();
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j) d.covariance[i * 6 + j] = r.covariance(i, j);
    d.num_features = r.num_features;
    d.num_intra_matches = r.num_intra_matches;
    d.num_inter_matches = r.num_inter_matches;
    d.num_inliers = r.num_inliers;
    d.residual_rms = r.residual_rms;
    d.prior_source = static_cast<int8_t>(r.prior_source);
    d.prior_ok = r.prior_ok;
    if (!r.valid) node_.health().count("invalid_delta");
    const auto& st = tracker_.predictionStats();
    node_.health().set("prediction_ok_permille",
                       st.frames_with_prior ? 1000 * st.frames_prior_ok / st.frames_with_prior : 0);
    node_.publish(ips::channels::kTrackerDelta, d);
  }

  ips::fw::Node& node_;
  ips::tracker::StereoTracker tracker_;
  ips::tracker::PriorBuilder priors_;
  ips::fw::StereoAdmission admission_;
  std::map<int64_t, Pending> pending_;
  int64_t last_utime_ = 0;
};

}  // namespace

int main(int argc, char** argv) {
  return ips::fw::guardedMain("tracker", [&]() {
    ips::Args args(argc, argv, "IPS stereo tracker: STEREO pairs in, TRACKER_DELTA (relative motion) out");
    args.required("--calib", "FILE", "calibration of the stereo head (project format)");
    ips::fw::addCommonOptions(args, "config/tracker.yaml");
    if (!args.parse()) return 0;
    ips::fw::applyCommonOptions(args);
    const ips::StereoCalibration calib = ips::loadCalibration(args.get("--calib"));
    const ips::Config cfg(args.get("--config"));
    const ips::tracker::TrackerParams params = ips::tracker::loadTrackerParams(cfg);
    ips::fw::Node node("tracker", args.get("--lcm-url"));
    TrackerProcess process(node, calib, params, cfg);
    IPS_INFO("tracking " << calib.cam0.width << "x" << calib.cam0.height << " pairs");
    const int rc = node.run();
    process.flush();
    return rc;
  });
}
