#pragma once
// The system's LCM channel names, in one place. Drivers and the simulator publish the same sensor channels.
namespace ips::channels {
inline constexpr const char* kStereo = "STEREO";               // ips::stereo_pair_t
inline constexpr const char* kImu = "IMU";                     // ips::imu_sample_t
inline constexpr const char* kTilt = "TILT";                   // ips::tilt_sample_t
inline constexpr const char* kTrackerDelta = "TRACKER_DELTA";  // ips::tracker_delta_t
inline constexpr const char* kFilterState = "FILTER_STATE";    // ips::filter_state_t, a posteriori
inline constexpr const char* kFilterPrior = "FILTER_PRIOR";    // ips::filter_state_t, a priori at image times
inline constexpr const char* kDisparity = "DISPARITY";         // ips::disparity_map_t
inline constexpr const char* kIntegrity = "INTEGRITY";         // ips::integrity_t (epipolar integrity, tracker)
inline constexpr const char* kKeyframe = "KEYFRAME";           // ips::keyframe_t, a pair e3d takes for a map
inline constexpr const char* kCloudDelta = "CLOUD_DELTA";      // ips::tracker_delta_t, map-to-map alignment (mapper)
inline constexpr const char* kPoints = "POINTS";               // ips::point_cloud_t
inline constexpr const char* kMonoPoints = "MONO_POINTS";      // ips::point_cloud_t, depth from one camera (e3d)
inline constexpr const char* kGtPose = "GT_POSE";              // ips::ground_truth_t (simulator only)
inline constexpr const char* kGtDisparity = "GT_DISPARITY";    // ips::disparity_map_t (simulator only)
inline constexpr const char* kHealthPrefix = "HEALTH_";        // + upper-case process name: ips::health_t
}  // namespace ips::channels
