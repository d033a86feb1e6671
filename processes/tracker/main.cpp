// tracker: the IPS stereo tracker as a process. STEREO pairs in, TRACKER_DELTA out.
// The search windows of the inter-matching are placed by the best motion prior on the bus: the filter's
// a-priori state at the new image time (FILTER_PRIOR) when a filter runs, else the gyro (IMU), else constant
// velocity. When a filter has been seen, a pair waits for its prior (the filter publishes one for every image
// time), so that a replayed log gives the same deltas as the live run.
#include <deque>
#include <ips/filter_state_t.hpp>
#include <ips/imu_sample_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <ips/tracker_delta_t.hpp>
#include <map>
#include <opencv2/imgproc.hpp>

#include "ips/calibration.hpp"
#include "ips/config.hpp"
#include "ips/framework/channels.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/process.hpp"
#include "ips/framework/validate.hpp"
#include "ips/tracker/params.hpp"
#include "ips/tracker/stereo_tracker.hpp"

namespace {

using ips::tracker::Matrix6d;
using ips::tracker::MotionPrior;

// Filter state indices (filter_state_t covariance order).
constexpr int kVelocityIndex = 3;
constexpr int kAngularRateIndex = 12;

struct Pending {
  int64_t utime = 0;
  int64_t seq = 0;
  cv::Mat left, right;  // 8-bit copies (the message buffer is gone after the handler)
};

Eigen::Isometry3d bodyPose(const ips::filter_state_t& s) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Quaterniond(s.orientation[0], s.orientation[1], s.orientation[2], s.orientation[3])
                   .normalized()
                   .toRotationMatrix();
  T.translation() = Eigen::Vector3d(s.position[0], s.position[1], s.position[2]);
  return T;
}

Eigen::Matrix3d block3(const ips::filter_state_t& s, int i) {
  Eigen::Matrix3d m;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m(r, c) = s.covariance[i + r][i + c];
  return m;
}

class TrackerProcess {
 public:
  TrackerProcess(ips::fw::Node& node, const ips::StereoCalibration& calib, const ips::tracker::TrackerParams& params,
                 const ips::Config& cfg)
      : node_(node),
        calib_(calib),
        tracker_(calib, params),
        prior_params_(params.prior),
        gyro_sigma_(cfg.getDouble("process/gyro_rate_sigma", 0.005)),
        prior_floor_rad_(cfg.getDouble("process/filter_prior_rotation_floor", 0.002)),
        prior_floor_m_(cfg.getDouble("process/filter_prior_translation_floor", 0.01)),
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
    if (!admission_.admit(m, node_.health())) return;
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
    filter_seen_ = true;
    priors_[m.utime] = m;
    while (priors_.size() > 64) priors_.erase(priors_.begin());
    drain();
  }

  void onImu(const ips::imu_sample_t& m) {
    if (!ips::fw::validate(m).ok()) return;  // the filter counts bad IMU input; here it only places windows
    if (!imu_.empty() && m.utime <= imu_.back().utime) return;
    imu_.push_back(m);
    while (imu_.size() > 2 && imu_.back().utime - imu_.front().utime > 5'000'000) imu_.pop_front();
  }

  void drain() {
    while (!pending_.empty()) {
      const int64_t t = pending_.begin()->first;
      // Without a filter on the bus, nothing to wait for; with one, wait for its prior of this image time,
      // but never hold more than one pair back.
      if (!filter_seen_ || priors_.count(t) || pending_.size() > 1)
        processOldest();
      else
        break;
    }
    node_.health().queueLength(static_cast<int>(pending_.size()));
  }

  bool filterPrior(int64_t t0, int64_t t1, MotionPrior* out) {
    auto a = priors_.find(t0), b = priors_.find(t1);
    if (a == priors_.end() || b == priors_.end()) return false;
    const Eigen::Isometry3d T_w_c0 = bodyPose(a->second) * calib_.T_imu_cam0;
    const Eigen::Isometry3d T_w_c1 = bodyPose(b->second) * calib_.T_imu_cam0;
    const Eigen::Isometry3d T_c0_c1 = T_w_c0.inverse() * T_w_c1;
    const double dt = (t1 - t0) * 1e-6;
    // The relative motion's uncertainty grows with the velocity and rate uncertainty over the interval.
    const Eigen::Matrix3d R_c_w = T_w_c0.linear().transpose();
    const Eigen::Matrix3d R_c_b = calib_.T_imu_cam0.linear().transpose();
    Matrix6d cov = Matrix6d::Zero();
    cov.topLeftCorner<3, 3>() = R_c_w * block3(b->second, kVelocityIndex) * R_c_w.transpose() * dt * dt +
                                Eigen::Matrix3d::Identity() * prior_floor_m_ * prior_floor_m_;
    cov.bottomRightCorner<3, 3>() = R_c_b * block3(b->second, kAngularRateIndex) * R_c_b.transpose() * dt * dt +
                                    Eigen::Matrix3d::Identity() * prior_floor_rad_ * prior_floor_rad_;
    *out = MotionPrior::fromFilter(T_c0_c1.linear(), T_c0_c1.translation(), cov);
    return true;
  }

  bool imuPrior(int64_t t0, int64_t t1, MotionPrior* out) {
    if (imu_.empty() || imu_.front().utime > t0 || imu_.back().utime < t1) return false;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    int n = 0;
    for (const auto& s : imu_) {
      if (s.utime < t0 || s.utime > t1) continue;
      sum += Eigen::Vector3d(s.angular_rate[0], s.angular_rate[1], s.angular_rate[2]);
      ++n;
    }
    if (n == 0) return false;
    Eigen::Vector3d bias = Eigen::Vector3d::Zero();
    if (!priors_.empty()) {
      const auto& s = priors_.rbegin()->second;
      bias = Eigen::Vector3d(s.gyro_bias[0], s.gyro_bias[1], s.gyro_bias[2]);
    }
    *out = MotionPrior::fromImuRates(sum / n - bias, calib_.T_imu_cam0.linear(), (t1 - t0) * 1e-6, gyro_sigma_,
                                     prior_params_);
    return true;
  }

  void processOldest() {
    Pending p = std::move(pending_.begin()->second);
    pending_.erase(pending_.begin());
    MotionPrior prior;
    const MotionPrior* use = nullptr;
    if (last_utime_ > 0) {
      if (filterPrior(last_utime_, p.utime, &prior)) {
        use = &prior;
        node_.health().count("prior_filter");
      } else if (imuPrior(last_utime_, p.utime, &prior)) {
        use = &prior;
        node_.health().count("prior_imu");
        if (filter_seen_) node_.health().count("filter_prior_missing");
      } else {
        node_.health().count("prior_constant_velocity");
      }
    }
    ips::tracker::TrackResult r;
    try {
      r = tracker_.process(p.utime, p.left, p.right, use);
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
  ips::StereoCalibration calib_;
  ips::tracker::StereoTracker tracker_;
  ips::tracker::PriorParams prior_params_;
  double gyro_sigma_, prior_floor_rad_, prior_floor_m_;
  ips::fw::StereoAdmission admission_;
  std::map<int64_t, Pending> pending_;
  std::map<int64_t, ips::filter_state_t> priors_;
  std::deque<ips::imu_sample_t> imu_;
  bool filter_seen_ = false;
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
