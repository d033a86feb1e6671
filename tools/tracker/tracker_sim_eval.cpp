// Relative pose error per frame of the tracker on a simulated scenario (default config/sim_walk.yaml's
// built-in defaults: the paper's walk through a building, 1360x1024 at 8 Hz).
//   tracker_sim_eval [--scenario config/sim_walk.yaml] [--duration SECONDS (10)] [--params config/tracker.yaml]
//                    [--prior cv|imu|none (cv)] [--quiet 1] [--e3d-config config/e3d_sim.yaml]
// --e3d-config: E3D (Vulkan) matches every pair in the same run and the tracker takes its intra-matches from the
// map (the tracker's own search for corners without a disparity); the summary gives both ways' intra figures.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "ips/args.hpp"
#include "ips/eval/e3d_guide.hpp"
#include "ips/eval/tracker_on_sim.hpp"

using namespace ips::tracker;

int main(int argc, char** argv) {
  try {
    ips::Args args(argc, argv, "relative pose error per frame of the tracker on a simulated scenario");
    args.option("--scenario", "FILE.yaml", "scenario, e.g. config/sim_walk.yaml (default: its built-in defaults)")
        .option("--duration", "SECONDS", "simulated time", "10")
        .option("--params", "TRACKER.yaml", "tracker parameters (default: built-in)")
        .option("--prior", "cv|imu|none", "motion prior: constant velocity, the simulated IMU, or none", "cv")
        .option("--quiet", "0|1", "1: only the summary, not a line per frame", "0")
        .option("--e3d-config", "E3D.yaml",
                "E3D (Vulkan) matches every pair and the tracker takes its intra-matches from the map");
    if (!args.parse()) return 0;
    const double duration = args.getDouble("--duration");
    const TrackerParams params = args.has("--params") ? loadTrackerParams(args.get("--params")) : TrackerParams();
    const std::string prior_name = args.get("--prior");
    ips::eval::SimPrior prior = ips::eval::SimPrior::ConstantVelocity;
    if (prior_name == "imu")
      prior = ips::eval::SimPrior::Imu;
    else if (prior_name == "none")
      prior = ips::eval::SimPrior::None;
    else if (prior_name != "cv")
      throw std::invalid_argument("--prior must be cv, imu or none");
    const bool quiet = args.get("--quiet") != "0";
    if (!quiet)
      std::printf("frame valid step_m step_deg rot_err_deg trans_err_m trans_err_pct inliers prior_ok total_ms\n");
    std::unique_ptr<ips::eval::E3dGuide> e3d;
    ips::eval::SimGuide guide;
    if (args.has("--e3d-config"))
      guide = [&](const StereoTracker& tracker, const ips::sim::StereoFrame& f) {
        if (!e3d)
          e3d = std::make_unique<ips::eval::E3dGuide>(tracker.calibration(), args.get("--e3d-config"),
                                                      tracker.rectification());
        return &e3d->match(f.left, f.right);
      };
    const auto errors = ips::eval::runTrackerOnSimulation(
        args.get("--scenario"), duration, params, prior,
        [&](const ips::eval::SimFrameError& e) {
          if (quiet) return;
          std::printf("%5lld %d %.4f %.3f %.4f %.4f %.2f %d %d %.1f\n", (long long)e.frame, int(e.result.valid),
                      e.step_m, e.step_deg, e.rot_err_deg, e.trans_err_m,
                      e.step_m > 0 ? 100 * e.trans_err_m / e.step_m : 0.0, e.result.num_inliers, int(e.result.prior_ok),
                      e.result.times.total);
        },
        guide);
    std::vector<double> rot, tr, pct;
    int valid = 0;
    double path = 0, sum_t = 0;
    for (const auto& e : errors) {
      path += e.step_m;
      if (!e.result.valid) continue;
      ++valid;
      rot.push_back(e.rot_err_deg);
      tr.push_back(e.trans_err_m);
      sum_t += e.trans_err_m;
      if (e.step_m > 0.02) pct.push_back(100 * e.trans_err_m / e.step_m);
    }
    auto stat = [](std::vector<double> v, const char* name, const char* unit) {
      if (v.empty()) return;
      std::sort(v.begin(), v.end());
      double rms = 0;
      for (double x : v) rms += x * x;
      rms = std::sqrt(rms / v.size());
      std::printf("%-22s median %.4f  rms %.4f  p95 %.4f  max %.4f %s\n", name, v[v.size() / 2], rms,
                  v[std::min(v.size() - 1, v.size() * 95 / 100)], v.back(), unit);
    };
    std::printf("pairs %zu, valid %d, path %.2f m, prior %s\n", errors.size(), valid, path, prior_name.c_str());
    stat(rot, "rotation error", "deg");
    stat(tr, "translation error", "m");
    stat(pct, "translation error (%)", "% of step (steps > 2 cm)");
    std::printf("sum of translation errors / path: %.2f %%\n", path > 0 ? 100 * sum_t / path : 0.0);
    // The increments chained (an invalid one counts as no motion), against the true increments chained; beside them
    // the increments fused with the rotation from far points (paper section 6), whose own error per pair is kept.
    Eigen::Isometry3d chain = Eigen::Isometry3d::Identity(), fused_chain = Eigen::Isometry3d::Identity();
    Eigen::Isometry3d truth = Eigen::Isometry3d::Identity();
    const auto increment = [](const Eigen::Quaterniond& q, const Eigen::Vector3d& t) {
      Eigen::Isometry3d d = Eigen::Isometry3d::Identity();
      d.linear() = q.toRotationMatrix();
      d.translation() = t;
      return d;
    };
    std::vector<double> intra_ms, far_err, near_err_same;
    double intra = 0, from_map = 0, inliers = 0, inter = 0, far_matches = 0, far_inliers = 0;
    int far_valid = 0, far_used = 0;
    for (const auto& e : errors) {
      truth = truth * e.truth;
      const FusedIncrement f = fuseFarRotation(e.result, params.far.fuse_chi2);
      if (e.result.valid) {
        chain = chain * increment(e.result.rotation, e.result.translation);
        fused_chain = fused_chain * increment(f.rotation, f.translation);
        inliers += e.result.num_inliers;
        inter += e.result.num_inter_matches;
      }
      intra_ms.push_back(e.result.times.intra);
      intra += e.result.num_intra_matches;
      from_map += e.result.guided_intra.from_map;
      far_used += f.far_used;
      far_matches += e.result.num_far_matches;
      far_inliers += e.result.num_far_inliers;
      if (!e.result.far_valid) continue;
      ++far_valid;
      far_err.push_back(
          Eigen::AngleAxisd(e.truth.linear().transpose() * e.result.far_rotation.toRotationMatrix()).angle() * 180 /
          M_PI);
      if (e.result.valid) near_err_same.push_back(e.rot_err_deg);
    }
    const auto rotErrPerM = [&](const Eigen::Isometry3d& c) {
      return path > 0 ? Eigen::AngleAxisd(truth.linear().transpose() * c.linear()).angle() * 180 / M_PI / path : 0.0;
    };
    if (!errors.empty()) {
      stat(far_err, "far rotation error", "deg");
      stat(near_err_same, "6-DoF rot. err. (same)", "deg (pairs with a far rotation)");
      std::printf(
          "far rotation: valid on %d of %zu pairs (%.0f far matches, %.0f inliers per pair), fused into %d increments; "
          "chained: rotation error %.5f deg/m without, %.5f deg/m with; end error %.3f m without, %.3f m with "
          "(%.2f %%, %.2f %% of %.2f m)\n",
          far_valid, errors.size(), far_matches / errors.size(), far_inliers / errors.size(), far_used,
          rotErrPerM(chain), rotErrPerM(fused_chain), (chain.translation() - truth.translation()).norm(),
          (fused_chain.translation() - truth.translation()).norm(),
          path > 0 ? 100 * (chain.translation() - truth.translation()).norm() / path : 0.0,
          path > 0 ? 100 * (fused_chain.translation() - truth.translation()).norm() / path : 0.0, path);
    }
    std::sort(intra_ms.begin(), intra_ms.end());
    if (!errors.empty())
      std::printf(
          "intra-matching (%s): median %.2f ms per pair, %.0f matches per pair (%.1f %% from the map), inliers %.1f %% "
          "of the inter-matches, end error %.3f m = %.2f %% of %.2f m\n",
          guide ? "E3D's map" : "own search", intra_ms[intra_ms.size() / 2], intra / errors.size(),
          intra > 0 ? 100 * from_map / intra : 0.0, inter > 0 ? 100 * inliers / inter : 0.0,
          (chain.translation() - truth.translation()).norm(),
          path > 0 ? 100 * (chain.translation() - truth.translation()).norm() / path : 0.0, path);
    return 0;
  } catch (const ips::ArgError& e) {
    std::fprintf(stderr, "%s\n", e.what());  // names the program and the option
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tracker_sim_eval: %s\n", e.what());
    return 1;
  }
}
