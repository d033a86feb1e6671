// traj_eval: evaluates filter trajectories against ground truth.
//
//   traj_eval --est est.tum --gt gt.tum [--segment 10] [--plot out.png] [--keep-truth-steps]
//       ATE RMSE after SE(3) alignment, relative error per distance, end-point error (% of distance); with
//       --lengths a second line: KITTI-devkit relative errors over sub-sequences of those lengths (every frame a
//       start) and the end-point error with only the first pose aligned.
//   traj_eval --simulate [--filter ekf|ukf|both] [--runs 10] [--seed 1] [--duration 125] [--config f.yaml]
//             [--calib calib.yaml] [--no-tracker] [--no-tilt] [--init-from-truth] [--image-hz 8]
//             [--tracker-sigma-t 0.002] [--tracker-sigma-r 1e-4] [--segment 10] [--out-dir DIR]
//       Monte Carlo runs of the fused filter on the analytic walk (3 s at rest for the static initialisation,
//       then ~90 m in 2 minutes) (the test bed; ips_sim once it exists):
//       the same figures per filter plus NEES of the pose averaged over runs with its 95 % bounds; writes
//       TUM files (ground truth and run 0 of each filter) and a PNG plot into DIR.
// The last line summarises: for --simulate `ekf_endpoint_pct=.. ekf_anees=.. ukf_endpoint_pct=.. ukf_anees=..`.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "ips/args.hpp"
#include "ips/config.hpp"
#include "ips/eval/filter_testbed.hpp"
#include "ips/eval/trajectory.hpp"
#include "ips/filter/models.hpp"
#include "ips/log.hpp"

using namespace ips::filter;
using namespace ips::eval;

namespace {

struct Options {
  std::string est, gt, plot, config, calib, out_dir;
  std::vector<double> lengths;  // --lengths 10,20,40: relative errors of sub-sequences of these lengths
  bool simulate = false, tracker = true, tilt = true;
  std::string filter;
  int runs = 0;
  unsigned seed = 0;
  double duration = 0, segment = 0;
  bool from_truth = false;
  bool keep_truth_steps = false;
  double image_hz = 0, sigma_t = 0, sigma_r = 0;
};

void declareOptions(ips::Args& args) {
  args.option("--est", "est.tum", "estimated trajectory (TUM)")
      .option("--gt", "gt.tum", "ground truth (TUM)")
      .option("--segment", "M", "segment length of the relative error", "10")
      .option("--lengths", "10,20,40",
              "also KITTI-devkit relative errors over sub-sequences of these lengths and the end-point error\n"
              "with only the first pose aligned")
      .option("--plot", "out.png", "top-down plot of the trajectories")
      .flag("--keep-truth-steps",
            "judge against the ground truth's positions as recorded (default: its steps beyond 5 g over one\n"
            "sample are taken off the later positions, as ips_report does)")
      .flag("--simulate", "Monte Carlo runs of the fused filter on the analytic walk instead")
      .option("--filter", "ekf|ukf|both", "--simulate: the filters", "both")
      .option("--runs", "N", "--simulate: runs", "10")
      .option("--seed", "S", "--simulate: first seed", "1")
      .option("--duration", "S", "--simulate: walk duration", "125")
      .option("--config", "filter.yaml", "--simulate: filter configuration (default: built-in)")
      .option("--calib", "calib.yaml", "--simulate: calibration (default: the test bed's)")
      .flag("--no-tracker", "--simulate: without tracker deltas")
      .flag("--no-tilt", "--simulate: without the tilt sensor")
      .flag("--init-from-truth", "--simulate: the filter starts from the truth with its initial covariance")
      .option("--image-hz", "F", "--simulate: image rate", "8")
      .option("--tracker-sigma-t", "M", "--simulate: noise of the tracker deltas' translation", "0.002")
      .option("--tracker-sigma-r", "RAD", "--simulate: noise of the tracker deltas' rotation", "1e-4")
      .option("--out-dir", "DIR", "--simulate: TUM files and the plot", ".");
}

Options readOptions(const ips::Args& args) {
  Options a;
  a.est = args.get("--est");
  a.gt = args.get("--gt");
  a.plot = args.get("--plot");
  a.config = args.get("--config");
  a.calib = args.get("--calib");
  a.out_dir = args.get("--out-dir");
  a.simulate = args.getFlag("--simulate");
  a.tracker = !args.getFlag("--no-tracker");
  a.tilt = !args.getFlag("--no-tilt");
  a.from_truth = args.getFlag("--init-from-truth");
  a.keep_truth_steps = args.getFlag("--keep-truth-steps");
  a.filter = args.get("--filter");
  a.runs = static_cast<int>(args.getInt("--runs"));
  a.seed = static_cast<unsigned>(args.getInt("--seed"));
  a.duration = args.getDouble("--duration");
  if (args.has("--lengths")) {
    std::stringstream ss(args.get("--lengths"));
    std::string item;
    while (std::getline(ss, item, ',')) a.lengths.push_back(std::stod(item));
  }
  a.segment = args.getDouble("--segment");
  a.image_hz = args.getDouble("--image-hz");
  a.sigma_t = args.getDouble("--tracker-sigma-t");
  a.sigma_r = args.getDouble("--tracker-sigma-r");
  if (a.runs < 1) throw std::invalid_argument("--runs must be >= 1");
  if (a.filter != "ekf" && a.filter != "ukf" && a.filter != "both")
    throw std::invalid_argument("--filter ekf|ukf|both");
  return a;
}

void printErrors(const std::string& name, const TrajectoryErrors& e) {
  std::printf("%s matched=%zu distance_m=%.2f ate_rmse_m=%.4f rpe_pct=%.3f endpoint_m=%.4f endpoint_pct=%.4f\n",
              name.c_str(), e.matched, e.distance_m, e.ate_rmse_m, e.rpe_percent, e.endpoint_error_m,
              e.endpoint_percent);
}

int evaluateFiles(const Options& a) {
  const Trajectory est = readTum(a.est);
  Trajectory gt = readTum(a.gt);
  // The same truth as ips_report's: without the position steps no head makes between two samples.
  if (!a.keep_truth_steps) {
    const std::vector<PositionStep> steps = removePositionSteps(gt);
    double largest = 0;
    for (const auto& step : steps) largest = std::max(largest, step.step.norm());
    std::printf("ground_truth_steps_removed=%zu ground_truth_step_max_m=%.4f\n", steps.size(), largest);
  }
  Trajectory e, r;
  associate(est, gt, 0.02, &e, &r);
  if (e.size() < 3) throw std::runtime_error("fewer than 3 estimate poses overlap the ground truth in time");
  const TrajectoryErrors err = evaluate(e, r, a.segment);
  printErrors("estimate", err);
  if (!a.lengths.empty()) {
    // The recordings' figures (KITTI devkit relative errors, every frame a start; end-point error with only
    // the first pose aligned).
    const RelativeErrors rel = relativeErrors(e, r, a.lengths);
    const double end_m = endErrorFirstPoseAligned(e, r);
    std::printf(
        "rpe_trans_pct=%.3f rpe_rot_deg_per_m=%.4f subsequences=%zu end_error_m=%.4f end_error_pct=%.3f "
        "ate_rmse_m=%.4f distance_m=%.2f\n",
        rel.trans_pct, rel.rot_deg_per_m, rel.subsequences, end_m,
        err.distance_m > 0 ? 100.0 * end_m / err.distance_m : NAN, err.ate_rmse_m, err.distance_m);
  }
  if (!a.plot.empty()) plotTopDown(a.plot, gt, {est}, {"estimate"});
  return 0;
}

int simulate(const Options& a) {
  FilterParams base;
  if (!a.config.empty()) {
    const ips::Config cfg(a.config);
    base = loadFilterParams(cfg.section("filter"));
    cfg.refuseUnreadKeys();
  }
  const ips::StereoCalibration calib = a.calib.empty() ? testbedCalibration() : ips::loadCalibration(a.calib);
  WalkParams wp;
  wp.duration_s = a.duration;
  const AnalyticWalk walk(wp);
  SensorSimParams sp;
  sp.image_rate_hz = a.image_hz;
  sp.tracker_sigma_t = a.sigma_t;
  sp.tracker_sigma_r = a.sigma_r;
  sp.gravity = base.gravity;
  std::filesystem::create_directories(a.out_dir);

  std::vector<FilterType> types;
  if (a.filter != "ukf") types.push_back(FilterType::Ekf);
  if (a.filter != "ekf") types.push_back(FilterType::Ukf);
  const double t_start = 0.0;
  // Default: the static initialisation during the walk's rest at the start; else a draw around the truth.
  const Matrix21d P0 = a.from_truth ? initialCovariance(base.init) : Matrix21d::Zero();
  std::string summary;
  Trajectory gt_run0;
  std::vector<Trajectory> plots;
  std::vector<std::string> labels;
  for (FilterType type : types) {
    FilterParams params = base;
    params.type = type;
    const std::string name = toString(type);
    // NEES of the pose averaged over runs, sampled once per second.
    std::vector<double> nees_sum;
    double endpoint_sum = 0, endpoint_max = 0, ate_sum = 0, rpe_sum = 0, dist = 0;
    ips::filter::SensorCounters tracker{}, imu{};
    for (int run = 0; run < a.runs; ++run) {
      SensorSim sim(walk, sp, calib, a.seed + 1000u * static_cast<unsigned>(run));
      Estimator est(params, calib);
      const std::vector<FilterOutput> out = runSimulation(est, sim, t_start, a.duration, a.tracker, a.tilt, P0);
      Trajectory e = toTrajectory(out), r;
      for (const FilterOutput& o : out) {
        const NavState t = sim.truth(o.state.utime);
        r.push_back({o.state.utime * 1e-6, t.position, t.orientation});
      }
      const TrajectoryErrors err = evaluate(e, r, a.segment);
      endpoint_sum += err.endpoint_percent;
      endpoint_max = std::max(endpoint_max, err.endpoint_percent);
      ate_sum += err.ate_rmse_m;
      rpe_sum += err.rpe_percent;
      dist = err.distance_m;
      const int64_t step_us = 1'000'000;
      int64_t next = static_cast<int64_t>(t_start * 1e6) + step_us;
      size_t k = 0;
      for (const FilterOutput& o : out) {
        if (o.state.utime < next) continue;
        next += step_us;
        if (nees_sum.size() <= k) nees_sum.resize(k + 1, 0.0);
        nees_sum[k++] += poseNees(o, sim.truth(o.state.utime));
      }
      tracker = est.counters()[kSensorTracker];
      imu = est.counters()[kSensorImu];
      if (run == 0) {
        writeTum(a.out_dir + "/" + name + "_run0.tum", e);
        if (gt_run0.empty()) {
          gt_run0 = r;
          writeTum(a.out_dir + "/ground_truth.tum", r);
        }
        plots.push_back(e);
        labels.push_back(name);
      }
    }
    double anees = 0;
    int inside = 0;
    const double lo = chiSquareQuantile(0.025, 6 * a.runs) / a.runs;
    const double hi = chiSquareQuantile(0.975, 6 * a.runs) / a.runs;
    for (double s : nees_sum) {
      const double v = s / a.runs;
      anees += v;
      inside += (v >= lo && v <= hi);
    }
    anees /= std::max<size_t>(1, nees_sum.size());
    // Bounds of the time average over all samples (runs x seconds x 6 dof), assuming independence in time.
    const double n_all = static_cast<double>(a.runs) * nees_sum.size();
    const double lo_all = chiSquareQuantile(0.025, static_cast<int>(6 * n_all)) / n_all;
    const double hi_all = chiSquareQuantile(0.975, static_cast<int>(6 * n_all)) / n_all;
    const double endpoint_mean = endpoint_sum / a.runs;
    std::printf(
        "filter=%s runs=%d distance_m=%.1f endpoint_pct_mean=%.4f endpoint_pct_max=%.4f ate_rmse_m=%.4f "
        "rpe_pct=%.3f anees_pose=%.3f anees_bounds_per_time=[%.3f,%.3f] frac_in_bounds=%.2f "
        "anees_bounds_overall=[%.3f,%.3f] last_run_tracker_accepted=%lld rejected=%lld too_late=%lld "
        "imu_rejected=%lld\n",
        name.c_str(), a.runs, dist, endpoint_mean, endpoint_max, ate_sum / a.runs, rpe_sum / a.runs, anees, lo, hi,
        nees_sum.empty() ? 0.0 : static_cast<double>(inside) / nees_sum.size(), lo_all, hi_all,
        static_cast<long long>(tracker.accepted), static_cast<long long>(tracker.rejected),
        static_cast<long long>(tracker.too_late), static_cast<long long>(imu.rejected));
    char buf[160];
    std::snprintf(buf, sizeof buf, "%s%s_endpoint_pct=%.4f %s_anees=%.3f", summary.empty() ? "" : " ", name.c_str(),
                  endpoint_mean, name.c_str(), anees);
    summary += buf;
  }
  plotTopDown(a.out_dir + "/trajectory.png", gt_run0, plots, labels);
  std::printf("%s\n", summary.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    ips::setLogLevel(ips::LogLevel::Warn);
    ips::Args args(argc, argv,
                   "evaluates trajectories against ground truth (--est, --gt), or the fused filter by Monte Carlo "
                   "runs\non the analytic walk (--simulate)");
    declareOptions(args);
    if (!args.parse()) return 0;
    const Options a = readOptions(args);
    if (a.simulate) return simulate(a);
    if (a.est.empty() || a.gt.empty()) {
      std::fputs(args.help().c_str(), stderr);
      return 2;
    }
    return evaluateFiles(a);
  } catch (const ips::ArgError& e) {
    std::fprintf(stderr, "%s\n", e.what());  // names the program and the option
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "traj_eval: %s\n", e.what());
    return 1;
  }
}
