#pragma once
// The E3D process's LCM side: STEREO, INTEGRITY and FILTER_STATE in; DISPARITY, KEYFRAME and MONO_POINTS out; the
// worker thread that matches. Which pair is matched when is StereoJobQueue's decision, which exposures make a map from
// one camera MonoPairing's.
#include <condition_variable>
#include <deque>
#include <ips/filter_state_t.hpp>
#include <ips/integrity_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <mutex>
#include <optional>
#include <thread>

#include "ips/calibration.hpp"
#include "ips/e3d/mono_depth.hpp"
#include "ips/e3d/mono_pairing.hpp"
#include "ips/e3d/stereo_jobs.hpp"
#include "ips/e3d/stereo_matcher.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/validate.hpp"

namespace ips::e3d_app {

class E3dProcess {
 public:
  E3dProcess(fw::Node& node, const StereoCalibration& calib, e3d::StereoMatcher& matcher,
             const StereoRectification& rect, const e3d::ProcessParams& params, e3d::MonoDepth* mono);
  ~E3dProcess() { stop(true); }

  // Stops the worker; with drain, the queued pairs are matched first. Call after the node's loop has returned: maps
  // still waiting for the filter's pose then never get it.
  void stop(bool drain);

 private:
  void onStereo(const stereo_pair_t& m);
  // LCM thread: the maps whose later exposure the filter has passed go to the worker with both poses.
  void onFilterState(const filter_state_t& m);
  // Maps from one camera that the pairing released: onto the worker's queue; its losses into the health.
  void queueMono(e3d::MonoPairing::Released released);
  void onIntegrity(const integrity_t& m);
  // Before matching a pair: the rectification of the newest correction decided before it.
  void rectifyFor(int64_t utime);
  void work();
  // Worker: the map from one camera, its points placed in the world with the filter's pose of the earlier exposure.
  void runMono(const e3d::MonoJob& job);
  void publish(const e3d::StereoJob& job, const cv::Mat& disparity);

  fw::Node& node_;
  e3d::StereoMatcher& matcher_;
  StereoCalibration calib_;
  double scale_;
  StereoRectification rect_;
  RightCorrectionSchedule corrections_;     // guarded by mutex_
  RightCameraCorrection corrections_told_;  // guarded by mutex_: the newest in the schedule
  int64_t last_stereo_utime_ = 0;           // LCM thread only
  RightCameraCorrection in_use_;            // worker only
  fw::StereoAdmission admission_;
  e3d::MonoDepth* mono_;                     // null: no depth from one camera
  std::optional<e3d::MonoPairing> pairing_;  // LCM thread; with mono_
  std::deque<e3d::MonoJob> mono_ready_;      // guarded by mutex_
  std::mutex mutex_;
  std::condition_variable cv_;
  e3d::StereoJobQueue jobs_;  // guarded by mutex_
  bool stopping_ = false;
  std::thread worker_;
};

}  // namespace ips::e3d_app
