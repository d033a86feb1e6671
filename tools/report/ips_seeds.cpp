// ips_seeds: the main job over several seeds (IPS_SEEDS=N ./tools/main_job.sh) summarised. Reads each run's
// report.json (the filters' end error and ATE) and nees_<channel>.tsv, and writes seeds.json: per filter the end
// error's mean, worst and spread over the seeds, the mean ATE, and the position NEES averaged over the seeds once per
// second against its 95 % band (ips/eval/seeds.hpp). The last line is
// `seeds=N ekf_end_pct_mean=... ekf_end_pct_worst=... ekf_anees=... ukf_end_pct_mean=... ...`.
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "ips/args.hpp"
#include "ips/eval/seeds.hpp"

namespace {

std::vector<std::string> splitList(const std::string& list) {
  std::vector<std::string> out;
  std::stringstream ss(list);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

double numberOr(const nlohmann::json& j, const char* key) {
  return j.contains(key) && j[key].is_number() ? j[key].get<double>() : NAN;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    ips::Args args(argc, argv, "The main job over several seeds: end error and NEES per filter over the seeds");
    args.required("--runs", "DIR,DIR,...", "the runs' output folders (report.json, nees_<channel>.tsv)")
        .required("--out", "FILE", "the summary (seeds.json)");
    if (!args.parse()) return 0;
    const std::vector<std::string> dirs = splitList(args.get("--runs"));
    if (dirs.empty()) throw std::invalid_argument("--runs: no folder given");
    // Per filter name (ekf, ukf): its runs, in the order of the folders.
    std::map<std::string, std::vector<ips::eval::SeedFilterRun>> by_filter;
    for (const std::string& dir : dirs) {
      std::ifstream in(dir + "/report.json");
      if (!in) throw std::runtime_error(dir + "/report.json: cannot open");
      nlohmann::json report;
      try {
        in >> report;
      } catch (const nlohmann::json::exception& e) {
        throw std::runtime_error(dir + "/report.json: " + e.what());
      }
      if (!report.contains("filters") || !report["filters"].is_array())
        throw std::runtime_error(dir + "/report.json: no 'filters' list");
      for (const nlohmann::json& f : report["filters"]) {
        if (!f.contains("filter") || !f.contains("channel")) continue;
        ips::eval::SeedFilterRun run;
        run.end_error_pct = numberOr(f, "end_error_pct");
        run.end_error_m = numberOr(f, "end_error_m");
        run.ate_rmse_m = numberOr(f, "ate_rmse_m");
        ips::eval::readNeesSeries(dir + "/nees_" + f["channel"].get<std::string>() + ".tsv", run.t, run.nees);
        by_filter[f["filter"].get<std::string>()].push_back(std::move(run));
      }
    }
    if (by_filter.empty()) throw std::runtime_error("no filter ran in any of the runs");
    nlohmann::json summary;
    summary["seeds"] = dirs.size();
    summary["runs"] = dirs;
    std::string last = "seeds=" + std::to_string(dirs.size());
    for (const auto& [name, runs] : by_filter) {
      if (runs.size() != dirs.size())
        throw std::runtime_error("filter " + name + " ran in " + std::to_string(runs.size()) + " of " +
                                 std::to_string(dirs.size()) + " runs");
      const ips::eval::SeedSummary s = ips::eval::summariseSeeds(runs);
      summary["filters"].push_back({{"filter", name},
                                    {"end_error_pct_mean", s.end_error_pct_mean},
                                    {"end_error_pct_worst", s.end_error_pct_worst},
                                    {"end_error_pct_std", s.end_error_pct_std},
                                    {"end_error_m_mean", s.end_error_m_mean},
                                    {"ate_rmse_m_mean", s.ate_rmse_m_mean},
                                    {"nees_position_mean_over_seeds", s.anees},
                                    {"nees_95_band_of_the_mean", {s.band_lo, s.band_hi}},
                                    {"nees_seconds_in_band_pct", s.in_band_pct},
                                    {"nees_seconds", s.nees_t.size()}});
      std::printf(
          "%s: end error mean %.3f %% worst %.3f %% (std %.3f) over %d seeds, ATE mean %.4f m, position NEES averaged "
          "over the seeds %.2f, %.0f %% of %zu seconds in its 95 %% band [%.2f, %.2f]\n",
          name.c_str(), s.end_error_pct_mean, s.end_error_pct_worst, s.end_error_pct_std, s.seeds, s.ate_rmse_m_mean,
          s.anees, s.in_band_pct, s.nees_t.size(), s.band_lo, s.band_hi);
      char buf[200];
      std::snprintf(buf, sizeof buf, " %s_end_pct_mean=%.4f %s_end_pct_worst=%.4f %s_anees=%.3f", name.c_str(),
                    s.end_error_pct_mean, name.c_str(), s.end_error_pct_worst, name.c_str(), s.anees);
      last += buf;
    }
    std::ofstream out(args.get("--out"));
    if (!out) throw std::runtime_error(args.get("--out") + ": cannot write");
    out << summary.dump(2) << "\n";
    std::printf("%s\n", last.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ips_seeds: %s\n", e.what());
    return 1;
  }
}
