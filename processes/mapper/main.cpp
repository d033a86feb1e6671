// mapper: georeferenced 3D maps. Every disparity map (DISPARITY) is turned into points in the world frame by
// the navigation state at its image's time (FILTER_STATE interpolated; the tracker's increments chained with
// --pose-source tracker, for a head without IMU; the ground truth GT_POSE with --pose-source truth) and the
// head's calibration; the points of each map are published on POINTS and fused
// into a voxel map, written at shutdown (and on SIGUSR1) to --map-out as PLY or PCD. A map waits for the
// state at its time, so that a replayed log gives the same points as the live run. The library (ips_mapper)
// knows nothing of LCM.
#include <chrono>
#include <csignal>
#include <deque>
#include <ips/disparity_map_t.hpp>
#include <ips/filter_state_t.hpp>
#include <ips/ground_truth_t.hpp>
#include <ips/point_cloud_t.hpp>
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
#include "ips/log.hpp"
#include "ips/mapper/params.hpp"
#include "ips/mapper/pose_buffer.hpp"
#include "ips/mapper/stereo_points.hpp"
#include "ips/mapper/voxel_map.hpp"
#include "ips/tracker/delta_chain.hpp"

namespace {

volatile std::sig_atomic_t g_save_requested = 0;
void onSaveRequest(int) { g_save_requested = 1; }

ips::mapper::Pose fromState(const ips::filter_state_t& s) {
  namespace layout = ips::fw::filter_state_layout;
  ips::mapper::Pose p;
  p.utime = s.utime;
  p.T_world_body.linear() = Eigen::Quaterniond(s.orientation[0], s.orientation[1], s.orientation[2], s.orientation[3])
                                .normalized()
                                .toRotationMatrix();
  p.T_world_body.translation() = Eigen::Vector3d(s.position[0], s.position[1], s.position[2]);
  const int index[6] = {layout::kPosition, layout::kPosition + 1, layout::kPosition + 2,
                        layout::kAttitude, layout::kAttitude + 1, layout::kAttitude + 2};
  if (s.cov_dim >= layout::kDim)
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) p.covariance(r, c) = s.covariance[index[r]][index[c]];
  return p;
}

class MapperProcess {
 public:
  MapperProcess(ips::fw::Node& node, const ips::StereoCalibration& calib, const ips::mapper::MapperParams& params,
                const std::string& points_channel)
      : node_(node),
        calib_(calib),
        params_(params),
        points_channel_(points_channel),
        poses_(params.max_pose_gap_s, 10.0),
        map_(params.voxel_size_m, params.max_voxels),
        stereo_admission_(calib.cam0.width, calib.cam0.height) {
    head_.R_rect0_cam0 = ips::computeRectification(calib).R_rect0_cam0;
    head_.T_body_cam0 = calib.T_imu_cam0;
  }

  void onStereo(const ips::stereo_pair_t& m) {
    // The pairs only give the points their grey values; still, a forged one must not stay among them.
    if (!stereo_admission_.admit(m, node_.health(), node_.arrivalUs())) return;
    lefts_[m.seq] = ips::fw::mono8Copy(ips::fw::leftImage(m));
    while (static_cast<int>(lefts_.size()) > params_.max_pending_images) lefts_.erase(lefts_.begin());
  }

  void onDisparity(const ips::disparity_map_t& m) {
    node_.health().received(m.utime);
    const ips::fw::Verdict v = ips::fw::validate(m);
    if (!v.ok()) return node_.health().bad(v.reason, v.detail);
    // Its seq is the pair's: E3D matches every n-th pair, so a jump in it is no loss (not counted as a gap).
    if (!ips::fw::admitInOrder(disparity_order_, m.utime, 0, node_.health(), "disparity", node_.arrivalUs())) return;
    node_.health().accepted();
    pending_.push_back(m);
    if (static_cast<int>(pending_.size()) > params_.max_pending_maps) {
      pending_.pop_front();
      node_.health().dropped("map_waited_too_long_for_a_pose");
    }
    drain();
  }

  void onPose(const ips::mapper::Pose& p) {
    // A stamp off the pose stream's time line (forged, an hour ahead) would hold every map back: refused here.
    if (!ips::fw::admitInOrder(pose_order_, p.utime, 0, node_.health(), "pose", node_.arrivalUs())) return;
    if (!poses_.add(p)) node_.health().count("pose_time_went_back");
    drain();
  }

  void save(const std::string& path) {
    if (path.empty()) return;
    map_.save(path);
    IPS_LOG(ips::LogLevel::Info, "wrote " << map_.size() << " voxels to " << path);
  }

  size_t voxels() const { return map_.size(); }

 private:
  void drain() {
    while (!pending_.empty()) {
      ips::mapper::Pose pose;
      const auto found = poses_.at(pending_.front().utime, &pose);
      if (found == ips::mapper::PoseBuffer::Lookup::kNotYet) return;
      if (found == ips::mapper::PoseBuffer::Lookup::kFound) {
        process(pending_.front(), pose);
      } else {
        node_.health().dropped(found == ips::mapper::PoseBuffer::Lookup::kGap ? "no_pose_gap" : "no_pose_before_map");
      }
      pending_.pop_front();
    }
  }

  void process(const ips::disparity_map_t& m, const ips::mapper::Pose& pose) {
    const auto t0 = std::chrono::steady_clock::now();
    ips::mapper::DisparityImage image;
    image.disparity.create(m.height, m.width, CV_32FC1);
    for (int r = 0; r < m.height; ++r)
      for (int c = 0; c < m.width; ++c) {
        const int16_t d = m.data[r][c];
        image.disparity.at<float>(r, c) = d == m.invalid_value ? NAN : static_cast<float>(d) / m.subpixel_scale;
      }
    image.focal_px = m.focal_px;
    image.cx = m.cx;
    image.cy = m.cy;
    image.baseline_m = m.baseline_m;
    const auto left = lefts_.find(m.seq);
    if (left != lefts_.end()) {
      image.grey = rectifiedLeft(left->second, m.width);
    } else {
      node_.health().count("points_without_grey");
    }
    if (!logged_range_) {
      IPS_LOG(ips::LogLevel::Info, "points kept up to "
                                       << ips::mapper::rangeForDepthSigma(params_, m.focal_px, m.baseline_m)
                                       << " m (depth error " << params_.max_depth_sigma_m << " m at "
                                       << params_.disparity_sigma_px << " px disparity error; f " << m.focal_px
                                       << " px, b " << m.baseline_m << " m)");
      logged_range_ = true;
    }
    ips::mapper::PointSet set = ips::mapper::triangulate(image, head_, pose.T_world_body, params_);
    ips::mapper::VoxelMap::downsample(params_.voxel_size_m, &set.points, &set.intensity);
    const int64_t dropped = map_.insert(set.points, set.intensity, pose.T_world_body.translation());
    if (dropped > 0) node_.health().count("voxels_dropped_far_from_head", dropped);

    ips::point_cloud_t out{};
    out.utime = m.utime;
    out.seq = m.seq;
    out.frame = "world";
    const Eigen::Vector3d t = pose.T_world_body.translation();
    const Eigen::Quaterniond q(pose.T_world_body.linear());
    for (int i = 0; i < 3; ++i) out.position[i] = t[i];
    out.orientation[0] = q.w(), out.orientation[1] = q.x(), out.orientation[2] = q.y(), out.orientation[3] = q.z();
    for (int i = 0; i < 36; ++i) out.pose_covariance[i] = pose.covariance(i / 6, i % 6);
    out.num_points = static_cast<int32_t>(set.points.size());
    out.points.resize(set.points.size());
    for (size_t i = 0; i < set.points.size(); ++i)
      out.points[i] = {static_cast<float>(set.points[i].x()), static_cast<float>(set.points[i].y()),
                       static_cast<float>(set.points[i].z())};
    out.intensity.assign(set.intensity.begin(), set.intensity.end());
    node_.publish(points_channel_, out);
    node_.health().set("map_voxels", static_cast<int64_t>(map_.size()));
    node_.health().latency(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }

  cv::Mat rectifiedLeft(const cv::Mat& raw, int width) {
    if (!rect_ || rect_->size.width != width)
      rect_ = ips::scaledRectification(calib_, static_cast<double>(width) / calib_.cam0.width);
    cv::Mat out;
    cv::remap(raw, out, rect_->map0x, rect_->map0y, cv::INTER_LINEAR);
    return out;
  }

  ips::fw::Node& node_;
  const ips::StereoCalibration calib_;
  const ips::mapper::MapperParams params_;
  const std::string points_channel_;
  ips::mapper::HeadGeometry head_;
  ips::mapper::PoseBuffer poses_;
  ips::mapper::VoxelMap map_;
  std::optional<ips::StereoRectification> rect_;
  std::map<int64_t, cv::Mat> lefts_;  // by seq
  std::deque<ips::disparity_map_t> pending_;
  ips::fw::StreamOrder disparity_order_, pose_order_;
  ips::fw::StereoAdmission stereo_admission_;
  bool logged_range_ = false;
};

}  // namespace

int main(int argc, char** argv) {
  return ips::fw::guardedMain("mapper", [&] {
    ips::Args args(argc, argv, "mapper: disparity maps placed in the world by the navigation state, fused into a map");
    args.required("--calib", "FILE", "the head's calibration")
        .option(
            "--pose-source", "filter|tracker|truth",
            "navigation states (FILTER_STATE), the tracker's increments chained (TRACKER_DELTA) or the ground truth "
            "(GT_POSE)",
            "filter")
        .option("--pose-channel", "CHANNEL", "channel of the poses (default: FILTER_STATE, TRACKER_DELTA or GT_POSE)")
        .option("--points-channel", "CHANNEL", "channel the points of each map go to", ips::channels::kPoints)
        .option("--map-out", "FILE", "the fused map written at shutdown and on SIGUSR1 (.ply or .pcd)")
        .option("--name", "NAME", "process name (health channel HEALTH_<NAME>)", "mapper");
    ips::fw::addCommonOptions(args, "config/mapper.yaml");
    if (!args.parse()) return 0;
    ips::fw::applyCommonOptions(args);
    const std::string source = args.get("--pose-source");
    if (source != "filter" && source != "tracker" && source != "truth")
      throw ips::ArgError("--pose-source must be filter, tracker or truth, not '" + source + "'");
    const auto calib = ips::loadCalibration(args.get("--calib"));
    const auto params = ips::mapper::loadMapperParams(ips::Config(args.get("--config")));
    const std::string map_out = args.has("--map-out") ? args.get("--map-out") : "";

    ips::fw::Node node(args.get("--name"), ips::fw::resolveLcmUrl(args.get("--lcm-url")));
    MapperProcess mapper(node, calib, params, args.get("--points-channel"));
    node.subscribe<ips::stereo_pair_t>(ips::channels::kStereo,
                                       [&](const ips::stereo_pair_t& m) { mapper.onStereo(m); });
    node.subscribe<ips::disparity_map_t>(ips::channels::kDisparity,
                                         [&](const ips::disparity_map_t& m) { mapper.onDisparity(m); });
    if (source == "filter") {
      node.subscribe<ips::filter_state_t>(
          args.has("--pose-channel") ? args.get("--pose-channel") : ips::channels::kFilterState,
          [&](const ips::filter_state_t& s) {
            const ips::fw::Verdict v = ips::fw::validate(s);
            if (!v.ok()) return node.health().bad(v.reason, v.detail);
            mapper.onPose(fromState(s));
          });
    } else if (source == "tracker") {
      // The world is the body at the first image: the chain of camera 0 turned onto the body. No
      // uncertainty is carried along the chain (the points' pose covariance is zero).
      auto chain = std::make_shared<ips::tracker::DeltaChain>();
      const Eigen::Isometry3d T_body_cam0 = calib.T_imu_cam0;
      node.subscribe<ips::tracker_delta_t>(
          args.has("--pose-channel") ? args.get("--pose-channel") : ips::channels::kTrackerDelta,
          [&node, &mapper, chain, T_body_cam0](const ips::tracker_delta_t& d) {
            const ips::fw::Verdict v = ips::fw::validate(d);
            if (!v.ok()) return node.health().bad(v.reason, v.detail);
            const int64_t invalid_before = chain->invalid();
            chain->add(d.utime, d.utime_prev, d.valid,
                       Eigen::Quaterniond(d.rotation[0], d.rotation[1], d.rotation[2], d.rotation[3]),
                       Eigen::Vector3d(d.translation[0], d.translation[1], d.translation[2]));
            if (chain->invalid() > invalid_before) node.health().count("tracker_motion_unknown");
            ips::mapper::Pose pose;
            pose.utime = chain->poses().back().utime;
            pose.T_world_body = T_body_cam0 * chain->poses().back().T_world_cam0 * T_body_cam0.inverse();
            mapper.onPose(pose);
          });
    } else {
      node.subscribe<ips::ground_truth_t>(
          args.has("--pose-channel") ? args.get("--pose-channel") : ips::channels::kGtPose,
          [&](const ips::ground_truth_t& g) {
            ips::mapper::Pose p;
            p.utime = g.utime;
            const Eigen::Quaterniond q(g.orientation[0], g.orientation[1], g.orientation[2], g.orientation[3]);
            const Eigen::Vector3d t(g.position[0], g.position[1], g.position[2]);
            if (!t.allFinite() || !q.coeffs().allFinite() || q.norm() < 0.5)
              return node.health().bad("nan", "a ground-truth pose that is not finite or not a rotation");
            p.T_world_body.linear() = q.normalized().toRotationMatrix();
            p.T_world_body.translation() = t;
            mapper.onPose(p);
          });
    }
    std::signal(SIGUSR1, onSaveRequest);
    const int rc = node.run([&] {
      if (g_save_requested) {
        g_save_requested = 0;
        mapper.save(map_out);
      }
    });
    mapper.save(map_out);
    return rc;
  });
}
