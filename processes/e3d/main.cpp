// e3d: dense stereo as a process. Raw STEREO pairs in; rectification and Semi-Global Matching on the Vulkan
// device; DISPARITY out. Matching runs in a worker thread: live, it always takes the newest pair and counts
// the ones it skipped; for replay, --every-nth N picks pairs by sequence number and --queue keeps all of
// them, so that a log replayed twice gives the same maps. With process/apply_integrity, the right camera's correction
// from the tracker's epipolar integrity monitor (INTEGRITY) rectifies the pairs after the one that decided it.
// With mono/enabled, depth from one camera: the left images of a pair and of the pair mono/gap_pairs before it,
// polar-rectified for the filter's relative pose (FILTER_STATE) and matched, go out as points on MONO_POINTS.
#include <chrono>
#include <condition_variable>
#include <deque>
#include <ips/disparity_map_t.hpp>
#include <ips/filter_state_t.hpp>
#include <ips/integrity_t.hpp>
#include <ips/keyframe_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "ips/calibration.hpp"
#include "ips/config.hpp"
#include "ips/e3d/mono_depth.hpp"
#include "ips/e3d/mono_pairing.hpp"
#include "ips/e3d/stereo_matcher.hpp"
#include "ips/e3d/vulkan_context.hpp"
#include "ips/framework/channels.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/message_poses.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/process.hpp"
#include "ips/framework/validate.hpp"

namespace {

// A full-size pair is about 2.8 MB: 256 queued pairs is already 700 MB, more than a deployment wants held.
constexpr long long kMaxQueueLimit = 256;

// How long a queued pair waits, at most, for the tracker's INTEGRITY of the pair before it (a tracker that stopped
// must not stop E3D); far beyond the tracker's time per pair.
constexpr auto kIntegrityWaitLimit = std::chrono::seconds(10);

struct Job {
  int64_t utime = 0;
  int64_t seq = 0;
  int64_t prev_utime = 0;  // the stamp of the STEREO pair before this one (selected or not)
  cv::Mat left, right;     // raw 8-bit copies
};

class E3dProcess {
 public:
  E3dProcess(ips::fw::Node& node, const ips::StereoCalibration& calib, ips::e3d::StereoMatcher& matcher,
             const ips::StereoRectification& rect, double scale, int every_nth, bool queue_all, size_t max_queue,
             bool apply_integrity, ips::e3d::MonoDepth* mono)
      : node_(node),
        matcher_(matcher),
        calib_(calib),
        scale_(scale),
        rect_(rect),
        every_nth_(every_nth),
        queue_all_(queue_all),
        max_queue_(max_queue),
        admission_(calib.cam0.width, calib.cam0.height),
        mono_(mono) {
    if (mono_) pairing_.emplace(mono_->params().gap_pairs, mono_->params().every_nth);
    node_.subscribe<ips::stereo_pair_t>(ips::channels::kStereo, [this](const ips::stereo_pair_t& m) { onStereo(m); });
    if (apply_integrity)
      node_.subscribe<ips::integrity_t>(ips::channels::kIntegrity,
                                        [this](const ips::integrity_t& m) { onIntegrity(m); });
    if (mono_)
      node_.subscribe<ips::filter_state_t>(ips::channels::kFilterState,
                                           [this](const ips::filter_state_t& m) { onFilterState(m); });
    worker_ = std::thread([this] { work(); });
  }

  ~E3dProcess() { stop(true); }

  // Stops the worker; with drain, the queued pairs are matched first. Call after the node's loop has returned: maps
  // still waiting for the filter's pose then never get it.
  void stop(bool drain) {
    if (pairing_ && pairing_->pending())
      node_.health().dropped("mono_no_filter_state", static_cast<int64_t>(pairing_->pending()));
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!drain) {
        jobs_.clear();
        mono_ready_.clear();
      }
      stopping_ = true;
    }
    cv_.notify_all();
    if (worker_.joinable()) worker_.join();
  }

 private:
  void onStereo(const ips::stereo_pair_t& m) {
    if (!admission_.admit(m, node_.health(), node_.arrivalUs())) return;
    const int64_t prev_utime = last_stereo_utime_;
    last_stereo_utime_ = m.utime;
    const bool for_stereo = every_nth_ <= 1 || m.seq % every_nth_ == 0;
    const bool for_mono = pairing_ && pairing_->wants(m.seq);
    if (!for_stereo && !for_mono) return;  // not selected: neither work nor loss
    cv::Mat left = ips::fw::mono8Copy(ips::fw::leftImage(m));
    if (for_mono) {
      const int64_t dropped = pairing_->addPair(m.seq, m.utime, left);
      if (dropped) node_.health().dropped("mono_no_filter_state", dropped);
    }
    if (!for_stereo) return;
    node_.health().accepted();
    Job job{m.utime, m.seq, prev_utime, std::move(left), ips::fw::mono8Copy(ips::fw::rightImage(m))};
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!queue_all_) {
        if (!jobs_.empty()) node_.health().dropped("superseded", static_cast<int64_t>(jobs_.size()));
        jobs_.clear();
      } else if (jobs_.size() >= max_queue_) {
        jobs_.pop_front();
        node_.health().dropped("queue_full");
      }
      jobs_.push_back(std::move(job));
      node_.health().queueLength(static_cast<int>(jobs_.size()));
    }
    cv_.notify_one();
    // At once, while the filter still holds the pose clone of this pair: it keeps the clone for the alignment of
    // this pair's map with the next (CLOUD_DELTA), which comes seconds later.
    ips::keyframe_t keyframe{};
    keyframe.utime = m.utime;
    keyframe.seq = m.seq;
    node_.publish(ips::channels::kKeyframe, keyframe);
  }

  // LCM thread: the maps whose later exposure the filter has passed go to the worker with both poses.
  void onFilterState(const ips::filter_state_t& m) {
    const ips::fw::Verdict v = ips::fw::validate(m);
    if (!v.ok()) return node_.health().bad(v.reason, "filter state: " + v.detail);
    ips::e3d::MonoPairing::Released released = pairing_->addPose(ips::fw::stampedPose(m.utime, ips::fw::bodyPose(m)));
    if (released.without_pose) node_.health().dropped("mono_no_pose", released.without_pose);
    if (released.ready.empty()) return;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      for (ips::e3d::MonoJob& job : released.ready) {
        if (mono_ready_.size() >= ips::e3d::MonoPairing::kMaxPending) {
          mono_ready_.pop_front();
          node_.health().dropped("mono_queue_full");
        }
        mono_ready_.push_back(std::move(job));
      }
    }
    cv_.notify_one();
  }

  void onIntegrity(const ips::integrity_t& m) {
    const ips::fw::Verdict v = ips::fw::validate(m);
    if (!v.ok()) return node_.health().bad(v.reason, "integrity: " + v.detail);
    ips::RightCameraCorrection c;
    c.rotation = Eigen::Vector3d(m.applied[0], m.applied[1], m.applied[2]);
    c.focal_scale = m.applied[3];
    {
      std::lock_guard<std::mutex> lock(mutex_);
      integrity_seen_utime_ = std::max(integrity_seen_utime_, m.utime);
      // Every INTEGRITY message repeats the correction in use: only a newly decided one is news.
      if (m.applied_utime > corrections_newest_) {
        corrections_newest_ = m.applied_utime;
        corrections_.add(m.applied_utime, c);
      }
    }
    cv_.notify_all();
  }

  // With every pair kept (replay), a pair waits for the tracker's INTEGRITY of the pair before it, once a tracker
  // has sent any: which correction a pair is matched with then depends on stamps, not on which process was faster,
  // and a replay repeats the live run. Live, the newest pair goes with what has arrived.
  bool integrityReady(const Job& job) const {
    return !queue_all_ || integrity_seen_utime_ == 0 || integrity_seen_utime_ >= job.prev_utime;
  }

  // Before matching a pair: the rectification of the newest correction decided before it.
  void rectifyFor(int64_t utime) {
    ips::RightCameraCorrection c;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      c = corrections_.forPair(utime);
      corrections_.dropBefore(utime);
    }
    if (c == in_use_) return;
    rect_ = ips::scaledRectification(calib_, scale_, c);
    matcher_.setRectification(rect_, cv::Size(calib_.cam0.width, calib_.cam0.height));
    in_use_ = c;
    node_.health().count("integrity_corrections_applied");
    IPS_INFO("rectifying with the right camera's correction (rotation " << c.rotation.norm() * 180 / M_PI
                                                                        << " deg) from pair " << utime << " on");
  }

  void work() {
    for (;;) {
      Job job;
      std::optional<ips::e3d::MonoJob> mono_job;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        cv_.wait(lock, [this] { return stopping_ || !jobs_.empty() || !mono_ready_.empty(); });
        if (!mono_ready_.empty()) {
          mono_job = std::move(mono_ready_.front());
          mono_ready_.pop_front();
        } else {
          if (jobs_.empty()) return;  // stopping, and nothing left
          if (!cv_.wait_for(lock, kIntegrityWaitLimit, [this] { return stopping_ || integrityReady(jobs_.front()); }))
            node_.health().count("integrity_wait_timeout");
          if (jobs_.empty()) return;  // stopped without draining while it waited
          job = std::move(jobs_.front());
          jobs_.pop_front();
          node_.health().queueLength(static_cast<int>(jobs_.size()));
        }
      }
      if (mono_job) {
        runMono(*mono_job);
        continue;
      }
      try {
        rectifyFor(job.utime);
        ips::e3d::MatchOutput out = matcher_.matchRaw(job.left, job.right);
        node_.health().latency(out.total_ms);
        publish(job, out.disparity);
      } catch (const std::exception& e) {
        node_.health().bad("match_error", e.what());
      }
    }
  }

  // Worker: the map from one camera, its points placed in the world with the filter's pose of the earlier exposure.
  void runMono(const ips::e3d::MonoJob& job) {
    try {
      const Eigen::Isometry3d W_a = job.pose_a.T_world_body * calib_.T_imu_cam0;
      const Eigen::Isometry3d W_b = job.pose_b.T_world_body * calib_.T_imu_cam0;
      const ips::e3d::MonoDepthResult r = mono_->compute(job.left_a, job.left_b, W_a.inverse() * W_b);
      if (!r.matched) return node_.health().count("mono_short_baseline");
      node_.health().count("mono_maps");
      std::vector<Eigen::Vector3d> world(r.points.size());
      for (size_t i = 0; i < r.points.size(); ++i) world[i] = W_a * r.points[i].cast<double>();
      node_.publish(ips::channels::kMonoPoints,
                    ips::fw::pointCloudMessage(job.utime_b, job.seq_b, "world", job.pose_a, world, r.intensity));
    } catch (const std::exception& e) {
      node_.health().bad("mono_error", e.what());
    }
  }

  void publish(const Job& job, const cv::Mat& disparity) {
    ips::disparity_map_t m{};
    m.utime = job.utime;
    m.seq = job.seq;
    m.width = disparity.cols;
    m.height = disparity.rows;
    m.subpixel_scale = ips::e3d::kSubpixelScale;
    m.min_disparity = static_cast<int16_t>(matcher_.params().min_disparity);
    m.num_disparities = static_cast<int16_t>(matcher_.params().num_disparities);
    m.invalid_value = ips::e3d::kInvalidDisparity;
    m.focal_px = rect_.f;
    m.cx = rect_.cx;
    m.cy = rect_.cy;
    m.baseline_m = rect_.baseline;
    m.data.resize(disparity.rows);
    for (int r = 0; r < disparity.rows; ++r) {
      const int16_t* row = disparity.ptr<int16_t>(r);
      m.data[r].assign(row, row + disparity.cols);
    }
    m.confidence_size = 0;
    node_.publish(ips::channels::kDisparity, m);
  }

  ips::fw::Node& node_;
  ips::e3d::StereoMatcher& matcher_;
  ips::StereoCalibration calib_;
  double scale_;
  ips::StereoRectification rect_;
  ips::RightCorrectionSchedule corrections_;  // guarded by mutex_
  int64_t corrections_newest_ = 0;            // guarded by mutex_
  int64_t integrity_seen_utime_ = 0;          // guarded by mutex_: the newest INTEGRITY's pair
  int64_t last_stereo_utime_ = 0;             // LCM thread only
  ips::RightCameraCorrection in_use_;         // worker only
  int every_nth_;
  bool queue_all_;
  size_t max_queue_;
  ips::fw::StereoAdmission admission_;
  ips::e3d::MonoDepth* mono_;                     // null: no depth from one camera
  std::optional<ips::e3d::MonoPairing> pairing_;  // LCM thread; with mono_
  std::deque<ips::e3d::MonoJob> mono_ready_;      // guarded by mutex_
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Job> jobs_;
  bool stopping_ = false;
  std::thread worker_;
};

}  // namespace

int main(int argc, char** argv) {
  return ips::fw::guardedMain("e3d", [&]() {
    ips::Args args(argc, argv, "E3D dense stereo: raw STEREO pairs in, DISPARITY maps (rectified left view) out");
    args.required("--calib", "FILE", "calibration of the stereo head (project format)")
        .option("--device", "INDEX|NAME", "Vulkan device (default: $IPS_VK_DEVICE, else the best GPU, else lavapipe)")
        .option("--every-nth", "N", "match only pairs whose sequence number is a multiple of N (overrides config)")
        .flag("--queue", "keep every selected pair instead of only the newest (replay; overrides config)");
    ips::fw::addCommonOptions(args, "config/e3d.yaml");
    if (!args.parse()) return 0;
    ips::fw::applyCommonOptions(args);
    const ips::StereoCalibration calib = ips::loadCalibration(args.get("--calib"));
    const ips::Config cfg(args.get("--config"));
    const ips::e3d::SgmParams params = ips::e3d::SgmParams::fromConfig(cfg.has("sgm") ? cfg.section("sgm") : cfg);
    const double scale = cfg.getDouble("process/output_scale", 1.0);
    if (!(scale > 0 && scale <= 1))
      throw ips::ConfigError(cfg.path() + ": key 'process/output_scale' must be in (0, 1]");
    const long long every_nth_value =
        args.has("--every-nth") ? args.getInt("--every-nth") : cfg.getInt("process/every_nth", 1);
    // A pair is selected when seq % N == 0: N below 1 selects nothing (or divides by zero).
    if (every_nth_value < 1 || every_nth_value > std::numeric_limits<int>::max())
      throw ips::ConfigError(cfg.path() + ": 'process/every_nth' (or --every-nth) must be at least 1, got " +
                             std::to_string(every_nth_value));
    const int every_nth = static_cast<int>(every_nth_value);
    const bool queue_all = args.getFlag("--queue") || cfg.getBool("process/queue_all", false);
    // The queue holds decoded pairs (two full images each): at least one, and bounded so memory stays flat.
    const long long max_queue_value = cfg.getInt("process/max_queue", 16);
    if (max_queue_value < 1 || max_queue_value > kMaxQueueLimit)
      throw ips::ConfigError(cfg.path() + ": key 'process/max_queue' must be in [1, " + std::to_string(kMaxQueueLimit) +
                             "], got " + std::to_string(max_queue_value));
    const auto max_queue = static_cast<size_t>(max_queue_value);

    ips::e3d::VulkanContext ctx(args.get("--device"));
    const ips::StereoRectification rect = ips::scaledRectification(calib, scale);
    ips::e3d::StereoMatcher matcher(ctx, rect.size, params);
    matcher.setRectification(rect, cv::Size(calib.cam0.width, calib.cam0.height));
    std::unique_ptr<ips::e3d::MonoDepth> mono;
    if (cfg.getBool("mono/enabled", false)) {
      mono = std::make_unique<ips::e3d::MonoDepth>(ctx, calib.cam0, params,
                                                   ips::e3d::MonoDepthParams::fromConfig(cfg.section("mono")));
      IPS_INFO("depth from one camera: pairs " << mono->params().gap_pairs << " apart, every "
                                               << mono->params().every_nth << "th pair, on "
                                               << ips::channels::kMonoPoints);
    }
    ips::fw::Node node("e3d", args.get("--lcm-url"));
    E3dProcess process(node, calib, matcher, rect, scale, every_nth, queue_all, max_queue,
                       cfg.getBool("process/apply_integrity", true), mono.get());
    IPS_INFO("matching " << rect.size.width << "x" << rect.size.height << " on " << ctx.info().name << ", "
                         << params.describe());
    const int rc = node.run();
    process.stop(true);
    node.publishHealth(1.0);
    return rc;
  });
}
