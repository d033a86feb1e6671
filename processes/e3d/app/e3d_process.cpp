#include "e3d_process.hpp"

#include <chrono>
#include <ips/disparity_map_t.hpp>
#include <ips/keyframe_t.hpp>

#include "ips/framework/channels.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/message_arrays.hpp"
#include "ips/framework/message_poses.hpp"
#include "ips/log.hpp"

namespace ips::e3d_app {

namespace {

// How long a queued pair waits, at most, for the tracker's INTEGRITY of the pair before it (a tracker that stopped
// must not stop E3D); far beyond the tracker's time per pair.
constexpr auto kIntegrityWaitLimit = std::chrono::seconds(10);

disparity_map_t toMessage(const e3d::StereoJob& job, const cv::Mat& disparity, const e3d::SgmParams& params,
                          const StereoRectification& rect) {
  disparity_map_t m{};
  m.utime = job.utime;
  m.seq = job.seq;
  m.width = disparity.cols;
  m.height = disparity.rows;
  m.subpixel_scale = e3d::kSubpixelScale;
  m.min_disparity = static_cast<int16_t>(params.min_disparity);
  m.num_disparities = static_cast<int16_t>(params.num_disparities);
  m.invalid_value = e3d::kInvalidDisparity;
  m.focal_px = rect.f;
  m.cx = rect.cx;
  m.cy = rect.cy;
  m.baseline_m = rect.baseline;
  m.data.resize(disparity.rows);
  for (int r = 0; r < disparity.rows; ++r) {
    const int16_t* row = disparity.ptr<int16_t>(r);
    m.data[r].assign(row, row + disparity.cols);
  }
  m.confidence_size = 0;
  return m;
}

}  // namespace

E3dProcess::E3dProcess(fw::Node& node, const StereoCalibration& calib, e3d::StereoMatcher& matcher,
                       const StereoRectification& rect, const e3d::ProcessParams& params, e3d::MonoDepth* mono)
    : node_(node),
      matcher_(matcher),
      calib_(calib),
      scale_(params.output_scale),
      rect_(rect),
      admission_(calib.cam0.width, calib.cam0.height),
      mono_(mono),
      jobs_(params.every_nth, params.queue_all, params.max_queue) {
  if (mono_) pairing_.emplace(mono_->params().gap_pairs, mono_->params().every_nth);
  node_.subscribe<stereo_pair_t>(channels::kStereo, [this](const stereo_pair_t& m) { onStereo(m); });
  if (params.apply_integrity)
    node_.subscribe<integrity_t>(channels::kIntegrity, [this](const integrity_t& m) { onIntegrity(m); });
  if (mono_)
    node_.subscribe<filter_state_t>(channels::kFilterState, [this](const filter_state_t& m) { onFilterState(m); });
  worker_ = std::thread([this] { work(); });
}

void E3dProcess::stop(bool drain) {
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

void E3dProcess::onStereo(const stereo_pair_t& m) {
  if (!admission_.admit(m, node_.health(), node_.arrivalUs())) return;
  const int64_t prev_utime = last_stereo_utime_;
  last_stereo_utime_ = m.utime;
  const bool for_stereo = jobs_.selects(m.seq);
  const bool for_mono = pairing_ && pairing_->wants(m.seq);
  if (!for_stereo && !for_mono) return;  // not selected: neither work nor loss
  cv::Mat left = fw::mono8Copy(fw::leftImage(m));
  if (for_mono) queueMono(pairing_->addPair(m.seq, m.utime, left));
  if (!for_stereo) return;
  node_.health().accepted();
  e3d::StereoJob job{m.utime, m.seq, prev_utime, std::move(left), fw::mono8Copy(fw::rightImage(m))};
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const e3d::StereoJobQueue::Dropped dropped = jobs_.push(std::move(job));
    if (dropped.superseded) node_.health().dropped("superseded", dropped.superseded);
    if (dropped.queue_full) node_.health().dropped("queue_full");
    node_.health().queueLength(static_cast<int>(jobs_.size()));
  }
  cv_.notify_one();
  // At once, while the filter still holds the pose clone of this pair: it keeps the clone for the alignment of
  // this pair's map with the next (CLOUD_DELTA), which comes seconds later.
  keyframe_t keyframe{};
  keyframe.utime = m.utime;
  keyframe.seq = m.seq;
  node_.publish(channels::kKeyframe, keyframe);
}

void E3dProcess::onFilterState(const filter_state_t& m) {
  const fw::Verdict v = fw::validate(m);
  if (!v.ok()) return node_.health().bad(v.reason, "filter state: " + v.detail);
  queueMono(pairing_->addPose(fw::stampedPose(m.utime, fw::bodyPose(m))));
}

void E3dProcess::queueMono(e3d::MonoPairing::Released released) {
  if (released.dropped) node_.health().dropped("mono_no_filter_state", released.dropped);
  if (released.without_pose) node_.health().dropped("mono_no_pose", released.without_pose);
  if (released.ready.empty()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (e3d::MonoJob& job : released.ready) {
      if (mono_ready_.size() >= e3d::MonoPairing::kMaxPending) {
        mono_ready_.pop_front();
        node_.health().dropped("mono_queue_full");
      }
      mono_ready_.push_back(std::move(job));
    }
  }
  cv_.notify_one();
}

void E3dProcess::onIntegrity(const integrity_t& m) {
  const fw::Verdict v = fw::validate(m);
  if (!v.ok()) return node_.health().bad(v.reason, "integrity: " + v.detail);
  RightCameraCorrection c;
  c.rotation = fw::vectorFromArray(m.applied);
  c.focal_scale = m.applied[3];
  c.disparity_offset_px = m.disparity_offset_px;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    jobs_.integritySeen(m.utime);
    // Every INTEGRITY message repeats the correction and the disparity offset in use: only a change is news, in use
    // after the newer of the two pairs that decided them (an older message arriving late is refused by the schedule).
    if (c != corrections_told_ && corrections_.add(std::max(m.applied_utime, m.disparity_offset_utime), c))
      corrections_told_ = c;
  }
  cv_.notify_all();
}

void E3dProcess::rectifyFor(int64_t utime) {
  RightCameraCorrection c;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    c = corrections_.forPair(utime);
    corrections_.dropBefore(utime);
  }
  if (c == in_use_) return;
  rect_ = scaledRectification(calib_, scale_, c);
  matcher_.setRectification(rect_, cv::Size(calib_.cam0.width, calib_.cam0.height));
  in_use_ = c;
  node_.health().count("integrity_corrections_applied");
  IPS_INFO("rectifying with the right camera's correction (rotation "
           << c.rotation.norm() * 180 / M_PI << " deg, disparity offset " << c.disparity_offset_px << " px) from pair "
           << utime << " on");
}

void E3dProcess::work() {
  for (;;) {
    e3d::StereoJob job;
    std::optional<e3d::MonoJob> mono_job;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      cv_.wait(lock, [this] { return stopping_ || !jobs_.empty() || !mono_ready_.empty(); });
      if (!mono_ready_.empty()) {
        mono_job = std::move(mono_ready_.front());
        mono_ready_.pop_front();
      } else {
        if (jobs_.empty()) return;  // stopping, and nothing left
        if (!cv_.wait_for(lock, kIntegrityWaitLimit, [this] { return stopping_ || jobs_.frontReady(); }))
          node_.health().count("integrity_wait_timeout");
        if (jobs_.empty()) return;  // stopped without draining while it waited
        job = jobs_.pop();
        node_.health().queueLength(static_cast<int>(jobs_.size()));
      }
    }
    if (mono_job) {
      runMono(*mono_job);
      continue;
    }
    try {
      rectifyFor(job.utime);
      e3d::MatchOutput out = matcher_.matchRaw(job.left, job.right);
      node_.health().latency(out.total_ms);
      publish(job, out.disparity);
    } catch (const std::exception& e) {
      node_.health().bad("match_error", e.what());
    }
  }
}

void E3dProcess::runMono(const e3d::MonoJob& job) {
  try {
    const Eigen::Isometry3d W_a = job.pose_a.T_world_body * calib_.T_imu_cam0;
    const Eigen::Isometry3d W_b = job.pose_b.T_world_body * calib_.T_imu_cam0;
    const e3d::MonoDepthResult r = mono_->compute(job.left_a, job.left_b, W_a.inverse() * W_b);
    if (!r.matched) return node_.health().count("mono_short_baseline");
    node_.health().count("mono_maps");
    std::vector<Eigen::Vector3d> world(r.points.size());
    for (size_t i = 0; i < r.points.size(); ++i) world[i] = W_a * r.points[i].cast<double>();
    node_.publish(channels::kMonoPoints,
                  fw::pointCloudMessage(job.utime_b, job.seq_b, "world", job.pose_a, world, r.intensity));
  } catch (const std::exception& e) {
    node_.health().bad("mono_error", e.what());
  }
}

void E3dProcess::publish(const e3d::StereoJob& job, const cv::Mat& disparity) {
  node_.publish(channels::kDisparity, toMessage(job, disparity, matcher_.params(), rect_));
}

}  // namespace ips::e3d_app
