#pragma once
// Monte Carlo over seeds: the main job run once per seed (IPS_SEEDS), each run's figures per filter summarised. The
// end error (the paper's: the start known, nothing aligned after) by its mean, worst and spread over the seeds, the
// ATE by its mean, and the filter's consistency by the position NEES averaged over the seeds once per second, against
// the two-sided 95 % band of the average of N chi-square variables with 3 degrees of freedom (N seeds): the share of
// seconds inside it, as for the filter's own Monte Carlo (traj_eval --simulate).
#include <string>
#include <vector>

namespace ips::eval {

// One seed's run of one filter.
struct SeedFilterRun {
  double end_error_pct = 0;  // of the distance
  double end_error_m = 0;
  double ate_rmse_m = 0;
  std::vector<double> t;     // [s] since the run's first state (of any filter: the report's t0)
  std::vector<double> nees;  // position NEES (3 dof) at t; NaN where the covariance was missing
};

struct SeedSummary {
  int seeds = 0;
  double end_error_pct_mean = 0, end_error_pct_worst = 0, end_error_pct_std = 0;  // std: sample standard deviation
  double end_error_m_mean = 0;
  double ate_rmse_m_mean = 0;
  // The NEES averaged over the seeds at each whole second every seed covers, and its mean over those seconds.
  std::vector<double> nees_t, nees_mean_over_seeds;
  double anees = 0;
  double band_lo = 0, band_hi = 0;  // 95 % band of one second's average over the seeds
  double in_band_pct = 0;           // share of the seconds inside it
};

// Throws std::invalid_argument without runs.
SeedSummary summariseSeeds(const std::vector<SeedFilterRun>& runs, double step_s = 1.0);

// A run's NEES series as ips_report writes it (nees_<channel>.tsv: "t nees" per line, '#' comments). Throws
// std::runtime_error naming the file and line when it does not parse.
void readNeesSeries(const std::string& path, std::vector<double>& t, std::vector<double>& nees);

}  // namespace ips::eval
