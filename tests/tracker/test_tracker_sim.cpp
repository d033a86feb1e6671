// The tracker on the simulated sensor head (ips_sim, config/sim_walk.yaml: raw distorted 1360x1024 pairs with
// noise and different gains, the head's true calibration) against the ground-truth motion of camera 0.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

#include "../../tools/tracker/sim_eval.hpp"

using namespace ips::tracker;

TEST(TrackerSim, WalkRelativePoseErrorPerFrame) {
  // The default walk (config/sim_walk.yaml holds its defaults) without the still start, so that the 2.5 s
  // tracked here are walking.
  const std::string scenario = testing::TempDir() + "/walk_without_still_start.yaml";
  {
    FILE* f = std::fopen(scenario.c_str(), "w");
    ASSERT_NE(f, nullptr);
    std::fputs("%YAML:1.0\n---\ntrajectory:\n  start_still_s: 0\n", f);
    std::fclose(f);
  }
  std::vector<double> rot, pct;
  const auto errors = tools::runTrackerOnSimulation(scenario, 2.5, TrackerParams(), tools::SimPrior::ConstantVelocity);
  ASSERT_EQ(errors.size(), 20u);  // 8 Hz
  for (const auto& e : errors) {
    ASSERT_TRUE(e.result.valid) << "frame " << e.frame;
    EXPECT_LT(e.rot_err_deg, 0.1) << "frame " << e.frame;
    // 3 % of the step, with 1 mm allowed for the first, tiny steps of the start.
    EXPECT_LT(e.trans_err_m, 0.03 * e.step_m + 0.001) << "frame " << e.frame;
    EXPECT_GT(e.result.num_inliers, 100);
    rot.push_back(e.rot_err_deg);
    if (e.step_m > 0.02) pct.push_back(100 * e.trans_err_m / e.step_m);
  }
  std::sort(rot.begin(), rot.end());
  std::sort(pct.begin(), pct.end());
  ASSERT_FALSE(pct.empty());
  std::printf(
      "[ SIM      ] %zu pairs: rotation error median %.4f max %.4f deg; translation error median %.2f max %.2f %%\n",
      errors.size(), rot[rot.size() / 2], rot.back(), pct[pct.size() / 2], pct.back());
}
