// The epipolar integrity monitor on a simulated head whose right camera turns after calibration (a step, a drift;
// CameraFigures::relative_rotation_step_deg, _drift_deg_per_min): when the alarm came, how close the correction came
// to the truth, and (with --e3d-config) E3D's bad 2.0 and density before the step, after it without the correction
// and after it with the correction, against the simulator's true disparity, in the same run. With --seeds N the
// scenario runs with seeds S..S+N-1 and the alarms are counted (on an unchanged head every alarm is a false one).
//   integrity_sim_eval [--scenario config/sim_walk.yaml] [--duration S (scenario's walk: 126)] [--params
//                      config/tracker.yaml] [--seeds N (1)] [--first-seed S (1)] [--e3d-config config/e3d_sim.yaml]
//                      [--e3d-every K (16)] [--quiet 1]
// The last line: "integrity: alarms A on S seeds, worst correction error E deg, alarm after L s".
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>

#include "ips/args.hpp"
#include "ips/e3d/sgm.hpp"
#include "ips/e3d/stereo_matcher.hpp"
#include "ips/e3d/vulkan_context.hpp"
#include "ips/eval/e3d_scorer.hpp"
#include "ips/eval/tracker_on_sim.hpp"

using namespace ips;
using namespace ips::tracker;

namespace {

constexpr double kDeg = M_PI / 180;
constexpr double kSettleS = 10.0;  // figures after the start and after a step are taken once this has passed

struct Score {
  double bad2_pct = 0, density_pct = 0;
  int maps = 0;
  void add(double bad2, double density) {
    bad2_pct += bad2;
    density_pct += density;
    ++maps;
  }
  double bad2() const { return maps ? bad2_pct / maps : 0; }
  double density() const { return maps ? density_pct / maps : 0; }
};

struct SeedResult {
  int64_t alarms = 0, steps = 0, corrections = 0;
  double alarm_delay_s = -1;   // first alarm after the step
  double final_error_deg = 0;  // |estimate change - truth change| at the end, rotation
  double final_error_axes[3] = {0, 0, 0};
  double worst_error_settled = 0;  // largest rotation error once settled (10 s in, and 10 s after a step)
  Score before, after_uncorrected, after_corrected, after_true;
  std::vector<double> monitor_ms;
};

}  // namespace

int main(int argc, char** argv) {
  try {
    ips::Args args(argc, argv, "the epipolar integrity monitor on a simulated head whose right camera turns");
    args.option("--scenario", "FILE.yaml", "scenario, e.g. config/sim_knock.yaml (default: built-in)")
        .option("--duration", "SECONDS", "simulated time (default: the scenario's walk)")
        .option("--params", "TRACKER.yaml", "tracker and integrity parameters (default: built-in)")
        .option("--seeds", "N", "runs with the seeds S..S+N-1; alarms are counted", "1")
        .option("--first-seed", "S", "first seed", "1")
        .option("--e3d-config", "E3D.yaml",
                "E3D's bad 2.0 and density before the step, and after it with and without the correction")
        .option("--e3d-every", "K", "E3D scores every K-th pair", "16")
        .option("--quiet", "0|1", "1: no line per frame, only the summaries", "0");
    if (!args.parse()) return 0;
    const std::string params_path = args.get("--params");
    const TrackerParams params = params_path.empty() ? TrackerParams() : loadTrackerParams(params_path);
    const IntegrityParams ip = params_path.empty() ? IntegrityParams() : loadIntegrityParams(Config(params_path));
    const int seeds = static_cast<int>(args.getInt("--seeds"));
    const int first_seed = static_cast<int>(args.getInt("--first-seed"));
    const int e3d_every = static_cast<int>(args.getInt("--e3d-every"));
    const bool quiet = args.get("--quiet") != "0";
    const bool with_e3d = args.has("--e3d-config");
    if (seeds < 1 || e3d_every < 1) throw std::invalid_argument("--seeds and --e3d-every must be >= 1");

    std::vector<SeedResult> results;
    for (int seed = first_seed; seed < first_seed + seeds; ++seed) {
      sim::Scenario sc =
          args.has("--scenario") ? sim::Scenario::load(args.get("--scenario")) : sim::Scenario::defaults();
      sc.seed = uint64_t(seed);
      const double duration =
          args.has("--duration") ? args.getDouble("--duration") : sim::Trajectory(sc.trajectory, sc.gravity).duration();
      const double step_s = sc.camera.relative_rotation_step_s;
      const bool has_step = sc.camera.relative_rotation_step_deg.norm() > 0;
      const bool perturbed = sc.calibration_errors.any();
      // E3D with the monitor's correction, with none, and with the true one (the reference on the same pairs).
      std::unique_ptr<eval::E3dScorer> e3d_applied, e3d_plain, e3d_true;
      SeedResult res;
      std::string source;
      // With the true calibration the estimate's zero is the truth's; with a perturbed one (whose own error the monitor
      // finds too) changes are compared, from the estimate once certain 10 s in.
      bool have_reference = !perturbed;
      Eigen::Vector3d reference_estimate = Eigen::Vector3d::Zero(), reference_truth = Eigen::Vector3d::Zero();
      IntegrityStatus last;
      if (!quiet && seed == first_seed)
        std::printf(
            "# t_s state points dy_rms_px pair_offset_px pair_chi2 est_wx_deg est_wy_deg est_wz_deg "
            "true_wx_deg true_wy_deg true_wz_deg focal_scale sigma_px corrections\n");
      eval::runIntegrityOnSimulation(
          sc, duration, params, ip, [&](int64_t k) { return with_e3d && k % e3d_every == 0; },
          [&](const eval::SimIntegrityFrame& fr) {
            const IntegrityStatus& st = *fr.status;
            const double t = fr.t;
            res.monitor_ms.push_back(fr.monitor_ms);
            source = fr.told->source;
            if (with_e3d && !e3d_applied) {
              e3d_applied = std::make_unique<eval::E3dScorer>(*fr.told, args.get("--e3d-config"));
              e3d_plain = std::make_unique<eval::E3dScorer>(*fr.told, args.get("--e3d-config"));
              e3d_true = std::make_unique<eval::E3dScorer>(*fr.told, args.get("--e3d-config"));
            }
            // E3D matches this pair with the correction in use when it was taken (the one before this pair's
            // decision).
            if (!fr.pair->gt_disparity.empty()) {
              const cv::Mat &l = fr.pair->left, &r = fr.pair->right, &gt = fr.pair->gt_disparity;
              if (has_step && t < step_s) {
                const auto [b, d] = e3d_applied->score(l, r, gt);
                res.before.add(b, d);
              } else if (t > (has_step ? step_s : 0.0) + kSettleS) {
                const auto [b_applied, d_applied] = e3d_applied->score(l, r, gt);
                const auto [b_plain, d_plain] = e3d_plain->score(l, r, gt);
                RightCameraCorrection exact;
                exact.rotation = fr.truth;
                e3d_true->setCorrection(exact);
                const auto [b_true, d_true] = e3d_true->score(l, r, gt);
                res.after_corrected.add(b_applied, d_applied);
                res.after_uncorrected.add(b_plain, d_plain);
                res.after_true.add(b_true, d_true);
              }
            }
            if (st.applied_now && e3d_applied) e3d_applied->setCorrection(st.applied);
            if (st.state == IntegrityStatus::State::Alarm && has_step && res.alarm_delay_s < 0 && t >= step_s)
              res.alarm_delay_s = t - step_s;
            if (!have_reference && st.certain && t >= kSettleS) {
              reference_estimate = st.estimate.rotation;
              reference_truth = fr.truth;
              have_reference = true;
            }
            const Eigen::Vector3d tr = fr.truth - reference_truth;
            const Eigen::Vector3d est = st.estimate.rotation - reference_estimate;
            if (have_reference) {
              const Eigen::Vector3d err = (est - tr) / kDeg;
              const bool settled = t >= kSettleS && (!has_step || t < step_s || t >= step_s + kSettleS);
              if (settled) res.worst_error_settled = std::max(res.worst_error_settled, err.norm());
              res.final_error_deg = err.norm();
              for (int i = 0; i < 3; ++i) res.final_error_axes[i] = err[i];
            }
            if (!quiet && seed == first_seed && fr.frame % 4 == 0)
              std::printf("%.3f %d %d %.3f %.3f %.1f %.4f %.4f %.4f %.4f %.4f %.4f %.6f %.3f %lld\n", t, int(st.state),
                          st.num_points, st.dy_rms_px, st.pair_offset_px, st.pair_chi2, est.x() / kDeg, est.y() / kDeg,
                          est.z() / kDeg, tr.x() / kDeg, tr.y() / kDeg, tr.z() / kDeg, st.estimate.focal_scale,
                          st.estimate_sigma_px, (long long)st.corrections);
            last = st;
          });
      const IntegrityStatus& st = last;
      std::sort(res.monitor_ms.begin(), res.monitor_ms.end());
      res.alarms = st.alarms;
      res.steps = st.steps;
      res.corrections = st.corrections;
      std::printf(
          "seed %d: %s calibration, %.0f s; alarms %lld, steps %lld, corrections %lld, alarm after the step %.2f s; "
          "rotation error at the end %.4f deg (x %.4f y %.4f z %.4f), worst once settled %.4f deg; monitor %.1f ms "
          "per pair (median)",
          seed, source.c_str(), duration, (long long)res.alarms, (long long)res.steps, (long long)res.corrections,
          res.alarm_delay_s, res.final_error_deg, res.final_error_axes[0], res.final_error_axes[1],
          res.final_error_axes[2], res.worst_error_settled,
          res.monitor_ms.empty() ? 0.0 : res.monitor_ms[res.monitor_ms.size() / 2]);
      if (res.after_corrected.maps > 0)
        std::printf(
            "; E3D bad 2.0 / density: before the step %.2f / %.2f %% (%d maps); after it (after %.0f s without "
            "a step) on the same %d maps: uncorrected %.2f / %.2f %%, with the monitor's correction %.2f / %.2f "
            "%%, with the true one %.2f / %.2f %%",
            res.before.bad2(), res.before.density(), res.before.maps, kSettleS, res.after_corrected.maps,
            res.after_uncorrected.bad2(), res.after_uncorrected.density(), res.after_corrected.bad2(),
            res.after_corrected.density(), res.after_true.bad2(), res.after_true.density());
      std::printf("\n");
      std::fflush(stdout);
      results.push_back(res);
    }
    int64_t alarms = 0;
    double worst = 0, worst_delay = -1;
    for (const SeedResult& r : results) {
      alarms += r.alarms;
      worst = std::max(worst, r.worst_error_settled);
      worst_delay = std::max(worst_delay, r.alarm_delay_s);
    }
    std::printf("integrity: alarms %lld on %d seeds, worst correction error %.4f deg, alarm after %.2f s\n",
                (long long)alarms, seeds, worst, worst_delay);
    return 0;
  } catch (const ips::ArgError& e) {
    std::cerr << e.what() << "\n";  // names the program and the option
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "integrity_sim_eval: " << e.what() << "\n";
    return 2;
  }
}
