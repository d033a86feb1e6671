#pragma once
// The IPS estimator (paper section 4.3): fed message by message in arrival order, it buffers measurements for
// a configurable window, applies them in time order to the chosen filter (EKF or UKF), initialises itself at
// rest or, while the head moves, from the tracker's first deltas, clones the pose at image times so that tracker deltas
// are proper measurements, and queues the posterior states. No middleware: the process main converts LCM messages to
// and from these structs.
//
// Per message:
//   IMU sample   -> time update to its stamp + IMU measurement update (a full filter cycle), posterior output
//   tilt sample  -> time update + tilt measurement update
//   image time   -> the a-priori state at that time is returned at once (for the tracker's prediction);
//                   in time order the pose is cloned at that time
//   tracker delta-> measurement update on the two clones (may arrive late: the clones are kept), then its
//                   rotation from far points, if any, as a rotation-only update with its own gate
//                   (params far_rotation; a delta without a valid 6-DoF part may still carry one)
//   keyframe     -> the clone at that image time is kept beyond the image clones (E3D maps that pair)
//   cloud delta  -> measurement update on two keyframe clones (the alignment of two dense maps)
// Every measurement passes a chi-square gate on its Mahalanobis distance; counts per sensor.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <vector>

#include "ips/calibration.hpp"
#include "ips/filter/camera_delay.hpp"
#include "ips/filter/kalman.hpp"
#include "ips/filter/params.hpp"
#include "ips/filter/state.hpp"

namespace ips::filter {

struct ImuSample {  // ips::imu_sample_t
  int64_t utime = 0;
  Eigen::Vector3d angular_rate = Eigen::Vector3d::Zero();    // [rad/s], IMU frame
  Eigen::Vector3d specific_force = Eigen::Vector3d::Zero();  // [m/s^2], IMU frame
};

struct TiltSample {  // ips::tilt_sample_t
  int64_t utime = 0;
  double angle_x = 0;  // [rad], see TiltMeasurement for the convention
  double angle_y = 0;
};

struct TrackerDelta {  // ips::tracker_delta_t: X_c0(utime_prev) = R * X_c0(utime) + t
  int64_t utime = 0;
  int64_t utime_prev = 0;
  bool valid = true;
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Matrix6d covariance = Matrix6d::Identity();  // order tx ty tz rx ry rz
  // The rotation from far points alone (ips_tracker_delta_t far_*), a further, independent measurement.
  bool far_valid = false;
  Eigen::Quaterniond far_rotation = Eigen::Quaterniond::Identity();
  Eigen::Matrix3d far_covariance = Eigen::Matrix3d::Identity();
};

enum Sensor : int {
  kSensorImu = 0,
  kSensorTilt = 1,
  kSensorTracker = 2,
  kSensorImage = 3,
  kSensorFarRotation = 4,  // the tracker's rotation from far points (counted apart, gated on its own)
  kSensorCloud = 5,        // the alignment of two of E3D's dense maps (CLOUD_DELTA)
  kNumSensors = 6
};

struct SensorCounters {
  const char* name = "";
  int64_t accepted = 0;
  int64_t rejected = 0;  // by the Mahalanobis gate
  int64_t too_late = 0;  // older than what the reordering window still allows (or clone gone)
};

// One optional state as the filter estimates it (ips::calibration_estimate_t): the registry's name and unit
// (ips/filter/optional_states.hpp), the value (a rotation as its rotation vector) and its covariance block.
struct CalibrationEstimate {
  const char* name = "";
  const char* unit = "";
  Eigen::VectorXd value;
  Eigen::MatrixXd covariance;
  Eigen::VectorXd sigma() const { return covariance.diagonal().cwiseMax(0.0).cwiseSqrt(); }
};

// One to one ips::filter_state_t.
struct FilterOutput {
  NavState state;
  Matrix21d covariance = Matrix21d::Zero();
  // The frame of the state (FilterParams::output_frame) and the local vertical in it (unit; z in World). In Start the
  // covariance is that of the motion since the first image.
  OutputFrame frame = OutputFrame::World;
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  // The optional states the filter estimates (the head's calibration as it learns it), by id; empty where a state is
  // not estimated.
  std::array<std::optional<CalibrationEstimate>, kOptionalStateCount> calibration;
  FilterType type = FilterType::Ekf;
  bool a_priori = false;
  std::array<SensorCounters, kNumSensors> sensors;
};

// Diagonal initial covariance from the configured standard deviations (attitude: roll/pitch about world x, y,
// heading about z).
Matrix21d initialCovariance(const InitParams& init);

class Estimator {
 public:
  Estimator(const FilterParams& params, const StereoCalibration& calib);

  void addImu(const ImuSample& sample);
  void addTilt(const TiltSample& sample);
  // Returns the a-priori state at the image time (nullopt before initialisation or if the time is too old).
  std::optional<FilterOutput> addImageTime(int64_t utime);
  void addTrackerDelta(const TrackerDelta& delta);
  // E3D takes the pair at utime for a dense map: the pose clone at that time is kept (beside the image clones)
  // until the map's alignment with the next one has come.
  void addKeyframe(int64_t utime);
  // The alignment of the dense maps at utime_prev and utime (both keyframes), same convention as a tracker delta;
  // the far-rotation fields are not used.
  void addCloudDelta(const TrackerDelta& delta);
  // Applies everything still buffered (end of a log).
  void flush();

  // Starts the filter from a known state instead of the static initialisation (e.g. from ground truth). With the lever
  // arm estimated, its states start from the calibration (or keep what they have learnt, on a restart).
  void initialize(const NavState& state, const Matrix21d& covariance);
  bool initialized() const { return initialized_; }
  // How often the filter started while the head was moving (InitParams::in_motion).
  int64_t startsInMotion() const { return starts_in_motion_; }

  // Posterior states produced since the last call, oldest first.
  std::vector<FilterOutput> takeOutputs();
  FilterOutput current() const;
  const KalmanFilter& filter() const { return *run_.kf; }
  const std::array<SensorCounters, kNumSensors>& counters() const { return counters_; }
  int64_t imuGaps() const { return imu_gaps_; }
  // Measurements refused for a stamp beyond imu_silence_release_us ahead of the IMU's while the IMU sends (counted
  // as rejected of their sensor too).
  int64_t aheadOfImu() const { return ahead_of_imu_; }
  // Map alignments that arrived after the filter's time had passed their map's by cloud_apply_delay_us: applied at
  // once, so a replay may fuse them at another point than the live run did.
  int64_t cloudAppliedLate() const { return cloud_applied_late_; }
  // The camera's delay against the IMU as estimated online (FilterParams::camera_delay).
  const CameraDelayEstimator::Figures& cameraDelay() const { return camera_delay_.figures(); }
  const FilterParams& params() const { return params_; }

 private:
  struct Event {
    int64_t time = 0;  // latency-corrected
    Sensor sensor = kSensorImu;
    ImuSample imu;
    TiltSample tilt;
    TrackerDelta delta;
  };
  // The filter plus what its processing needs; copied to compute an a-priori state ahead of the buffer.
  struct Runner {
    std::unique_ptr<KalmanFilter> kf;
    int64_t last_imu_time = INT64_MIN;
    std::array<int, kNumSensors> consecutive_rejects{};
    bool in_gap = false;  // no IMU data for imu_gap_s: rates reset, milder process noise
    bool counts = false;  // the estimator's own runner (not a look-ahead copy): counts and logs
    MotionNoise motion{ProcessNoise{}, ImuNoise{}};  // the process noise the IMU's samples call for
  };

  // A tracker or cloud delta, checked, latency-corrected, applied at once (its clones exist) or buffered.
  void addDelta(const TrackerDelta& d, Sensor sensor);
  // Drops the clones no measurement can still use: all but the newest max_clones image clones and the newest
  // max_keyframe_clones keyframe clones.
  void pruneClones(KalmanFilter& kf);
  // Buffers a measurement; false when it was refused (too late, or ahead of the IMU).
  bool insert(Event&& e);
  void release(int64_t up_to);
  void process(const Event& e);
  void processInit(const Event& e);
  // The start on the mean specific force (no tracker deltas to start from).
  void initializeInMotion();
  // The start from the tracker's first deltas (ips/filter/motion_start.hpp) once they span the window; the events
  // since the chain's first image are then processed again. Returns true when the filter started.
  bool tryMotionStart();
  // The start state at the newest window sample: level from `specific_force_up`, configured position/heading.
  NavState startState(const Eigen::Vector3d& specific_force_up, double* roll, double* pitch) const;
  // Applies an IMU or tilt event to a runner; returns true if the measurement was applied.
  bool applyMeasurement(Runner& run, const Event& e, std::array<SensorCounters, kNumSensors>* counters);
  // Time update to t; enters the gap mode if the IMU has been silent for imu_gap_s by then.
  void predictTo(Runner& run, int64_t t);
  double gateFor(Runner& run, Sensor s, int dof, bool enabled) const;
  // Counts an update's outcome for its sensor (counters: the estimator's own, or null for a look-ahead copy) and
  // tracks the consecutive rejections the re-capture rule needs.
  static void countUpdate(Runner& run, Sensor s, bool applied, std::array<SensorCounters, kNumSensors>* counters);
  FilterOutput makeOutput(const KalmanFilter& kf, bool a_priori) const;

  FilterParams params_;
  Eigen::Isometry3d T_imu_cam0_;
  // The latency of each camera stamp: the configured one until the online estimate is certain.
  CameraDelayEstimator camera_delay_;
  Eigen::Matrix3d R_body_tilt_;
  double gyro_sigma_, accel_sigma_;
  double gate2_, gate6_;

  Runner run_;
  bool initialized_ = false;
  int64_t starts_in_motion_ = 0;
  std::multimap<int64_t, Event> buffer_;
  int64_t newest_time_ = INT64_MIN;      // of any sensor
  int64_t newest_imu_time_ = INT64_MIN;  // of the IMU
  int64_t processed_time_ = INT64_MIN;
  std::array<SensorCounters, kNumSensors> counters_;
  int64_t imu_gaps_ = 0;
  int64_t ahead_of_imu_ = 0;
  // Messages of the other sensors since the IMU's last; this many in a row mean the IMU has fallen silent (at
  // 200 Hz a few others come between two samples).
  static constexpr int kImuSilentMessages = 50;
  static constexpr size_t kMaxEventsBeforeImu = 4000;
  int non_imu_in_a_row_ = 0;
  int64_t cloud_applied_late_ = 0;
  int64_t imu_since_output_ = 0;
  std::vector<FilterOutput> outputs_;
  // The start frame's anchor (FilterParams::output_frame start): the first image time since the (re)start, and the
  // clone as it was taken then.
  int64_t anchor_utime_ = INT64_MIN;
  PoseClone start_pose_;
  // Keyframe times (latency-corrected) announced by E3D, newest last; bounded by the clones they can still pin.
  std::set<int64_t> keyframe_times_;
  // Image times a tracker delta has used as its earlier image: those clones wait for nothing more.
  std::set<int64_t> earlier_images_fused_;

  // Static initialisation.
  std::vector<ImuSample> init_imu_;
  std::vector<TiltSample> init_tilt_;
  // Before the start: every event in time order over the last seconds (IMU, tilt, image times, tracker deltas),
  // for the start from the tracker's deltas, which begins at their first image and processes them again.
  std::vector<Event> init_events_;
  bool tracker_seen_ = false;  // a valid tracker delta has come before the start
};

}  // namespace ips::filter
