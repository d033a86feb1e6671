#pragma once
// Parameters of the IPS filter, read from the `filter` section of a YAML file (config/filter.yaml documents
// every key). Defaults are the paper's sensor head: Systron Donner MMQ-50 IMU at 200 Hz, PEI Z260 tilt sensor.
#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>

#include "ips/calibration.hpp"
#include "ips/config.hpp"

namespace ips::filter {

enum class FilterType { Ekf = 1, Ukf = 2 };  // values as filter_state_t.FILTER_EKF / FILTER_UKF

struct ProcessNoise {
  // The kinematic model holds acceleration and angular rate as states driven by white noise. With from_imu these
  // two are floors under what the IMU's own samples show of the head's motion (MotionNoise, models.hpp).
  double jerk_psd = 4.0;              // [m^2/s^5] spectral density of the jerk driving the acceleration
  double angular_accel_psd = 20.0;    // [rad^2/s^3] spectral density of the angular acceleration (head motion)
  double accel_bias_psd = 1e-8;       // [m^2/s^5] accelerometer bias random walk
  double gyro_bias_psd = 1e-12;       // [rad^2/s^3] gyro bias random walk
  double delta_scale_psd = 1e-7;      // [1/s] random walk of the tracker's scale error, when estimated: the tracker's
                                      // disparity offset changes in steps (each application) and the scale it leaves
                                      // with the scene's depths (offset / disparity): 0.2 % in a minute
  double delta_direction_psd = 1e-8;  // [rad^2/s] random walk of the turn of the tracker's steps, when estimated:
                                      // it follows the scene, whose depths and their spread across the image change
                                      // as the head walks on (1 mrad in two minutes)
  double delta_rotation_drift_psd = 1e-10;  // [(rad/m)^2/s] random walk of the tracker's rotation drift, when
                                            // estimated: it follows the scene too (0.1 mrad/m in two minutes)
  // The jerk and angular acceleration densities measured from the IMU's sample-to-sample differences over the last
  // from_imu_window_s, where they exceed the configured ones: a flying MAV's vibration moves the specific force by
  // 1-2 m/s^2 from one 5 ms sample to the next (EuRoC V1_01: 130-800 m^2/s^5), a carried head's by 0.1 (MH_01's
  // first 150 frames: 0.6-1.5); with a walker's density the filter's gate refused 70 % of such an IMU's samples.
  // That excess is vibration: large accelerations of little velocity and displacement (2 m/s^2 at 100 Hz is 3 mm/s),
  // so it enters the acceleration and angular rate states alone, not their integrals (vibration_*_psd, set by
  // MotionNoise; zero in a configuration).
  bool from_imu = true;
  double from_imu_window_s = 1.0;
  double vibration_jerk_psd = 0;           // [m^2/s^5] on the acceleration state only
  double vibration_angular_accel_psd = 0;  // [rad^2/s^3] on the angular rate state only
};

struct ImuNoise {
  // MMQ-50: angle random walk 0.005 deg/s/rtHz, velocity random walk 0.5 mg/rtHz.
  double gyro_noise_density = 8.7e-5;   // [rad/s/sqrt(Hz)]
  double accel_noise_density = 4.9e-3;  // [m/s^2/sqrt(Hz)]
  double rate_hz = 200.0;               // nominal sample rate: discrete sigma = density * sqrt(rate)
};

struct InitParams {
  double duration_s = 2.0;     // time at rest averaged for the static initialisation
  double max_accel_std = 0.3;  // [m/s^2] above this the head is not at rest: the window restarts
  double max_gyro_std = 0.02;  // [rad/s]  (MMQ-50 noise alone: 0.07 m/s^2, 1.2e-3 rad/s per sample)
  double heading_rad = 0.0;    // yaw of the body x axis about world z (the IMU cannot observe it)
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  // Initial standard deviations of the error state.
  double sigma_position = 1e-3;       // [m]
  double sigma_velocity = 0.01;       // [m/s]
  double sigma_acceleration = 0.05;   // [m/s^2]
  double sigma_accel_bias = 0.02;     // [m/s^2]
  double sigma_angular_rate = 0.005;  // [rad/s]
  double sigma_gyro_bias = 2e-4;      // [rad/s] (static start: at least the mean's own uncertainty)
  double sigma_roll_pitch = 0.01;     // [rad]
  double sigma_heading = 1e-3;        // [rad] heading is a convention (from config), so small

  // Start (or restart, after a crash) while the head moves: when a window is not at rest, roll and pitch come
  // from the mean specific force over the window, the samples rotated into one frame by the gyro, and the
  // tracker's deltas then resolve the velocity. Off: the filter waits for the head to stand still.
  bool in_motion = true;
  double moving_sigma_velocity = 1.5;      // [m/s] unknown: walking speed, or a slow vehicle
  double moving_sigma_acceleration = 2.0;  // [m/s^2] a walking head's acceleration
  double moving_sigma_angular_rate = 0.5;  // [rad/s]
  // [rad] the window's mean linear acceleration tilts the gravity estimate: 0.5 m/s^2 (a turn at walking speed)
  // is 3 degrees
  double moving_sigma_roll_pitch = 0.05;
  double moving_sigma_gyro_bias = 2e-3;  // [rad/s] not observable in motion: the gyro's turn-on bias
  // The start in motion from the tracker's deltas (ips/filter/motion_start.hpp): once a chain of at least
  // motion_min_deltas consecutive deltas spans motion_window_s while the IMU shows motion, the gyro bias, the
  // velocity and gravity's direction at its first image are estimated from it and the filter starts there, at the
  // chain's first image; without deltas (no tracker) it starts on the mean specific force over duration_s as above.
  // 1 s: the gyro bias to a few 1e-4 rad/s and gravity's direction to a few 1e-4 rad from a stereo tracker's
  // millimetres, while the head has hardly moved.
  double motion_window_s = 1.0;
  int motion_min_deltas = 5;
  // |estimated gravity| within this share of `gravity`, else the deltas and the IMU disagree and the start waits.
  double motion_max_gravity_error = 0.05;
};

// Online estimation of the camera's delay against the IMU (FilterParams::camera_delay).
struct CameraDelayParams {
  bool estimate = true;
  // The delay is searched within +-max_us: beyond what a camera driver's clock and transfer leave (tens of ms).
  int64_t max_us = 50'000;
  // Estimated every `every_intervals` tracker deltas (5 s at 8 Hz), over the newest window_intervals (1 min): a
  // walk's turns, and a bounded cost (about 80 ms per estimate on one core).
  int every_intervals = 40;
  int window_intervals = 480;
  // Applied once this many intervals (10 s of walking) turned by at least min_rate and its standard deviation is below
  // max_sigma_us: a tenth of the delays that matter (3 ms cost 0.2 % of the distance on a walk). Each interval the
  // delay runs on unknown costs heading, which the filter does not get back.
  int min_intervals = 80;
  double min_rate = 0.05;  // [rad/s]: slower intervals are the gyro's and the tracker's noise
  double max_sigma_us = 300;
};

// The frame the filter publishes its states in.
enum class OutputFrame {
  // Local level as the filter knows it now: roll and pitch as good as its latest estimate of gravity.
  World,
  // The world frame as the filter knew it at its first image, carried by its current estimate of the pose then:
  // the path since the start as best known now. Without a tilt sensor the start's level is the accelerometer's,
  // bias included; the filter relearns it as the head turns, and in World that correction turns the path it has
  // already published about the start (on EuRoC MH_01 an 8 mrad kink of the 12 mrad start tilt error).
  Start,
};

struct FilterParams {
  FilterType type = FilterType::Ekf;
  OutputFrame output_frame = OutputFrame::World;
  double gravity = 9.81;  // [m/s^2], world gravity is (0, 0, -gravity)

  // Scaled unscented transform (Julier 2002).
  double ukf_alpha = 1.0;
  double ukf_beta = 2.0;
  double ukf_kappa = 0.0;

  ProcessNoise process;
  ImuNoise imu;
  double tilt_sigma = 8.7e-3;  // [rad] per axis: the PEI Z260's accuracy, 0.5 deg RMS (resolution 0.1 deg)
  // Feasibility of a tilt sample: an inclinometer's sensing element lags (and rings) under acceleration, so
  // samples are used only while the estimated acceleration is below this (counted as rejected otherwise).
  double tilt_max_acceleration = 0.5;  // [m/s^2]
  bool tilt_specific_force = true;     // the inclinometer senses specific force (accelerometer type), not gravity alone
  double tracker_min_sigma_t = 1e-4;   // [m] floor on the tracker's translation sigma
  double tracker_min_sigma_r = 1e-5;   // [rad] floor on the tracker's rotation sigma
  // [px] the same floor in pixels of camera 0 (0: none): a calibration's residual that every feature of a pair shares
  // (the lens model's error at the same image places), which the tracker's covariance, built from independent
  // per-feature noise, leaves out. withHeadSensors turns it into radians with the head's focal length.
  double tracker_min_sigma_r_px = 0.0;
  // The tracker's rotation from far points (paper section 6) as a rotation-only measurement between the clones.
  bool far_rotation = true;
  double far_rotation_min_sigma = 1e-5;  // [rad] floor on its sigma

  // The alignment of E3D's successive dense maps (CLOUD_DELTA, from the mapper; paper section 6, "navigation can be
  // supported using a dense 3D point cloud") as a relative-pose measurement between the clones at the two maps'
  // times, which the filter keeps when E3D announces the pair (KEYFRAME). Floors as for the tracker's deltas:
  // the alignment's covariance comes from its own residuals and may claim more than the maps' systematic errors
  // (SGM's smoothing, the range limit) allow. Off by default: on the walk they change the end point within a run's
  // noise and on the hard walk they make the filter too certain; config/filter_weak.yaml turns them on past plain
  // walls, where they hold the velocity through the tracker's gaps (processes/mapper/README.md has the figures).
  bool cloud = false;
  double cloud_min_sigma_t = 2e-3;  // [m]: a fraction of the maps' 5 cm voxels
  double cloud_min_sigma_r = 2e-4;  // [rad]: 2 mm over the ~10 m the maps reach
  // A map's alignment is applied when the filter's time has passed the map's time by this much [us], whenever it
  // arrived before, so that a replay fuses it at the same point as the live run. It cannot come sooner than E3D's
  // match and the mapper's wait for the filter's own state at the map's time (which leaves the filter after the
  // reordering window): about 1 s on lavapipe beside the tracker, 3 s leaves room for a busy E3D. One that arrives
  // later still is applied at once (its clones kept) and counted (Estimator::cloudAppliedLate). The clones act on the
  // present state through their covariance, so the delay costs nothing but the time until the correction.
  int64_t cloud_apply_delay_us = 3'000'000;
  // Keyframe clones kept besides the image clones: the newest three, so that the alignment may span one skipped map
  // (E3D busy). With a map every second, the clones must outlast cloud_apply_delay_us: config/filter_weak.yaml.
  int max_keyframe_clones = 3;

  // The lever arm (camera 0's origin in the IMU frame) as three further filter states, as the paper suggests for
  // the translations between the sensors (section 3). Off: T_imu_cam0's translation from the calibration (measured
  // mechanically) is taken as exact. On: the calibration's value is the start, with lever_arm_sigma per axis; the
  // deltas of the tracker determine it where the head turns between two images (a turn of angle a about an axis
  // shows a lever-arm error e as a camera translation of about a * e across that axis), so a walk's heading changes
  // give the components across the vertical, and the vertical one follows only as the head nods and rolls.
  bool estimate_lever_arm = false;
  double lever_arm_sigma = 0.03;  // [m] per axis: a tape measure against centres hidden inside two housings

  // The tracker's scale error as a further filter state: its translations are (1 + s) times the true ones. A
  // calibration leaves the right rectified principal point a few tenths of a pixel off the left's; the tracker finds
  // most of that disparity offset while walking, but what it misses (a few hundredths of a pixel, against disparities
  // of tens of pixels indoors) makes every step too long or too short alike, an error no white noise on the deltas
  // represents. The IMU's accelerations observe s; where they do not, its variance keeps the position's covariance
  // honest. delta_scale_sigma: the start's uncertainty, 0.1 px of offset at a mean disparity of 20 px.
  bool estimate_delta_scale = false;
  double delta_scale_sigma = 0.005;

  // The turn of the tracker's steps as three further filter states: its translations are (I + [b]x) times the true
  // ones (camera 0), its rotations untouched. The disparity errors a calibration leaves are not one offset but vary
  // across the image (the relative focal length, the principal points against the lens distortion): where the
  // scene's points lie unevenly, the fitted motion tilts towards the side whose depths come out short, the same way in
  // every step, a drift across the path and in height growing with the distance walked that neither the deltas' white
  // noise nor the camera alignment (which turns the rotations too, and is pinned by the gyro) represents. The IMU
  // hardly observes it; its variance keeps the position's covariance honest. delta_direction_sigma: the tracker's
  // steps on the simulated hard walk (a calibration with the errors of sim/calibration_errors) turn by 0.3-0.8 mrad
  // against the truth, averaged over 15 s, up to 3.6 mrad where the walls are plain (processes/filter/README.md).
  bool estimate_delta_direction = false;
  double delta_direction_sigma = 1.0e-3;  // [rad] per axis

  // The tracker's rotation drift as three further filter states: its rotations err by Exp(|t| r), r per metre of the
  // step measured (camera 0). The same disparity errors that vary across the image turn the fitted rotation with the
  // motion: a disparity error g u (u = x / f) makes depths come out short on one side as the head walks forward by t,
  // and the rigid fit takes that for a turn of g t / (f b) about the axis across the gradient. No calibration pins g to
  // a hundredth of a pixel; the deltas' white noise (0.1 mrad a step) does not represent a turn that adds up step after
  // step, and the gyro cannot tell it from its own bias while the head walks at an even pace. Its variance keeps the
  // heading's, and through it the position's, covariance honest. delta_rotation_drift_sigma: g = 0.015 px at
  // f b = 149 px m (744 px, 0.2 m) gives 1e-4 rad/m; measured on the simulated hard walk: the tracker's rotations
  // alone drift in heading by 3-13 mrad over 91 m (seeds 1-5, rms 0.105 mrad/m).
  bool estimate_delta_rotation_drift = false;
  double delta_rotation_drift_sigma = 1.0e-4;  // [rad/m] per axis

  // The tilt sensor's constant offsets as two further filter states. Off, they are part of its white noise
  // (tilt_sigma, the sensor's whole accuracy): then hundreds of samples average to a roll and pitch the filter holds
  // far too certain, while the offset stays in every one of them, and each step of the tracker is put into the world
  // with that pitch: a height error growing with the distance walked that the covariance does not show. On, the
  // offsets start at zero with tilt_sigma, and each sample carries its white noise alone (tilt_offset_noise_sigma:
  // the PEI Z260's resolution of 0.1 deg).
  bool estimate_tilt_offset = false;
  double tilt_offset_noise_sigma = 1.75e-3;  // [rad]

  // The camera's rotation against the IMU as three further filter states, correcting the calibration's. The tracker's
  // steps are put into the world through it: an error of e turns every step by e, a drift of e times the distance
  // walked (across the path, or in height) that the deltas' own noise does not show. What the calibration leaves: the
  // camera-to-IMU rotation within 0.05 deg, and the left camera's principal point within 0.3 px, which turns the
  // rectified frame by 0.3 / f (0.4 mrad at f = 744 px). On: the calibration's rotation is the start with
  // camera_alignment_sigma per axis; the IMU's accelerations and turns seen by both observe it.
  bool estimate_camera_alignment = false;
  double camera_alignment_sigma = 1.0e-3;  // [rad] per axis

  // Latencies subtracted from message stamps [us] (zero when drivers already remove them).
  int64_t imu_latency_us = 0;
  int64_t tilt_latency_us = 0;
  int64_t camera_latency_us = 0;
  // The camera's delay against the IMU estimated online (camera_delay.hpp), in place of camera_latency_us once it is
  // certain. A few milliseconds unknown cost more than anything else on a walk: the deltas' rotations are then
  // compared with the gyro's over shifted intervals, and the heading drifts (the hard walk: 0.27 % end error with 3 ms
  // unknown, 0.05 % with it known).
  CameraDelayParams camera_delay;

  // Whether the head has a tilt sensor: without one, TILT messages are refused (counted) and no offset state is kept.
  bool use_tilt = true;

  int64_t reorder_window_us = 50'000;  // measurements are held this long so that they can be sorted
  // The IMU's stamps drive that release: it is the densest, most regular stream. Another sensor's stamp may
  // lead the IMU's newest by at most this much before it drives the release itself (the IMU has fallen
  // silent); a corrupt stamp a little ahead, which the stream checks cannot refuse (up to 20 intervals of the
  // 8 Hz pairs, 2.5 s), then cannot make every real measurement too late.
  int64_t imu_silence_release_us = 3'000'000;
  int max_clones = 3;  // pose clones kept at image times
  // Besides those, an image clone that no tracker delta has used as its earlier image yet is kept while it is at
  // most this much older than the newest image: a tracker that falls behind (a loaded machine: a backlog of
  // seconds) still has its deltas fused instead of counted too late. Steady state costs no clone more.
  int64_t clone_wait_us = 1'500'000;

  double gate_probability = 0.9995;  // chi-square gate on the Mahalanobis distance of every measurement
  bool gate_imu = true;
  bool gate_tilt = true;
  bool gate_tracker = true;
  bool gate_far_rotation = true;
  bool gate_cloud = true;
  int max_consecutive_rejects = 20;  // then the next measurement is applied anyway (re-capture)

  // IMU gap: a longer pause between IMU samples resets acceleration and angular rate to zero with these
  // uncertainties, and the time update runs with the process noise `gap_process` until IMU data return (the
  // usual angular one, tuned for 200 Hz rate updates, would blow the attitude up over a second).
  double imu_gap_s = 0.1;
  double gap_sigma_acceleration = 3.0;  // [m/s^2] (walking: ~3 m/s^2 vertical at the step frequency)
  double gap_sigma_angular_rate = 0.5;  // [rad/s]
  ProcessNoise gap_process{20.0, 2.0, 1e-8, 1e-12};
  int output_decimation = 1;  // one posterior output per this many IMU samples

  InitParams init;
};

// Reads the keys of `cfg` (a section such as Config("config/filter.yaml").section("filter")); absent keys
// keep their defaults, wrong ones throw ConfigError naming file and key.
FilterParams loadFilterParams(const Config& cfg);

// The parameters with the head's own sensors where its calibration describes them (ips/calibration.hpp
// ImuDescription, TiltDescription): the IMU's noise densities and rate, its biases' random walks (the process noise
// of the bias states: density squared) and turn-on sigmas (their prior at a start); the tilt sensor's accuracy and
// resolution, or no tilt sensor (use_tilt false) where the calibration describes an IMU but no tilt sensor. A
// calibration without `imu` leaves the parameters as they are (their defaults: the paper's MMQ-50 and PEI Z260).
// The tracker's rotation floor in pixels (tracker_min_sigma_r_px) becomes radians with camera 0's focal length.
FilterParams withHeadSensors(FilterParams params, const StereoCalibration& calib);
std::string toString(FilterType type);
// "ekf" or "ukf" (as toString gives them); nothing for any other name.
std::optional<FilterType> filterTypeFromString(const std::string& name);
std::string toString(OutputFrame frame);
// "world" or "start"; nothing for any other name.
std::optional<OutputFrame> outputFrameFromString(const std::string& name);

}  // namespace ips::filter
