// track_log: the stereo tracker alone over the STEREO pairs of an LCM log (as dataset_to_lcm writes them), on one
// thread, its increments chained into the trajectory of camera 0; writes it and the ground truth of camera 0
// (GT_POSE of the body times T_imu_cam0) as TUM files for traj_eval, and prints the time per pair.
// --e3d-config E3D.yaml: E3D (the e3d process's matcher, Vulkan) matches every pair first, in the same run, and the
// tracker takes its intra-matches from that map (its own search where the map has no disparity); E3D's own time
// is printed apart and not counted in ms_per_pair (it runs anyway, as its own process).
// --far-out FILE.tum: also the chain of the increments fused with the rotation from far points (fuseFarRotation), the
// tracker-only use of paper section 6's points at infinity, for traj_eval beside --out.
// The epipolar monitor runs after each pair when the config enables it (integrity/enabled), as in the tracker
// process, and its corrections rectify the following pairs (E3D's map with --e3d-config keeps the calibration's); its
// time is printed apart.
// Last line: "pairs=N valid=V ms_per_pair=X".
#include <chrono>
#include <fstream>
#include <iomanip>
#include <ips/ground_truth_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <opencv2/core.hpp>

#include "ips/args.hpp"
#include "ips/calibration.hpp"
#include "ips/eval/e3d_guide.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/log_reader.hpp"
#include "ips/framework/message_arrays.hpp"
#include "ips/framework/process.hpp"
#include "ips/framework/validate.hpp"
#include "ips/tracker/delta_chain.hpp"
#include "ips/tracker/epipolar_integrity.hpp"
#include "ips/tracker/stereo_tracker.hpp"

namespace {

void writeTumLine(std::ofstream& out, int64_t utime, const Eigen::Isometry3d& T) {
  const Eigen::Quaterniond q(T.linear());
  const Eigen::Vector3d p = T.translation();
  out << std::fixed << std::setprecision(6) << utime * 1e-6 << std::setprecision(9) << ' ' << p.x() << ' ' << p.y()
      << ' ' << p.z() << ' ' << q.x() << ' ' << q.y() << ' ' << q.z() << ' ' << q.w() << '\n';
}

}  // namespace

int main(int argc, char** argv) {
  return ips::fw::guardedMain("track_log", [&]() {
    ips::Args args(argc, argv, "the stereo tracker alone over a log's stereo pairs: trajectory, ground truth, time");
    args.required("--log", "FILE.lcmlog", "log with STEREO (and GT_POSE) messages")
        .option("--calib", "FILE", "calibration (default: FILE.lcmlog.calib.yaml)")
        .required("--config", "FILE", "tracker parameters (config/euroc.yaml, config/kitti.yaml, ...)")
        .required("--out", "FILE.tum", "trajectory of camera 0 (first pair = origin)")
        .option("--gt-out", "FILE.tum", "ground truth of camera 0 in the ground truth's world frame")
        .option("--e3d-config", "E3D.yaml", "intra-matches from E3D's disparity map of each pair (E3D in this run)")
        .option("--far-out", "FILE.tum", "trajectory of the increments fused with the rotation from far points");
    if (!args.parse()) return 0;
    cv::setNumThreads(1);  // one thread, as the time per pair is compared
    const std::string log_path = args.get("--log");
    const ips::StereoCalibration calib =
        ips::loadCalibration(args.has("--calib") ? args.get("--calib") : log_path + ".calib.yaml");
    const ips::Config cfg(args.get("--config"));
    ips::tracker::StereoTracker tracker(calib, ips::tracker::loadTrackerParams(cfg));
    // The epipolar monitor as the tracker process runs it (config integrity/enabled): its corrections change the
    // rectification of the following pairs, so the trajectory is the deployed one.
    ips::tracker::EpipolarMonitor monitor(tracker.rectification(), ips::tracker::loadIntegrityParams(cfg));

    std::unique_ptr<ips::eval::E3dGuide> e3d;
    if (args.has("--e3d-config"))
      e3d = std::make_unique<ips::eval::E3dGuide>(calib, args.get("--e3d-config"), tracker.rectification());
    double e3d_ms = 0;
    int64_t intra = 0, from_map = 0, inliers = 0, inter = 0;
    ips::fw::LogReader log(log_path);  // a damaged log is an error naming the byte, not a short run
    ips::fw::LogMessage event;
    std::ofstream gt_out;
    if (args.has("--gt-out")) gt_out.open(args.get("--gt-out"));
    ips::tracker::DeltaChain chain, far_chain;
    int64_t pairs = 0, valid = 0, far_valid = 0, far_used = 0;
    double far_matches = 0, far_inliers = 0;
    double total_ms = 0, integrity_ms = 0;
    ips::tracker::StageTimes stages;  // sums [ms]
    int64_t guided = 0, wide = 0, offset_observed = 0, offset_rejected = 0;
    while (log.next(&event)) {
      if (event.channel == "GT_POSE" && gt_out.is_open()) {
        ips::ground_truth_t g{};
        if (g.decode(event.data.data(), 0, static_cast<int>(event.data.size())) < 0) continue;
        Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
        T_w_b.linear() = ips::fw::quaternionFromArray(g.orientation).normalized().toRotationMatrix();
        T_w_b.translation() = ips::fw::vectorFromArray(g.position);
        writeTumLine(gt_out, g.utime, T_w_b * calib.T_imu_cam0);
      } else if (event.channel == "STEREO") {
        ips::stereo_pair_t m;
        if (m.decode(event.data.data(), 0, static_cast<int>(event.data.size())) < 0)
          throw std::runtime_error("STEREO does not decode");
        const auto check = ips::fw::validate(m);
        if (!check.ok()) throw std::runtime_error("bad stereo pair " + std::to_string(m.seq) + ": " + check.detail);
        // Timed as the process would see it: from the decoded message's images to the increment.
        const ips::tracker::DisparityGuide* guide = nullptr;
        if (e3d) {
          double ms = 0;
          guide = &e3d->match(ips::fw::leftImage(m), ips::fw::rightImage(m), &ms);
          e3d_ms += ms;
        }
        const auto t0 = std::chrono::steady_clock::now();
        const ips::tracker::TrackResult r =
            tracker.process(m.utime, ips::fw::leftImage(m), ips::fw::rightImage(m), nullptr, guide);
        total_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        const auto t1 = std::chrono::steady_clock::now();
        const ips::tracker::IntegrityStatus& integrity = ips::tracker::monitorPair(monitor, tracker, m.utime);
        integrity_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count();
        if (integrity.applied_now) {
          const Eigen::Vector3d w = integrity.applied.rotation * 180 / M_PI;
          std::printf("integrity: correction applied after pair %lld: rotation [%.4f %.4f %.4f] deg, focal %.5f\n",
                      static_cast<long long>(m.seq), w.x(), w.y(), w.z(), integrity.applied.focal_scale);
        }
        stages.rectify += r.times.rectify, stages.detect += r.times.detect, stages.intra += r.times.intra;
        stages.inter += r.times.inter, stages.motion += r.times.motion;
        guided += r.guided_pass ? 1 : 0, wide += r.wide_retry ? 1 : 0;
        offset_observed += r.disparity_offset_observed, offset_rejected += r.disparity_offset_rejected;
        chain.add(r.utime, r.utime_prev, r.valid, r.rotation, r.translation);
        const ips::tracker::FusedIncrement fused = ips::tracker::fuseFarRotation(r, tracker.params().far.fuse_chi2);
        far_chain.add(r.utime, r.utime_prev, r.valid, fused.rotation, fused.translation);
        far_valid += r.far_valid, far_used += fused.far_used;
        far_matches += r.num_far_matches, far_inliers += r.num_far_inliers;
        ++pairs;
        valid += r.valid ? 1 : 0;
        intra += r.num_intra_matches, from_map += r.guided_intra.from_map;
        if (r.valid) inliers += r.num_inliers, inter += r.num_inter_matches;
      }
    }
    std::ofstream out(args.get("--out"));
    for (const auto& p : chain.poses()) writeTumLine(out, p.utime, p.T_world_cam0);
    if (args.has("--far-out")) {
      std::ofstream far_out(args.get("--far-out"));
      for (const auto& p : far_chain.poses()) writeTumLine(far_out, p.utime, p.T_world_cam0);
    }
    const double n = std::max<int64_t>(1, pairs);
    std::printf(
        "stages [ms per pair]: rectify %.2f detect %.2f intra %.2f inter %.2f motion %.2f; guided passes %lld, "
        "wide retries %lld\n",
        stages.rectify / n, stages.detect / n, stages.intra / n, stages.inter / n, stages.motion / n,
        static_cast<long long>(guided), static_cast<long long>(wide));
    std::printf(
        "intra-matching (%s): %.0f matches per pair, %.1f %% from the map; inliers %.1f %% of the inter-matches",
        e3d ? "E3D's map" : "own search", intra / n, intra ? 100.0 * from_map / intra : 0.0,
        inter ? 100.0 * inliers / inter : 0.0);
    if (e3d) std::printf("; E3D %.1f ms per pair", e3d_ms / n);
    std::printf("\n");
    std::printf(
        "rotation from far points: valid on %lld pairs, %.0f far matches and %.0f far inliers per pair, fused "
        "into %lld increments\n",
        static_cast<long long>(far_valid), far_matches / n, far_inliers / n, static_cast<long long>(far_used));
    std::printf(
        "disparity offset: estimate %.3f px (sigma %.3f px) after %lld pairs' observations (%lld refused by the gate), "
        "in use %.3f px\n",
        tracker.disparityOffsetEstimate(), tracker.disparityOffsetSigma(), static_cast<long long>(offset_observed),
        static_cast<long long>(offset_rejected), tracker.disparityOffset());
    if (monitor.params().enabled)
      std::printf(
          "epipolar integrity: %lld alarms, %lld steps, %lld corrections, %lld pairs without measurement; %.2f ms per "
          "pair (not in ms_per_pair)\n",
          static_cast<long long>(monitor.status().alarms), static_cast<long long>(monitor.status().steps),
          static_cast<long long>(monitor.status().corrections),
          static_cast<long long>(monitor.status().pairs_without_measurement), integrity_ms / n);
    std::printf("pairs=%lld valid=%lld ms_per_pair=%.2f\n", static_cast<long long>(pairs),
                static_cast<long long>(valid), pairs ? total_ms / pairs : 0.0);
    return 0;
  });
}
