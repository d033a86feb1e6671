#pragma once
// The tracker's LCM side: STEREO, FILTER_PRIOR, IMU and DISPARITY in, converted to ips_tracker's plain types;
// TRACKER_DELTA and INTEGRITY out; health counts. When a pair goes on is PairScheduler's decision.
#include <ips/disparity_map_t.hpp>
#include <ips/filter_state_t.hpp>
#include <ips/imu_sample_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <ips/stereo_time_t.hpp>

#include "ips/calibration.hpp"
#include "ips/config.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/validate.hpp"
#include "ips/tracker/epipolar_integrity.hpp"
#include "ips/tracker/pair_scheduler.hpp"
#include "ips/tracker/params.hpp"
#include "ips/tracker/prior_builder.hpp"
#include "ips/tracker/stereo_tracker.hpp"

namespace ips::tracker_app {

class TrackerProcess {
 public:
  TrackerProcess(fw::Node& node, const StereoCalibration& calib, const tracker::TrackerParams& params,
                 const tracker::IntegrityParams& integrity, const tracker::PriorBuilderParams& prior_builder,
                 const tracker::DisparityWait& wait);

  // End of input: whatever still waits for a prior is tracked with the fallback.
  void flush();
  // Goes on with the pending pairs once the socket holds nothing more (called after every handled message).
  void drain();

 private:
  void onStereo(const stereo_pair_t& m);
  void onPrior(const filter_state_t& m);
  void onPriorNone(const stereo_time_t& m);
  void onDisparity(const disparity_map_t& m);
  void onImu(const imu_sample_t& m);
  void processOldest();
  void checkIntegrity(const tracker::PendingPair& p);

  fw::Node& node_;
  tracker::StereoTracker tracker_;
  tracker::EpipolarMonitor monitor_;
  tracker::PriorBuilder priors_;
  fw::StereoAdmission admission_;
  tracker::PairScheduler pairs_;
  fw::StreamOrder disparity_order_;
};

}  // namespace ips::tracker_app
