#pragma once
// A simulation scenario: the sensor head's figures (camera, IMU, tilt sensor, timing), the motion and the
// world. Scenario::defaults() is the paper's test (a person walking ~90 m through a building in ~2 min with the
// DLR head); Scenario::load() reads a YAML file whose keys override those defaults (config/sim_*.yaml).
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "ips/sim/jet.hpp"

namespace ips::sim {

struct CameraFigures {
  int width = 1360;
  int height = 1024;
  double focal_px = 744.19;  // 4.8 mm lens on 6.45 um pixels
  double baseline_m = 0.2;
  double rate_hz = 8.0;  // up to 30
  // OpenCV k1 k2 p1 p2 k3 of the left and right lens.
  Eigen::Matrix<double, 5, 1> distortion_left =
      (Eigen::Matrix<double, 5, 1>() << -0.11, 0.045, 2e-4, -1e-4, -0.008).finished();
  Eigen::Matrix<double, 5, 1> distortion_right =
      (Eigen::Matrix<double, 5, 1>() << -0.105, 0.04, -1.5e-4, 2e-4, -0.007).finished();
  Eigen::Vector2d principal_offset_left{4.0, -3.0};  // [px] from the image centre
  Eigen::Vector2d principal_offset_right{-2.5, 5.0};
  double focal_ratio_right = 1.004;                       // fx_right / fx_left
  Eigen::Vector3d relative_rotation_deg{0.3, -0.5, 0.4};  // rotation vector of cam1 against cam0 [deg]
  Eigen::Vector3d baseline_offset_m{0.0, 0.002, -0.003};  // y, z offset of cam1's centre besides the baseline
  // The right camera turning about its own centre after calibration, which the processes are not told: a step
  // (a knock) of relative_rotation_step_deg at relative_rotation_step_s, and a drift (temperature) of
  // relative_rotation_drift_deg_per_min from the start. Rotation vectors in the right camera's frame; zero: the head
  // stays as calibrated.
  Eigen::Vector3d relative_rotation_step_deg{0.0, 0.0, 0.0};
  double relative_rotation_step_s = 0.0;
  Eigen::Vector3d relative_rotation_drift_deg_per_min{0.0, 0.0, 0.0};
  double noise_sigma = 1.5;  // [grey levels] sensor noise of each pixel
  double gain_left_db = 0.0;
  double gain_right_db = 0.4;  // gain difference of the right camera
  // [us] the exposure time; with auto_exposure the reference at which the world's radiance gives its grey levels
  // (a surface's grey scales with the exposure time and the gain).
  double exposure_us = 4000.0;
  // Effects of a real camera, each off by default (the easy walk; config/sim_hard.yaml switches them on).
  // Motion blur: every image integrates the scene over its exposure, rendered at sub-times close enough that
  // neighbouring sub-images lie at most blur_step_px apart, tile by tile (a far wall needs fewer than the floor at the
  // feet). A tile takes 3^k sub-images, at most max_blur_samples (a power of 3): the sub-times of 3^k are among those
  // of 3^(k+1), so each sub-image is rendered once, over the tiles that need it.
  bool motion_blur = false;
  double blur_step_px = 1.0;
  int max_blur_samples = 27;
  // Auto exposure per camera: the exposure that brings the camera's previous image (its mean grey) to
  // ae_target_grey, as a camera's exposure loop acts on the last image; within [ae_min_exposure_us,
  // ae_max_exposure_us], beyond that the gain rises, up to ae_max_gain_db. Bright and dark views then differ in
  // exposure (blur) and gain (noise), and the two cameras expose differently.
  bool auto_exposure = false;
  double ae_target_grey = 100.0;
  double ae_min_exposure_us = 100.0;
  double ae_max_exposure_us = 15000.0;  // indoors 5-15 ms
  double ae_max_gain_db = 12.0;
  // Natural vignetting of the lens: illumination falls with cos^4 of the ray's angle to the optical axis.
  bool vignetting = false;
  // Each image lost (a GigE frame dropped) with this probability, independently.
  double frame_loss = 0.0;
  // Timing of every sensor: latency = delivery delay after the true sample time (the order in which messages
  // arrive, e.g. image transfer); the stamp = true time + stamp_offset + N(0, jitter) (clock errors).
  double latency_us = 30000.0;
  double stamp_offset_us = 0.0;
  double jitter_us = 0.0;
  double near_m = 0.05;  // nearest rendered distance
};

struct ImuFigures {
  double rate_hz = 200.0;
  double gyro_arw_deg_sqrt_h = 0.3;           // angle random walk (white rate noise density)
  double accel_vrw_mg_sqrt_hz = 0.5;          // velocity random walk (white acceleration noise density)
  double gyro_bias_deg_s = 0.05;              // std dev of the constant (turn-on) gyro bias per axis
  double accel_bias_mg = 5.0;                 // std dev of the constant accelerometer bias per axis
  double gyro_bias_walk_deg_s_sqrt_s = 2e-4;  // bias random walk density
  double accel_bias_walk_mg_sqrt_s = 0.02;
  double gyro_lsb_deg_s = 0.0061;  // quantisation: 400 deg/s over 16 bits
  double accel_lsb_mg = 0.305;     // 20 g over 16 bits
  double gyro_range_deg_s = 200.0;
  double accel_range_g = 10.0;
  double misalignment_mrad = 5.0;                  // std dev per axis of the IMU's rotation against the head's axes
  Eigen::Vector3d lever_arm_m{-0.05, 0.0, -0.06};  // camera 0 centre in the IMU frame
  double latency_us = 2000.0;
  double stamp_offset_us = 0.0;
  double jitter_us = 20.0;

  // The same sensor without noise, biases, quantisation, misalignment or time errors.
  static ImuFigures ideal();
};

struct TiltFigures {
  double rate_hz = 14.0;
  double resolution_deg = 0.1;
  double accuracy_deg = 0.5;      // std dev of the constant offset of each angle
  double noise_deg = 0.03;        // white noise before quantisation
  double time_constant_s = 0.15;  // first-order response of the sensing element to specific force
  double misalignment_deg = 1.0;  // std dev per axis of its mounting against the head's axes
  double latency_us = 40000.0;    // a slow serial inclinometer
  double stamp_offset_us = 0.0;
  double jitter_us = 1000.0;

  static TiltFigures ideal();
};

// A person walking to and fro along a lane of the floor plan (from -> to -> from ...), standing dwell_s at each end.
struct PersonLane {
  Eigen::Vector2d from{0, 0}, to{0, 0};  // [m]
  double speed_mps = 1.2;
  double dwell_s = 0.0;
};

// A stretch of corridor lit brighter or dimmer than the rest: the rectangle [low, high] of the floor plan (walls,
// floor, ceiling and whatever stands in it) gets `ratio` times the building's light, blended over the zone's edges
// (WorldConfig::lighting_transition_m).
struct LightingZone {
  Eigen::Vector2d low{0, 0}, high{0, 0};  // [m]
  double ratio = 1.0;
};

// A hump in a corridor's floor as a wheelchair ramp builds it: from `start_m` (the foot of the up slope, on the
// corridor's centre line) along heading_deg the floor rises with `slope` to rise_m, stays level for plateau_m and falls
// again with the same slope; width_m across. The ramp spans the corridor wall to wall, so that the corridor's walls are
// its sides. rise_m 0: no ramp.
struct Ramp {
  Eigen::Vector2d start_m{0, 0};
  double heading_deg = 0.0;
  double width_m = 2.4;
  double rise_m = 0.0;
  double slope = 1.0 / 12;
  double plateau_m = 4.0;
  // A walker's body does not follow the floor's kinks: its height rounds each of them over this length (C2, so that
  // the IMU's specific force stays finite), which puts it at most 0.078 slope blend_m off the floor at a kink.
  double blend_m = 1.0;

  bool any() const { return rise_m > 0; }
  double run() const { return rise_m / slope; }  // length of one slope along the floor plan
  double length() const { return 2 * run() + plateau_m; }
  // Where p is on the ramp: along (from the foot of the up slope) and across (from the centre line, to the left).
  Eigen::Vector2d local(const Eigen::Vector2d& p) const;
  // The floor's height at p: the ramp's surface on it, 0 elsewhere.
  double floorHeight(const Eigen::Vector2d& p) const;
  // The height of the floor under a walker at (x, y), kinks rounded over blend_m, with its time derivatives.
  Jet2 walkerFloor(const Jet2& x, const Jet2& y) const;
  bool operator==(const Ramp& o) const {
    return start_m == o.start_m && heading_deg == o.heading_deg && width_m == o.width_m && rise_m == o.rise_m &&
           slope == o.slope && plateau_m == o.plateau_m && blend_m == o.blend_m;
  }
};

struct TrajectoryConfig {
  // walk | vehicle | still | wave | stations. still: holds the first waypoint. wave: holds it too, turned about all
  // three axes for still_duration_s as a user waves a head to calibrate its IMU against the cameras (wave_*).
  // stations: the head set down at each of `stations` in turn (static positions, e.g. in front of a chart).
  std::string type = "walk";
  std::vector<Eigen::Vector2d> waypoints;  // [m] x y on the floor, polyline to follow
  double speed_mps = 0.75;
  double height_m = 1.45;        // IMU height above the floor
  double knot_spacing_s = 1.0;   // of the cubic B-spline; larger = smoother corners
  double still_duration_s = 60;  // duration of a 'still' scenario (and the hold at the end of the others)
  // The head stands still this long before it starts moving, as a person does before walking off: the
  // navigation filter initialises at rest (roll, pitch and gyro bias from the first seconds).
  double start_still_s = 3.0;
  double yaw_deg = 0;           // heading for 'still'
  double pitch_down_deg = 6.0;  // constant pitch of the head
  double roll_deg = 0.0;
  // Gait (walk) or vibration (vehicle): vertical bounce, lateral sway and head wobble.
  double step_frequency_hz = 1.7;
  double bounce_m = 0.025;     // vertical amplitude at the step frequency
  double sway_m = 0.02;        // lateral amplitude at half the step frequency
  double nod_deg = 1.0;        // pitch amplitude at the step frequency
  double roll_sway_deg = 1.5;  // roll amplitude at half the step frequency
  double yaw_sway_deg = 1.5;   // yaw amplitude at half the step frequency
  double ramp_s = 2.0;         // gait amplitude ramps up after start and down before stop
  // wave: sinusoidal turns about the body's x (roll), y (pitch) and z (yaw) axes with these amplitudes and periods
  // (different periods, so that the rotation axis sweeps all directions), on top of the gait keys.
  Eigen::Vector3d wave_amplitude_deg{15.0, 10.0, 20.0};
  Eigen::Vector3d wave_period_s{3.1, 2.3, 4.3};
  // stations: body poses x y z [m], roll pitch yaw [deg] (pitch > 0: nose down), each held station_hold_s, moved
  // between in station_move_s (smooth: at rest at both ends of a move).
  struct Station {
    Eigen::Vector3d position;
    Eigen::Vector3d roll_pitch_yaw_deg;
  };
  std::vector<Station> stations;
  double station_hold_s = 4.0;
  double station_move_s = 2.0;
  // The floor the walker walks on (walk, vehicle, still, wave): the head's height is height_m above it. The world's
  // ramp (WorldConfig::ramp; Scenario::load copies it, validate() checks that the two agree).
  Ramp floor_ramp;

  static std::vector<Eigen::Vector2d> defaultWaypoints();
};

// What the processes are told about the head differs from the truth the simulator renders with by these
// errors (standard deviations, drawn once per seed): the residual errors of a good calibration. All zero: the
// processes get the true calibration.
struct CalibrationErrors {
  double focal_rel = 0;            // relative error of each camera's focal length
  double principal_px = 0;         // per coordinate of each principal point
  double stereo_rotation_deg = 0;  // per axis of the relative rotation of the cameras
  double imu_rotation_deg = 0;     // per axis of the camera-to-IMU rotation
  double tilt_rotation_deg = 0;    // per axis of the camera-to-tilt-sensor rotation

  bool any() const {
    return focal_rel > 0 || principal_px > 0 || stereo_rotation_deg > 0 || imu_rotation_deg > 0 ||
           tilt_rotation_deg > 0;
  }
};

struct WorldConfig {
  std::string data_dir;  // photographs (stereo/*/left.png, ...); empty = ips::dataDir()
  // building: the indoor corridor ring of the paper's walk (the keys down to texel_m);
  // street: outdoors, facades along the streets of `route` and buildings 50-500 m away under a sky (street_*).
  std::string type = "building";
  double wall_height_m = 2.8;
  double corridor_width_m = 2.4;
  Eigen::Vector2d building_size_m{30.0, 14.0};  // outer corridor ring
  double weak_texture_share = 0.25;             // share of wall segments with weak (plaster) texture
  bool weak_floor = false;                      // floor and ceiling with the weak plaster texture too (painted)
  double poster_spacing_m = 4.0;                // along the walls
  double object_spacing_m = 6.0;                // cabinets and boxes along the walls
  double texel_m = 0.004;                       // size of a procedural texel on the walls
  // A calibration chart standing in the building: a chessboard of chart_inner_corners (columns, rows; 0 0: no chart)
  // with squares of chart_square_m and a white margin of one square, its centre at chart_centre_m, upright (rows
  // level, the board plumb), its printed side facing the heading chart_facing_deg (0: +x).
  Eigen::Vector2d chart_inner_corners{0, 0};
  double chart_square_m = 0.1;
  Eigen::Vector3d chart_centre_m{6.5, 1.2, 1.45};
  double chart_facing_deg = 180;

  // street: the streets are the segments of `route` (Scenario::load sets it to the trajectory's waypoints).
  std::vector<Eigen::Vector2d> route;
  double street_half_width_m = 9.0;  // kerb-side facades this far either side of a street's centre line
  Eigen::Vector2d street_facade_height_m{6.0, 15.0};  // range of the facades' heights
  double street_gap_share = 0.3;                      // share of the frontage left open (side streets, yards): the far
                                                      // buildings show through
  int far_buildings = 60;                             // buildings at far_distance_m from the nearest street
  Eigen::Vector2d far_distance_m{50.0, 500.0};
  Eigen::Vector2d far_height_m{15.0, 60.0};
  double sky_distance_m = 5000.0;  // the sky: weakly textured clouds, "at infinity" for any baseline

  // building: what makes a real walk harder, each absent by default (config/sim_hard.yaml has all of them).
  // People walking through the view: person-sized boxes in clothing-like texture on these lanes, each at a phase drawn
  // from the seed such that it keeps person_clearance_m from the walker (no one walks into the head).
  std::vector<PersonLane> people;
  Eigen::Vector3d person_size_m{0.45, 0.3, 1.75};  // across the lane (shoulders), along it, height
  double person_clearance_m = 0.4;                 // from the head's (IMU's) position to a person's box
  // Dim and bright stretches: the light of the building scaled per zone, with smooth edges this long.
  std::vector<LightingZone> lighting_zones;
  double lighting_transition_m = 1.5;
  Ramp ramp;  // a hump in the floor (Scenario::load copies it to the trajectory, which follows the floor)
  // A contiguous plain stretch: inside the floor plan's rectangle x0, y0, x1, y1 every wall piece, the floor and the
  // ceiling have the weak plaster texture, and no posters or objects; all zero: none.
  Eigen::Matrix<double, 4, 1> weak_stretch_m{0, 0, 0, 0};
};

struct Scenario {
  std::string name = "walk";
  std::string source = "built-in default";  // file it was read from
  uint64_t seed = 1;
  int64_t start_utime = 1'000'000;  // common-clock time of t = 0 [us]
  double gravity = 9.81;
  CameraFigures camera;
  ImuFigures imu;
  TiltFigures tilt;
  CalibrationErrors calibration_errors;
  TrajectoryConfig trajectory;
  WorldConfig world;

  static Scenario defaults();
  // Keys present in the file override the defaults, or the scenario the file names as its `base` (a path relative to
  // the file); a wrong key type throws ips::ConfigError naming file and key.
  static Scenario load(const std::string& path);
  void validate() const;  // throws std::invalid_argument on impossible figures
};

// What makes a scenario harder than the built-in walk, by name, for reports ("sim_effects"): "motion_blur",
// "auto_exposure", "vignetting", "frame_loss", "stamp_offsets" (any sensor's stamps offset), "perturbed_calibration"
// (calibration_errors), "camera_knock" and "camera_drift" (relative_rotation_step / drift), "weak_texture" (more
// plain walls than the walk's), "people", "lighting_zones", "ramp", "weak_stretch" (the world's keys of the same
// names), in this order; empty for the walk.
std::vector<std::string> simEffects(const Scenario& scenario);

}  // namespace ips::sim
