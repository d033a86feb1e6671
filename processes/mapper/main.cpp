// mapper: every disparity map (DISPARITY) placed in the world by the navigation state at its image's time
// (FILTER_STATE, or TRACKER_DELTA chained, or GT_POSE: --pose-source), published on POINTS and fused into a
// voxel map written at shutdown and on SIGUSR1 (--map-out, PLY or PCD). The work is ips_mapper's (no LCM);
// this file turns messages into its inputs and its frames into messages. With --cloud-delta-channel each map is
// also aligned with the previous one (ips::mapper::CloudOdometry) and the relative pose goes to the filter.
#include <csignal>
#include <optional>
#include <string>

#include "app/mapper_process.hpp"
#include "ips/calibration.hpp"
#include "ips/config.hpp"
#include "ips/framework/channels.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/process.hpp"
#include "ips/mapper/cloud_odometry.hpp"
#include "ips/mapper/params.hpp"

namespace {

volatile std::sig_atomic_t g_save_requested = 0;
void onSaveRequest(int) { g_save_requested = 1; }

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
    const std::optional<ips::mapper_app::PoseSource> pose_source =
        ips::mapper_app::poseSourceFromName(args.get("--pose-source"));
    if (!pose_source)
      throw ips::ArgError("--pose-source must be filter, tracker or truth, not '" + args.get("--pose-source") + "'");
    const auto calib = ips::loadCalibration(args.get("--calib"));
    const ips::Config cfg(args.get("--config"));
    const auto params = ips::mapper::loadMapperParams(cfg);
    const auto cloud_odometry = ips::mapper::CloudOdometryParams::fromConfig(cfg);
    if (ips::fw::configChecked(args, cfg)) return 0;
    const std::string map_out = args.has("--map-out") ? args.get("--map-out") : "";

    ips::fw::Node node(args.get("--name"), ips::fw::resolveLcmUrl(args.get("--lcm-url")));
    const std::string cloud_delta_channel =
        args.get("--cloud-delta-channel") == "none" ? "" : args.get("--cloud-delta-channel");
    ips::mapper_app::MapperProcess mapper(node, calib, params, args.get("--points-channel"), cloud_delta_channel,
                                          cloud_odometry, *pose_source,
                                          args.has("--pose-channel") ? args.get("--pose-channel") : "");
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
