#include "ips/eval/seeds.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "ips/filter/models.hpp"

namespace ips::eval {

namespace {

// The sample of a series nearest to time t (the series ascending in t); NaN for an empty one.
double nearest(const std::vector<double>& t, const std::vector<double>& v, double at) {
  if (t.empty()) return NAN;
  const auto it = std::lower_bound(t.begin(), t.end(), at);
  size_t i = static_cast<size_t>(it - t.begin());
  if (i == t.size() || (i > 0 && at - t[i - 1] < t[i] - at)) --i;
  return v[i];
}

}  // namespace

SeedSummary summariseSeeds(const std::vector<SeedFilterRun>& runs, double step_s) {
  if (runs.empty()) throw std::invalid_argument("summariseSeeds: no runs");
  if (!(step_s > 0)) throw std::invalid_argument("summariseSeeds: step must be positive");
  SeedSummary s;
  s.seeds = static_cast<int>(runs.size());
  const double n = static_cast<double>(runs.size());
  for (const SeedFilterRun& r : runs) {
    s.end_error_pct_mean += r.end_error_pct / n;
    s.end_error_m_mean += r.end_error_m / n;
    s.ate_rmse_m_mean += r.ate_rmse_m / n;
    s.end_error_pct_worst = std::max(s.end_error_pct_worst, r.end_error_pct);
  }
  double ss = 0;
  for (const SeedFilterRun& r : runs)
    ss += (r.end_error_pct - s.end_error_pct_mean) * (r.end_error_pct - s.end_error_pct_mean);
  s.end_error_pct_std = runs.size() > 1 ? std::sqrt(ss / (n - 1)) : 0.0;

  // Seconds every run covers.
  double end = INFINITY;
  for (const SeedFilterRun& r : runs) end = std::min(end, r.t.empty() ? 0.0 : r.t.back());
  const int k = static_cast<int>(runs.size());
  s.band_lo = filter::chiSquareQuantile(0.025, 3 * k) / n;
  s.band_hi = filter::chiSquareQuantile(0.975, 3 * k) / n;
  int inside = 0;
  for (int second = 1; second * step_s <= end + 1e-9; ++second) {
    const double at = second * step_s;
    double sum = 0;
    bool all = true;
    for (const SeedFilterRun& r : runs) {
      const double v = nearest(r.t, r.nees, at);
      if (!std::isfinite(v)) {
        all = false;
        break;
      }
      sum += v;
    }
    if (!all) continue;
    const double mean = sum / n;
    s.nees_t.push_back(at);
    s.nees_mean_over_seeds.push_back(mean);
    s.anees += mean;
    inside += mean >= s.band_lo && mean <= s.band_hi ? 1 : 0;
  }
  if (!s.nees_t.empty()) {
    s.anees /= static_cast<double>(s.nees_t.size());
    s.in_band_pct = 100.0 * inside / static_cast<double>(s.nees_t.size());
  } else {
    s.anees = NAN;
    s.in_band_pct = NAN;
  }
  return s;
}

void readNeesSeries(const std::string& path, std::vector<double>& t, std::vector<double>& nees) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  t.clear();
  nees.clear();
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    std::string a, b;
    if (!(ss >> a >> b)) throw std::runtime_error(path + ":" + std::to_string(number) + ": expected 't nees'");
    try {
      size_t used_a = 0, used_b = 0;
      const double ta = std::stod(a, &used_a);
      const double vb = b == "nan" ? NAN : std::stod(b, &used_b);
      if (used_a != a.size() || (b != "nan" && used_b != b.size())) throw std::invalid_argument("trailing");
      if (!t.empty() && !(ta >= t.back())) throw std::invalid_argument("time goes back");
      t.push_back(ta);
      nees.push_back(vb);
    } catch (const std::exception& e) {
      throw std::runtime_error(path + ":" + std::to_string(number) + ": " + e.what() + " in '" + line + "'");
    }
  }
}

}  // namespace ips::eval
