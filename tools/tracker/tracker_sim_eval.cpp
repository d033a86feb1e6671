// Relative pose error per frame of the tracker on a simulated scenario (default config/sim_walk.yaml's
// built-in defaults: the paper's walk through a building, 1360x1024 at 8 Hz).
//   tracker_sim_eval [--scenario config/sim_walk.yaml] [--duration SECONDS (10)] [--params config/tracker.yaml]
//                    [--prior cv|imu|none (cv)] [--quiet 1]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>

#include "common.hpp"
#include "sim_eval.hpp"

using namespace ips::tracker;

int main(int argc, char** argv) {
  try {
    auto opts = tools::parseOptions(argc, argv, 1);
    if (opts.count("help")) {
      std::cout << "usage: tracker_sim_eval [--scenario FILE.yaml] [--duration S (10)] [--params P]"
                   " [--prior cv|imu|none] [--quiet 1]\n";
      return 0;
    }
    const double duration = opts.count("duration") ? std::stod(opts["duration"]) : 10.0;
    const TrackerParams params = opts.count("params") ? loadTrackerParams(opts["params"]) : TrackerParams();
    const std::string prior_name = opts.count("prior") ? opts["prior"] : "cv";
    tools::SimPrior prior = tools::SimPrior::ConstantVelocity;
    if (prior_name == "imu")
      prior = tools::SimPrior::Imu;
    else if (prior_name == "none")
      prior = tools::SimPrior::None;
    else if (prior_name != "cv")
      throw std::invalid_argument("--prior must be cv, imu or none");
    const bool quiet = opts.count("quiet") && opts["quiet"] != "0";
    if (!quiet)
      std::printf("frame valid step_m step_deg rot_err_deg trans_err_m trans_err_pct inliers prior_ok total_ms\n");
    const auto errors = tools::runTrackerOnSimulation(
        opts.count("scenario") ? opts["scenario"] : "", duration, params, prior, [&](const tools::SimFrameError& e) {
          if (quiet) return;
          std::printf("%5lld %d %.4f %.3f %.4f %.4f %.2f %d %d %.1f\n", (long long)e.frame, int(e.result.valid),
                      e.step_m, e.step_deg, e.rot_err_deg, e.trans_err_m,
                      e.step_m > 0 ? 100 * e.trans_err_m / e.step_m : 0.0, e.result.num_inliers, int(e.result.prior_ok),
                      e.result.times.total);
        });
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
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tracker_sim_eval: %s\n", e.what());
    return 1;
  }
}
