#include "ips/drivers/clock_mapper.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace ips::drivers {

ClockMapper::ClockMapper(ClockMapperConfig config) : config_(config) {
  if (config_.window < 2) throw std::invalid_argument("ClockMapper: window must be >= 2");
}

void ClockMapper::reset() {
  pairs_.clear();
  slope_ = 1.0;
  offset_ = 0.0;
}

int64_t ClockMapper::map(int64_t device_us) const {
  if (pairs_.empty()) throw std::logic_error("ClockMapper::map before any update");
  const double d = static_cast<double>(device_us - device_ref_);
  return arrival_ref_ + static_cast<int64_t>(std::llround(offset_ + slope_ * d));
}

int64_t ClockMapper::update(int64_t device_us, int64_t arrival_us) {
  if (!pairs_.empty()) {
    const int64_t predicted = map(device_us);
    const int64_t err = arrival_us - predicted;
    // A device clock that restarted or jumped, or time going backwards on the device: start again.
    if (err > config_.reset_jump_us || err < -config_.reset_jump_us || device_us < device_ref_) {
      reset();
      ++resets_;
    }
  }
  if (pairs_.empty()) {
    device_ref_ = device_us;
    arrival_ref_ = arrival_us;
  }
  pairs_.push_back(
      ClockMapperPoint{static_cast<double>(device_us - device_ref_), static_cast<double>(arrival_us - arrival_ref_)});
  if (pairs_.size() > config_.window) pairs_.pop_front();
  refit();
  return map(device_us);
}

namespace {

// Least-squares slope of arrival over device time for the points with keep[i].
double fitSlope(const std::deque<ClockMapperPoint>& pts, const std::vector<char>& keep) {
  double n = 0, md = 0, ma = 0;
  for (size_t i = 0; i < pts.size(); ++i)
    if (keep[i]) {
      md += pts[i].device;
      ma += pts[i].arrival;
      ++n;
    }
  if (n < 2) return 1.0;
  md /= n;
  ma /= n;
  double sdd = 0, sda = 0;
  for (size_t i = 0; i < pts.size(); ++i)
    if (keep[i]) {
      sdd += (pts[i].device - md) * (pts[i].device - md);
      sda += (pts[i].device - md) * (pts[i].arrival - ma);
    }
  return sdd > 0 ? sda / sdd : 1.0;
}

}  // namespace

void ClockMapper::refit() {
  const size_t n = pairs_.size();
  double slope = 1.0;
  if (n >= config_.min_pairs_for_drift) {
    // Latency is a floor plus a one-sided tail (and the odd frame stuck behind other traffic). A plain fit
    // follows the tail; refitting on the points below the median residual follows the floor.
    std::vector<char> keep(n, 1);
    slope = fitSlope(pairs_, keep);
    std::vector<double> residual(n);
    for (int iteration = 0; iteration < 2; ++iteration) {
      for (size_t i = 0; i < n; ++i) residual[i] = pairs_[i].arrival - slope * pairs_[i].device;
      std::vector<double> sorted = residual;
      std::nth_element(sorted.begin(), sorted.begin() + n / 2, sorted.end());
      const double median = sorted[n / 2];
      for (size_t i = 0; i < n; ++i) keep[i] = residual[i] <= median;
      slope = fitSlope(pairs_, keep);
    }
    const double max_dev = config_.max_drift_ppm * 1e-6;
    slope = std::clamp(slope, 1.0 - max_dev, 1.0 + max_dev);
  }
  slope_ = slope;
  double lowest = INFINITY;
  for (const auto& p : pairs_) lowest = std::min(lowest, p.arrival - slope * p.device);
  offset_ = lowest;
}

}  // namespace ips::drivers
