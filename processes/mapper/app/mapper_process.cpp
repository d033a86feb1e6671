#include "mapper_process.hpp"

#include <chrono>
#include <ips/filter_state_t.hpp>
#include <ips/ground_truth_t.hpp>
#include <ips/point_cloud_t.hpp>
#include <ips/tracker_delta_t.hpp>

#include "ips/framework/channels.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/message_arrays.hpp"
#include "ips/framework/message_poses.hpp"
#include "ips/log.hpp"

namespace ips::mapper_app {

std::optional<PoseSource> poseSourceFromName(const std::string& name) {
  if (name == "filter") return PoseSource::kFilter;
  if (name == "tracker") return PoseSource::kTracker;
  if (name == "truth") return PoseSource::kTruth;
  return std::nullopt;
}

MapperProcess::MapperProcess(fw::Node& node, const StereoCalibration& calib, const mapper::MapperParams& params,
                             const std::string& points_channel, const std::string& cloud_delta_channel,
                             const mapper::CloudOdometryParams& cloud_params, PoseSource source,
                             const std::string& pose_channel)
    : node_(node),
      points_channel_(points_channel),
      cloud_delta_channel_(cloud_delta_channel),
      T_body_cam0_(calib.T_imu_cam0),
      mapper_(
          calib, params, [this](const std::string& name, int64_t n) { node_.health().dropped(name, n); },
          [this](const std::string& name, int64_t n) { node_.health().count(name, n); }),
      stereo_admission_(calib.cam0.width, calib.cam0.height) {
  if (!cloud_delta_channel_.empty()) {
    odometry_.emplace(cloud_params);
    mapper_.keepAlignmentPoints();
  }
  if (source == PoseSource::kTracker) tracker_poses_.emplace(calib.T_imu_cam0);
  node_.subscribe<ips::stereo_pair_t>(ips::channels::kStereo, [this](const ips::stereo_pair_t& m) { onStereo(m); });
  node_.subscribe<ips::disparity_map_t>(ips::channels::kDisparity,
                                        [this](const ips::disparity_map_t& m) { onDisparity(m); });
  subscribePoses(source, pose_channel);
}

void MapperProcess::onStereo(const ips::stereo_pair_t& m) {
  // The pairs only give the points their grey values; still, a forged one must not stay among them.
  if (!stereo_admission_.admit(m, node_.health(), node_.arrivalUs())) return;
  mapper_.addLeftImage(m.seq, ips::fw::mono8Copy(ips::fw::leftImage(m)));
}

void MapperProcess::onDisparity(const ips::disparity_map_t& m) {
  node_.health().received(m.utime);
  const ips::fw::Verdict v = ips::fw::validate(m);
  if (!v.ok()) return node_.health().bad(v.reason, v.detail);
  // Its seq is the pair's: E3D matches every n-th pair, so a jump in it is no loss (not counted as a gap).
  if (!ips::fw::admitInOrder(disparity_order_, m.utime, 0, node_.health(), "disparity", node_.arrivalUs())) return;
  node_.health().accepted();
  ips::mapper::DisparityInput in;
  in.utime = m.utime;
  in.seq = m.seq;
  in.disparity = ips::fw::disparityImage(m);
  in.focal_px = m.focal_px, in.cx = m.cx, in.cy = m.cy, in.baseline_m = m.baseline_m;
  if (!logged_range_) {
    IPS_LOG(ips::LogLevel::Info, "points kept up to " << mapper_.rangeFor(in) << " m (f " << m.focal_px << " px, b "
                                                      << m.baseline_m << " m)");
    logged_range_ = true;
  }
  timed([&] { return mapper_.addDisparity(in); });
}

void MapperProcess::onPose(const ips::Pose& p) {
  // A stamp off the pose stream's time line (forged, an hour ahead) would hold every map back: refused here.
  if (!ips::fw::admitInOrder(pose_order_, p.utime, 0, node_.health(), "pose", node_.arrivalUs())) return;
  timed([&] { return mapper_.addPose(p); });
}

void MapperProcess::subscribePoses(PoseSource source, const std::string& channel) {
  if (source == PoseSource::kFilter) {
    node_.subscribe<ips::filter_state_t>(channel.empty() ? ips::channels::kFilterState : channel,
                                         [this](const ips::filter_state_t& s) {
                                           const ips::fw::Verdict v = ips::fw::validate(s);
                                           if (!v.ok()) return node_.health().bad(v.reason, v.detail);
                                           onPose(ips::fw::stampedPose(s.utime, ips::fw::bodyPose(s)));
                                         });
  } else if (source == PoseSource::kTracker) {
    node_.subscribe<ips::tracker_delta_t>(
        channel.empty() ? ips::channels::kTrackerDelta : channel, [this](const ips::tracker_delta_t& d) {
          const ips::fw::Verdict v = ips::fw::validate(d);
          if (!v.ok()) return node_.health().bad(v.reason, v.detail);
          bool motion_unknown = false;
          onPose(tracker_poses_->add(d.utime, d.utime_prev, d.valid, ips::fw::quaternionFromArray(d.rotation),
                                     ips::fw::vectorFromArray(d.translation), &motion_unknown));
          if (motion_unknown) node_.health().count("tracker_motion_unknown");
        });
  } else {
    node_.subscribe<ips::ground_truth_t>(
        channel.empty() ? ips::channels::kGtPose : channel, [this](const ips::ground_truth_t& g) {
          ips::fw::BodyPose b;
          if (!ips::fw::bodyPose(g, &b))
            return node_.health().bad("nan", "a ground-truth pose that is not finite or not a rotation");
          onPose(ips::fw::stampedPose(g.utime, b));
        });
  }
}

void MapperProcess::save(const std::string& path) {
  if (path.empty()) return;
  mapper_.map().save(path);
  IPS_LOG(ips::LogLevel::Info, "wrote " << mapper_.map().size() << " voxels to " << path);
}

template <class Fn>
void MapperProcess::timed(Fn fn) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<ips::mapper::MappedFrame> frames = fn();
  if (frames.empty()) return;
  node_.health().latency(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count() /
                         frames.size());
  publish(frames);
}

void MapperProcess::publish(const std::vector<ips::mapper::MappedFrame>& frames) {
  for (const auto& f : frames) {
    if (!f.has_grey) node_.health().count("points_without_grey");
    const ips::point_cloud_t out = ips::fw::pointCloudMessage(f.utime, f.seq, "world", f.pose, f.points, f.intensity);
    node_.publish(points_channel_, out);
    if (odometry_) align(f);
  }
  node_.health().set("map_voxels", static_cast<int64_t>(mapper_.map().size()));
}

void MapperProcess::align(const ips::mapper::MappedFrame& f) {
  const auto t0 = std::chrono::steady_clock::now();
  const ips::mapper::CloudDelta d =
      odometry_->add(f.utime, f.alignment_points, f.pose.T_world_body * T_body_cam0_, f.depth_sigma_per_m2);
  node_.health().set(
      "cloud_align_ms",
      static_cast<int64_t>(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count()));
  if (d.reason == "first_map") return;
  node_.health().count(d.valid ? "cloud_valid" : "cloud_" + d.reason);
  ips::tracker_delta_t m{};
  m.utime = d.utime;
  m.utime_prev = d.utime_prev;
  m.seq = ++cloud_seq_;
  m.valid = d.valid;
  ips::fw::vectorToArray(d.T_prev_now.translation(), m.translation);
  ips::fw::quaternionToArray(Eigen::Quaterniond(d.T_prev_now.linear()), m.rotation);
  if (d.valid) ips::fw::matrixToArray<6>(d.covariance, m.covariance);
  m.num_features = d.points;
  m.num_inter_matches = m.num_inliers = d.correspondences;
  m.residual_rms = d.rmse_m;
  m.far_rotation[0] = 1;
  node_.publish(cloud_delta_channel_, m);
}

}  // namespace ips::mapper_app
