#pragma once
// The system's LCM channel names, in one place. Drivers and the simulator publish the same sensor channels.
#include <string>

namespace ips::channels {
inline constexpr const char* kStereo = "STEREO";               // ips::stereo_pair_t (bulk bus)
inline constexpr const char* kStereoTime = "STEREO_TIME";      // ips::stereo_time_t, the stamp of each STEREO
inline constexpr const char* kImu = "IMU";                     // ips::imu_sample_t
inline constexpr const char* kTilt = "TILT";                   // ips::tilt_sample_t
inline constexpr const char* kTrackerDelta = "TRACKER_DELTA";  // ips::tracker_delta_t
inline constexpr const char* kFilterState = "FILTER_STATE";    // ips::filter_state_t, a posteriori
inline constexpr const char* kFilterPrior = "FILTER_PRIOR";    // ips::filter_state_t, a priori at image times
// ips::stereo_time_t: an image time the filter has no a-priori state for (not started yet, or the stamp came too late),
// so that the tracker waits for the filter's answer to every pair, not for a prior that is not coming.
inline constexpr const char* kFilterPriorNone = "FILTER_PRIOR_NONE";
inline constexpr const char* kDisparity = "DISPARITY";       // ips::disparity_map_t
inline constexpr const char* kIntegrity = "INTEGRITY";       // ips::integrity_t (epipolar integrity, tracker)
inline constexpr const char* kKeyframe = "KEYFRAME";         // ips::keyframe_t, a pair e3d takes for a map
inline constexpr const char* kCloudDelta = "CLOUD_DELTA";    // ips::tracker_delta_t, map-to-map alignment (mapper)
inline constexpr const char* kPoints = "POINTS";             // ips::point_cloud_t
inline constexpr const char* kMonoPoints = "MONO_POINTS";    // ips::point_cloud_t, depth from one camera (e3d)
inline constexpr const char* kGtPose = "GT_POSE";            // ips::ground_truth_t (simulator only)
inline constexpr const char* kGtDisparity = "GT_DISPARITY";  // ips::disparity_map_t (simulator only)
inline constexpr const char* kHealthPrefix = "HEALTH_";      // + upper-case process name: ips::health_t

// The channels of the bulk bus (processes/framework/README.md, "Two buses"): images and dense products, megabytes
// a message. Everything else (IMU, tilt, the tracker's deltas, the filters' states, health, procman) is small and
// travels on the control bus, so that a process reading IMU samples never has image datagrams in its socket. A
// channel pattern ("POINTS.*") is bulk when the channels it matches are.
inline bool isBulkChannel(const std::string& channel) {
  return channel == kStereo || channel == kDisparity || channel == kGtDisparity || channel == kMonoPoints ||
         channel.rfind(kPoints, 0) == 0;
}
}  // namespace ips::channels
