// e3d: dense stereo as a process. Raw STEREO pairs in; rectification and Semi-Global Matching on the Vulkan
// device; DISPARITY out. Matching runs in a worker thread: live, it always takes the newest pair and counts
// the ones it skipped; for replay, --every-nth N picks pairs by sequence number and --queue keeps all of
// them, so that a log replayed twice gives the same maps. With process/apply_integrity, the right camera's correction
// from the tracker's epipolar integrity monitor (INTEGRITY) rectifies the pairs after the one that decided it, and
// so does the tracker's disparity offset, which comes in the same message.
// With mono/enabled, depth from one camera: the left images of a pair and of the pair mono/gap_pairs before it,
// polar-rectified for the filter's relative pose (FILTER_STATE) and matched, go out as points on MONO_POINTS.
#include <memory>
#include <optional>

#include "app/e3d_process.hpp"
#include "ips/calibration.hpp"
#include "ips/config.hpp"
#include "ips/e3d/mono_depth.hpp"
#include "ips/e3d/stereo_jobs.hpp"
#include "ips/e3d/stereo_matcher.hpp"
#include "ips/e3d/vulkan_context.hpp"
#include "ips/framework/channels.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/process.hpp"
#include "ips/log.hpp"

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
    const std::optional<long long> every_nth =
        args.has("--every-nth") ? std::optional<long long>(args.getInt("--every-nth")) : std::nullopt;
    const ips::e3d::ProcessParams process_params = ips::e3d::loadProcessParams(cfg, every_nth, args.getFlag("--queue"));
    const bool mono_enabled = cfg.getBool("mono/enabled", false);
    const std::optional<ips::e3d::MonoDepthParams> mono_params =
        cfg.has("mono") ? std::optional(ips::e3d::MonoDepthParams::fromConfig(cfg.section("mono"))) : std::nullopt;
    if (ips::fw::configChecked(args, cfg)) return 0;

    ips::e3d::VulkanContext ctx(args.get("--device"));
    const ips::StereoRectification rect = ips::scaledRectification(calib, process_params.output_scale);
    ips::e3d::StereoMatcher matcher(ctx, rect.size, params);
    matcher.setRectification(rect, cv::Size(calib.cam0.width, calib.cam0.height));
    std::unique_ptr<ips::e3d::MonoDepth> mono;
    if (mono_enabled) {
      mono = std::make_unique<ips::e3d::MonoDepth>(ctx, calib.cam0, params, *mono_params);
      IPS_INFO("depth from one camera: pairs " << mono->params().gap_pairs << " apart, every "
                                               << mono->params().every_nth << "th pair, on "
                                               << ips::channels::kMonoPoints);
    }
    ips::fw::Node node("e3d", args.get("--lcm-url"));
    ips::e3d_app::E3dProcess process(node, calib, matcher, rect, process_params, mono.get());
    IPS_INFO("matching " << rect.size.width << "x" << rect.size.height << " on " << ctx.info().name << ", "
                         << params.describe());
    if (rect.hasFlatField())
      IPS_INFO("the lenses' flat-field gain (vignetting_gain): "
               << (matcher.appliesFlatField() ? "applied" : "not applied (census does not need it)"));
    const int rc = node.run();
    process.stop(true);
    node.publishHealth(1.0);
    return rc;
  });
}
