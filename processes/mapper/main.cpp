// mapper: every disparity map (DISPARITY) placed in the world by the navigation state at its image's time
// (FILTER_STATE, or TRACKER_DELTA chained, or GT_POSE: --pose-source), published on POINTS and fused into a
// voxel map written at shutdown and on SIGUSR1 (--map-out, PLY or PCD). The work is ips_mapper's (no LCM);
// this file turns messages into its inputs and its frames into messages. With --cloud-delta-channel each map is
// also aligned with the previous one (ips::mapper::CloudOdometry) and the relative pose goes to the filter.
#include <chrono>
#include <csignal>
#include <ips/disparity_map_t.hpp>
#include <ips/point_cloud_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <ips/tracker_delta_t.hpp>
#include <optional>

#include "ips/calibration.hpp"
#include "ips/config.hpp"
#include "ips/framework/channels.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/message_arrays.hpp"
#include "ips/framework/message_poses.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/process.hpp"
#include "ips/framework/validate.hpp"
#include "ips/log.hpp"
#include "ips/mapper/cloud_odometry.hpp"
#include "ips/mapper/mapper.hpp"

namespace {

volatile std::sig_atomic_t g_save_requested = 0;
void onSaveRequest(int) { g_save_requested = 1; }

// Messages in, the library's plain inputs; its frames out as POINTS.
class MapperProcess {
 public:
  MapperProcess(ips::fw::Node& node, const ips::StereoCalibration& calib, const ips::mapper::MapperParams& params,
                const std::string& points_channel, const std::string& cloud_delta_channel,
                const ips::mapper::CloudOdometryParams& cloud_params)
      : node_(node),
        points_channel_(points_channel),
        cloud_delta_channel_(cloud_delta_channel),
        T_body_cam0_(calib.T_imu_cam0),
        mapper_(
            calib, params, [this](const std::string& name, int64_t n) { node_.health().dropped(name, n); },
            [this](const std::string& name, int64_t n) { node_.health().count(name, n); }),
        stereo_admission_(calib.cam0.width, calib.cam0.height) {
    if (!cloud_delta_channel_.empty()) odometry_.emplace(cloud_params);
  }

  void onStereo(const ips::stereo_pair_t& m) {
    // The pairs only give the points their grey values; still, a forged one must not stay among them.
    if (!stereo_admission_.admit(m, node_.health(), node_.arrivalUs())) return;
    mapper_.addLeftImage(m.seq, ips::fw::mono8Copy(ips::fw::leftImage(m)));
  }

  void onDisparity(const ips::disparity_map_t& m) {
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

  void onPose(const ips::Pose& p) {
    // A stamp off the pose stream's time line (forged, an hour ahead) would hold every map back: refused here.
    if (!ips::fw::admitInOrder(pose_order_, p.utime, 0, node_.health(), "pose", node_.arrivalUs())) return;
    timed([&] { return mapper_.addPose(p); });
  }

  void save(const std::string& path) {
    if (path.empty()) return;
    mapper_.map().save(path);
    IPS_LOG(ips::LogLevel::Info, "wrote " << mapper_.map().size() << " voxels to " << path);
  }

 private:
  // Runs one input through the mapper and publishes what came out; the processing time per map for health.
  template <class Fn>
  void timed(Fn fn) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::vector<ips::mapper::MappedFrame> frames = fn();
    if (frames.empty()) return;
    node_.health().latency(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count() /
                           frames.size());
    publish(frames);
  }

  void publish(const std::vector<ips::mapper::MappedFrame>& frames) {
    for (const auto& f : frames) {
      if (!f.has_grey) node_.health().count("points_without_grey");
      const ips::point_cloud_t out = ips::fw::pointCloudMessage(f.utime, f.seq, "world", f.pose, f.points, f.intensity);
      node_.publish(points_channel_, out);
      if (odometry_) align(f);
    }
    node_.health().set("map_voxels", static_cast<int64_t>(mapper_.map().size()));
  }

  // The map aligned with the previous one: a relative pose of camera 0 for the filter (CLOUD_DELTA, with the
  // convention and covariance order of a tracker delta; seq counts the alignments).
  void align(const ips::mapper::MappedFrame& f) {
    const auto t0 = std::chrono::steady_clock::now();
    const ips::mapper::CloudDelta d =
        odometry_->add(f.utime, f.points, f.pose.T_world_body * T_body_cam0_, f.depth_sigma_per_m2);
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
    for (int i = 0; i < 3; ++i) m.translation[i] = d.T_prev_now.translation()[i];
    ips::fw::quaternionToArray(Eigen::Quaterniond(d.T_prev_now.linear()), m.rotation);
    if (d.valid) ips::fw::matrixToArray<6>(d.covariance, m.covariance);
    m.num_features = d.points;
    m.num_inter_matches = m.num_inliers = d.correspondences;
    m.residual_rms = d.rmse_m;
    m.far_rotation[0] = 1;
    node_.publish(cloud_delta_channel_, m);
  }

  ips::fw::Node& node_;
  const std::string points_channel_, cloud_delta_channel_;
  const Eigen::Isometry3d T_body_cam0_;
  ips::mapper::Mapper mapper_;
  std::optional<ips::mapper::CloudOdometry> odometry_;
  int64_t cloud_seq_ = 0;
  ips::fw::StereoAdmission stereo_admission_;
  ips::fw::StreamOrder disparity_order_, pose_order_;
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
        .option("--name", "NAME", "process name (health channel HEALTH_<NAME>)", "mapper")
        .option("--cloud-delta-channel", "CHANNEL",
                "align each map with the previous one (cloud_odometry in the config) and publish the relative pose "
                "for the filter on this channel (CLOUD_DELTA); 'none': do not",
                "none");
    ips::fw::addCommonOptions(args, "config/mapper.yaml");
    if (!args.parse()) return 0;
    ips::fw::applyCommonOptions(args);
    const std::string source = args.get("--pose-source");
    if (source != "filter" && source != "tracker" && source != "truth")
      throw ips::ArgError("--pose-source must be filter, tracker or truth, not '" + source + "'");
    const auto calib = ips::loadCalibration(args.get("--calib"));
    const ips::Config cfg(args.get("--config"));
    const auto params = ips::mapper::loadMapperParams(cfg);
    const std::string map_out = args.has("--map-out") ? args.get("--map-out") : "";

    ips::fw::Node node(args.get("--name"), ips::fw::resolveLcmUrl(args.get("--lcm-url")));
    const std::string cloud_delta_channel =
        args.get("--cloud-delta-channel") == "none" ? "" : args.get("--cloud-delta-channel");
    MapperProcess mapper(node, calib, params, args.get("--points-channel"), cloud_delta_channel,
                         ips::mapper::CloudOdometryParams::fromConfig(cfg));
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
            mapper.onPose(ips::fw::stampedPose(s.utime, ips::fw::bodyPose(s)));
          });
    } else if (source == "tracker") {
      auto chain = std::make_shared<ips::mapper::TrackerPoses>(calib.T_imu_cam0);
      node.subscribe<ips::tracker_delta_t>(
          args.has("--pose-channel") ? args.get("--pose-channel") : ips::channels::kTrackerDelta,
          [&node, &mapper, chain](const ips::tracker_delta_t& d) {
            const ips::fw::Verdict v = ips::fw::validate(d);
            if (!v.ok()) return node.health().bad(v.reason, v.detail);
            bool motion_unknown = false;
            mapper.onPose(chain->add(d.utime, d.utime_prev, d.valid,
                                     Eigen::Quaterniond(d.rotation[0], d.rotation[1], d.rotation[2], d.rotation[3]),
                                     Eigen::Vector3d(d.translation[0], d.translation[1], d.translation[2]),
                                     &motion_unknown));
            if (motion_unknown) node.health().count("tracker_motion_unknown");
          });
    } else {
      node.subscribe<ips::ground_truth_t>(
          args.has("--pose-channel") ? args.get("--pose-channel") : ips::channels::kGtPose,
          [&](const ips::ground_truth_t& g) {
            ips::fw::BodyPose b;
            if (!ips::fw::bodyPose(g, &b))
              return node.health().bad("nan", "a ground-truth pose that is not finite or not a rotation");
            mapper.onPose(ips::fw::stampedPose(g.utime, b));
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
