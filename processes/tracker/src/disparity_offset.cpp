#include "ips/tracker/disparity_offset.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ips::tracker {

double DisparityOffsetEstimator::sigma() const {
  if (!(weight_ > 0)) return std::numeric_limits<double>::infinity();
  const double c = mean(), n = count_;
  // sum w^2 (c_i - mean)^2 / (sum w)^2, unbiased by n / (n - 1).
  const double scatter = n > 1 ? (w2_sum2_ - 2 * c * w2_sum_ + c * c * w2_) / (weight_ * weight_) * n / (n - 1) : 0.0;
  return std::sqrt(std::max(1.0 / weight_, scatter));
}

DisparityOffsetEstimator::Outcome DisparityOffsetEstimator::add(double correction_px, double variance_px2) {
  Outcome out;
  // Gated against the prior, zero correction within prior_sigma_px, not against the round's average: a few alike
  // pairs of a still head (sigmas of 10-20 px, values tens of pixels off) or one wrong but believable pair would
  // otherwise become the average that refuses every pair after them. Pairs that pass enter with their weights, and
  // the average's sigma takes their scatter, so a stray pair delays an application rather than steering it.
  const double prior_px2 = params_.prior_sigma_px * params_.prior_sigma_px;
  if (correction_px * correction_px / (variance_px2 + prior_px2) > params_.gate_chi2) {
    out.refused = true;
    return out;
  }
  const double w = 1.0 / variance_px2;
  weighted_sum_ += w * correction_px;
  weight_ += w;
  w2_ += w * w;
  w2_sum_ += w * w * correction_px;
  w2_sum2_ += w * w * correction_px * correction_px;
  ++count_;
  out.observed = true;
  if (count_ >= params_.min_observations && std::abs(mean()) > params_.apply_sigmas * sigma()) {
    in_use_ = estimate();
    count_ = 0;
    weighted_sum_ = weight_ = w2_ = w2_sum_ = w2_sum2_ = 0;
    out.applied = true;
  }
  return out;
}

}  // namespace ips::tracker
