#include "ips/calib/delay_estimation.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ips::calib {
namespace {

// The integral of the gyro (trapezoids between samples) from the first sample, to average over any interval.
class GyroIntegral {
 public:
  explicit GyroIntegral(const std::vector<GyroSample>& g) : g_(g), cum_(g.size(), Eigen::Vector3d::Zero()) {
    for (size_t i = 1; i < g.size(); ++i)
      cum_[i] = cum_[i - 1] + 0.5 * (g[i].rate + g[i - 1].rate) * ((g[i].utime - g[i - 1].utime) * 1e-6);
  }
  bool covers(double t0, double t1) const { return t0 >= g_.front().utime && t1 <= g_.back().utime; }
  Eigen::Vector3d at(double t) const {
    auto it = std::upper_bound(g_.begin(), g_.end(), t, [](double v, const GyroSample& s) { return v < s.utime; });
    size_t i = static_cast<size_t>(it - g_.begin());
    if (i == 0) return cum_[0];
    if (i >= g_.size()) return cum_.back();
    const GyroSample& a = g_[i - 1];
    const GyroSample& b = g_[i];
    const double h = (t - a.utime) * 1e-6;
    const double span = (b.utime - a.utime) * 1e-6;
    const Eigen::Vector3d rate_t = a.rate + (b.rate - a.rate) * (span > 0 ? h / span : 0.0);
    return cum_[i - 1] + 0.5 * (a.rate + rate_t) * h;
  }

 private:
  const std::vector<GyroSample>& g_;
  std::vector<Eigen::Vector3d> cum_;
};

double pearson(const std::vector<double>& a, const std::vector<double>& b) {
  const size_t n = a.size();
  if (n < 3) return 0;
  double ma = 0, mb = 0;
  for (size_t i = 0; i < n; ++i) {
    ma += a[i];
    mb += b[i];
  }
  ma /= n;
  mb /= n;
  double sab = 0, saa = 0, sbb = 0;
  for (size_t i = 0; i < n; ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
  }
  return saa > 0 && sbb > 0 ? sab / std::sqrt(saa * sbb) : 0;
}

}  // namespace

DelayEstimate estimateCameraImuDelay(const std::vector<GyroSample>& gyro_in, const std::vector<TrackerRotation>& deltas,
                                     const DelayEstimatorConfig& config) {
  if (config.step_us <= 0 || config.max_delay_us < config.step_us)
    throw std::invalid_argument("delay estimation: need step_us > 0 and max_delay_us >= step_us");
  DelayEstimate result;
  std::vector<GyroSample> gyro = gyro_in;
  std::sort(gyro.begin(), gyro.end(), [](const GyroSample& a, const GyroSample& b) { return a.utime < b.utime; });
  gyro.erase(std::unique(gyro.begin(), gyro.end(),
                         [](const GyroSample& a, const GyroSample& b) { return a.utime == b.utime; }),
             gyro.end());
  if (gyro.size() < 2) return result;
  const GyroIntegral integral(gyro);

  // Tracker magnitudes |log(R)| / dt. Intervals that the gyro does not cover at every candidate delay are
  // left out, so that all candidates are compared on the same intervals.
  struct Interval {
    double t0, t1, magnitude;
  };
  std::vector<Interval> intervals;
  for (const auto& d : deltas) {
    const double dt = (d.utime - d.utime_prev) * 1e-6;
    if (!(dt > 0)) continue;
    const double t0 = static_cast<double>(d.utime_prev), t1 = static_cast<double>(d.utime);
    if (!integral.covers(t0 - config.max_delay_us - config.step_us, t1 + config.max_delay_us + config.step_us))
      continue;
    const Eigen::AngleAxisd aa(d.rotation.normalized());
    const double magnitude = std::fabs(aa.angle()) / dt;
    if (!std::isfinite(magnitude) || magnitude < config.min_rate) continue;
    intervals.push_back({t0, t1, magnitude});
  }
  result.intervals = intervals.size();
  if (intervals.size() < config.min_intervals) return result;

  std::vector<double> camera(intervals.size()), imu(intervals.size());
  for (size_t i = 0; i < intervals.size(); ++i) camera[i] = intervals[i].magnitude;
  auto correlationAt = [&](double delay) {
    for (size_t i = 0; i < intervals.size(); ++i) {
      const double a = intervals[i].t0 - delay, b = intervals[i].t1 - delay;
      imu[i] = ((integral.at(b) - integral.at(a)) / ((b - a) * 1e-6)).norm();
    }
    return pearson(camera, imu);
  };
  size_t best = 0;
  for (int64_t d = -config.max_delay_us; d <= config.max_delay_us; d += config.step_us) {
    result.curve.emplace_back(static_cast<double>(d), correlationAt(static_cast<double>(d)));
    if (result.curve.back().second > result.curve[best].second) best = result.curve.size() - 1;
  }
  // Refinement: a fine grid (a tenth of the step) around the coarse maximum, then a parabola through the best
  // fine point and its neighbours.
  double delay = result.curve[best].first;
  if (best > 0 && best + 1 < result.curve.size()) {
    const double fine = config.step_us / 10.0;
    double best_c = -2, best_d = delay;
    std::vector<std::pair<double, double>> fine_curve;
    for (int i = -10; i <= 10; ++i) {
      const double d = delay + i * fine;
      fine_curve.emplace_back(d, correlationAt(d));
      if (fine_curve.back().second > best_c) {
        best_c = fine_curve.back().second;
        best_d = d;
      }
    }
    delay = best_d;
    const size_t k = static_cast<size_t>(std::llround((best_d - fine_curve.front().first) / fine));
    if (k > 0 && k + 1 < fine_curve.size()) {
      const double ym = fine_curve[k - 1].second, y0 = fine_curve[k].second, yp = fine_curve[k + 1].second;
      const double denom = ym - 2 * y0 + yp;
      if (denom < 0) delay += 0.5 * (ym - yp) / denom * fine;
    }
  }
  result.delay_us = delay;
  result.correlation = correlationAt(delay);
  result.ok = best > 0 && best + 1 < result.curve.size();  // a maximum at the edge of the range is not a maximum
  return result;
}

}  // namespace ips::calib
