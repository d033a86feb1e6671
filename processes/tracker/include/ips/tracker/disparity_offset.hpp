#pragma once
// The disparity offset's self-calibration over pairs (DisparityOffsetParams): the pairs' corrections
// (observeDisparityOffset, motion.hpp) are averaged with their inverse variances; the average replaces the offset in
// use once it has min_observations pairs and lies more than apply_sigmas of its sigmas from zero, and then begins
// anew against the new offset. A pair's correction falls somewhat short of the whole (its disparities are noisy,
// which dilutes the near/far contrast the offset is seen in); each round takes most of the rest of the way.
// Plain arithmetic on the pairs in the order given: replaying them gives the same schedule.
#include "ips/tracker/params.hpp"

namespace ips::tracker {

class DisparityOffsetEstimator {
 public:
  explicit DisparityOffsetEstimator(const DisparityOffsetParams& params)
      : params_(params), in_use_(params.initial_px) {}

  struct Outcome {
    bool observed = false;  // the correction entered the average
    bool refused = false;   // ... or the gate refused it
    bool applied = false;   // the average replaced the offset in use
  };
  // One pair's correction of the offset in use, with its variance [px^2].
  Outcome add(double correction_px, double variance_px2);

  double inUse() const { return in_use_; }
  // The offset in use plus the current round's average (the offset in use before any correction).
  double estimate() const { return in_use_ + mean(); }
  // The average's sigma: the larger of the pairs' variances' and the corrections' scatter's (on a real head the
  // pairs' variances can be too small, and a right offset must not be moved on their word). Infinite before the
  // round's first correction.
  double sigma() const;

 private:
  double mean() const { return weight_ > 0 ? weighted_sum_ / weight_ : 0.0; }
  DisparityOffsetParams params_;
  double in_use_ = 0;
  int count_ = 0;                             // corrections in this round
  double weighted_sum_ = 0, weight_ = 0;      // sum w c, sum w (w = 1 / a pair's variance)
  double w2_ = 0, w2_sum_ = 0, w2_sum2_ = 0;  // sum w^2, sum w^2 c, sum w^2 c^2
};

}  // namespace ips::tracker
