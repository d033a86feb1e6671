#include "ips/filter/params.hpp"

#include <algorithm>

namespace ips::filter {

namespace {

void positive(const Config& cfg, const std::string& key, double v) {
  if (!(v > 0)) throw ConfigError(cfg.path() + ": key '" + key + "' must be positive");
}
void nonNegative(const Config& cfg, const std::string& key, double v) {
  if (!(v >= 0)) throw ConfigError(cfg.path() + ": key '" + key + "' must not be negative");
}

}  // namespace

std::string toString(FilterType type) { return type == FilterType::Ekf ? "ekf" : "ukf"; }

std::optional<FilterType> filterTypeFromString(const std::string& name) {
  if (name == "ekf") return FilterType::Ekf;
  if (name == "ukf") return FilterType::Ukf;
  return std::nullopt;
}

std::string toString(OutputFrame frame) { return frame == OutputFrame::Start ? "start" : "world"; }

std::optional<OutputFrame> outputFrameFromString(const std::string& name) {
  if (name == "world") return OutputFrame::World;
  if (name == "start") return OutputFrame::Start;
  return std::nullopt;
}

FilterParams loadFilterParams(const Config& c) {
  FilterParams p;
  // The sensors' own figures belong to the head's description (the calibration file), not to the method's settings.
  for (const char* key : {"imu", "process_noise/accel_bias_psd", "process_noise/gyro_bias_psd", "tilt/sigma",
                          "tilt/offset_noise_sigma", "init/sigma_accel_bias", "init/moving_sigma_gyro_bias"})
    if (c.has(key))
      throw ConfigError(c.path() + ": key '" + key +
                        "' is the sensor's: it is read from the calibration file's imu and tilt blocks (its noise "
                        "densities, random walks, turn-on biases, the tilt sensor's accuracy and resolution)");
  const std::string type = c.getString("type", "ekf");
  const std::optional<FilterType> t = filterTypeFromString(type);
  if (!t) throw ConfigError(c.path() + ": key 'type' must be 'ekf' or 'ukf', not '" + type + "'");
  p.type = *t;
  const std::string frame = c.getString("output_frame", toString(p.output_frame));
  const std::optional<OutputFrame> f = outputFrameFromString(frame);
  if (!f) throw ConfigError(c.path() + ": key 'output_frame' must be 'world' or 'start', not '" + frame + "'");
  p.output_frame = *f;
  p.gravity = c.getDouble("gravity", p.gravity);
  positive(c, "gravity", p.gravity);

  p.ukf_alpha = c.getDouble("ukf/alpha", p.ukf_alpha);
  p.ukf_beta = c.getDouble("ukf/beta", p.ukf_beta);
  p.ukf_kappa = c.getDouble("ukf/kappa", p.ukf_kappa);
  positive(c, "ukf/alpha", p.ukf_alpha);

  p.process.jerk_psd = c.getDouble("process_noise/jerk_psd", p.process.jerk_psd);
  p.process.angular_accel_psd = c.getDouble("process_noise/angular_accel_psd", p.process.angular_accel_psd);
  positive(c, "process_noise/jerk_psd", p.process.jerk_psd);
  positive(c, "process_noise/angular_accel_psd", p.process.angular_accel_psd);
  p.process.from_imu = c.getBool("process_noise/from_imu", p.process.from_imu);
  p.process.from_imu_window_s = c.getDouble("process_noise/from_imu_window_s", p.process.from_imu_window_s);
  positive(c, "process_noise/from_imu_window_s", p.process.from_imu_window_s);
  p.process.delta_scale_psd = c.getDouble("delta_scale/psd", p.process.delta_scale_psd);
  nonNegative(c, "delta_scale/psd", p.process.delta_scale_psd);
  p.process.delta_direction_psd = c.getDouble("delta_direction/psd", p.process.delta_direction_psd);
  nonNegative(c, "delta_direction/psd", p.process.delta_direction_psd);
  p.process.delta_rotation_drift_psd = c.getDouble("delta_rotation_drift/psd", p.process.delta_rotation_drift_psd);
  nonNegative(c, "delta_rotation_drift/psd", p.process.delta_rotation_drift_psd);

  p.tilt_max_acceleration = c.getDouble("tilt/max_acceleration", p.tilt_max_acceleration);
  positive(c, "tilt/max_acceleration", p.tilt_max_acceleration);
  p.tilt_specific_force = c.getBool("tilt/specific_force", p.tilt_specific_force);
  p.tracker_min_sigma_t = c.getDouble("tracker/min_sigma_t", p.tracker_min_sigma_t);
  p.tracker_min_sigma_r = c.getDouble("tracker/min_sigma_r", p.tracker_min_sigma_r);
  nonNegative(c, "tracker/min_sigma_t", p.tracker_min_sigma_t);
  nonNegative(c, "tracker/min_sigma_r", p.tracker_min_sigma_r);
  p.tracker_min_sigma_r_px = c.getDouble("tracker/min_sigma_r_px", p.tracker_min_sigma_r_px);
  nonNegative(c, "tracker/min_sigma_r_px", p.tracker_min_sigma_r_px);
  p.far_rotation = c.getBool("tracker/far_rotation", p.far_rotation);
  p.far_rotation_min_sigma = c.getDouble("tracker/far_rotation_min_sigma", p.far_rotation_min_sigma);
  nonNegative(c, "tracker/far_rotation_min_sigma", p.far_rotation_min_sigma);

  p.imu_latency_us = c.getInt("latency_us/imu", static_cast<int>(p.imu_latency_us));
  p.tilt_latency_us = c.getInt("latency_us/tilt", static_cast<int>(p.tilt_latency_us));
  p.camera_latency_us = c.getInt("latency_us/camera", static_cast<int>(p.camera_latency_us));
  CameraDelayParams& cd = p.camera_delay;
  cd.estimate = c.getBool("camera_delay/estimate", cd.estimate);
  cd.max_us = c.getInt("camera_delay/max_us", static_cast<int>(cd.max_us));
  cd.every_intervals = c.getInt("camera_delay/every_intervals", cd.every_intervals);
  cd.window_intervals = c.getInt("camera_delay/window_intervals", cd.window_intervals);
  cd.min_intervals = c.getInt("camera_delay/min_intervals", cd.min_intervals);
  cd.min_rate = c.getDouble("camera_delay/min_rate", cd.min_rate);
  cd.max_sigma_us = c.getDouble("camera_delay/max_sigma_us", cd.max_sigma_us);
  if (cd.max_us <= 0 || cd.max_us > 1'000'000 || cd.every_intervals < 1 || cd.min_intervals < 20 ||
      cd.window_intervals < cd.min_intervals || cd.min_rate < 0 || !(cd.max_sigma_us > 0))
    throw ConfigError(c.path() +
                      ": camera_delay: need 0 < max_us <= 1e6, every_intervals >= 1, min_intervals >= 20, "
                      "window_intervals >= min_intervals, min_rate >= 0, max_sigma_us > 0");

  p.reorder_window_us = c.getInt("reorder_window_us", static_cast<int>(p.reorder_window_us));
  nonNegative(c, "reorder_window_us", static_cast<double>(p.reorder_window_us));
  p.imu_silence_release_us = c.getInt("imu_silence_release_us", static_cast<int>(p.imu_silence_release_us));
  nonNegative(c, "imu_silence_release_us", static_cast<double>(p.imu_silence_release_us));
  p.estimate_lever_arm = c.getBool("lever_arm/estimate", p.estimate_lever_arm);
  p.lever_arm_sigma = c.getDouble("lever_arm/sigma", p.lever_arm_sigma);
  if (!(p.lever_arm_sigma > 0)) throw ConfigError(c.path() + ": key 'lever_arm/sigma' must be positive");
  p.estimate_tilt_offset = c.getBool("tilt/estimate_offset", p.estimate_tilt_offset);
  p.estimate_camera_alignment = c.getBool("camera_alignment/estimate", p.estimate_camera_alignment);
  p.camera_alignment_sigma = c.getDouble("camera_alignment/sigma", p.camera_alignment_sigma);
  positive(c, "camera_alignment/sigma", p.camera_alignment_sigma);
  p.estimate_delta_scale = c.getBool("delta_scale/estimate", p.estimate_delta_scale);
  p.delta_scale_sigma = c.getDouble("delta_scale/sigma", p.delta_scale_sigma);
  if (!(p.delta_scale_sigma > 0)) throw ConfigError(c.path() + ": key 'delta_scale/sigma' must be positive");
  p.estimate_delta_direction = c.getBool("delta_direction/estimate", p.estimate_delta_direction);
  p.delta_direction_sigma = c.getDouble("delta_direction/sigma", p.delta_direction_sigma);
  positive(c, "delta_direction/sigma", p.delta_direction_sigma);
  p.estimate_delta_rotation_drift = c.getBool("delta_rotation_drift/estimate", p.estimate_delta_rotation_drift);
  p.delta_rotation_drift_sigma = c.getDouble("delta_rotation_drift/sigma", p.delta_rotation_drift_sigma);
  positive(c, "delta_rotation_drift/sigma", p.delta_rotation_drift_sigma);
  p.cloud = c.getBool("cloud/enabled", p.cloud);
  p.cloud_min_sigma_t = c.getDouble("cloud/min_sigma_t", p.cloud_min_sigma_t);
  p.cloud_min_sigma_r = c.getDouble("cloud/min_sigma_r", p.cloud_min_sigma_r);
  nonNegative(c, "cloud/min_sigma_t", p.cloud_min_sigma_t);
  nonNegative(c, "cloud/min_sigma_r", p.cloud_min_sigma_r);
  p.cloud_apply_delay_us = c.getInt("cloud/apply_delay_us", static_cast<int>(p.cloud_apply_delay_us));
  nonNegative(c, "cloud/apply_delay_us", static_cast<double>(p.cloud_apply_delay_us));
  p.max_keyframe_clones = c.getInt("cloud/max_keyframe_clones", p.max_keyframe_clones);
  if (p.max_keyframe_clones < 2) throw ConfigError(c.path() + ": key 'cloud/max_keyframe_clones' must be at least 2");
  p.max_clones = c.getInt("max_clones", p.max_clones);
  if (p.max_clones < 2) throw ConfigError(c.path() + ": key 'max_clones' must be at least 2");
  p.clone_wait_us = c.getInt("clone_wait_us", static_cast<int>(p.clone_wait_us));
  nonNegative(c, "clone_wait_us", static_cast<double>(p.clone_wait_us));

  p.gate_probability = c.getDouble("gate/probability", p.gate_probability);
  if (!(p.gate_probability > 0 && p.gate_probability < 1))
    throw ConfigError(c.path() + ": key 'gate/probability' must be in (0, 1)");
  p.gate_imu = c.getBool("gate/imu", p.gate_imu);
  p.gate_tilt = c.getBool("gate/tilt", p.gate_tilt);
  p.gate_tracker = c.getBool("gate/tracker", p.gate_tracker);
  p.gate_far_rotation = c.getBool("gate/far_rotation", p.gate_far_rotation);
  p.gate_cloud = c.getBool("gate/cloud", p.gate_cloud);
  p.max_consecutive_rejects = c.getInt("gate/max_consecutive_rejects", p.max_consecutive_rejects);
  if (p.max_consecutive_rejects < 1) throw ConfigError(c.path() + ": key 'gate/max_consecutive_rejects' must be >= 1");

  p.imu_gap_s = c.getDouble("imu_gap_s", p.imu_gap_s);
  positive(c, "imu_gap_s", p.imu_gap_s);
  // Longer than any stream may stay silent before its next stamp counts as a new time line (10 s in the
  // framework's stream checks); also keeps the microsecond conversion far from overflow.
  if (p.imu_gap_s > 10.0) throw ConfigError(c.path() + ": key 'imu_gap_s' must be at most 10 s");
  p.gap_sigma_acceleration = c.getDouble("gap/sigma_acceleration", p.gap_sigma_acceleration);
  p.gap_sigma_angular_rate = c.getDouble("gap/sigma_angular_rate", p.gap_sigma_angular_rate);
  p.gap_process.jerk_psd = c.getDouble("gap/jerk_psd", p.gap_process.jerk_psd);
  p.gap_process.angular_accel_psd = c.getDouble("gap/angular_accel_psd", p.gap_process.angular_accel_psd);
  positive(c, "gap/sigma_acceleration", p.gap_sigma_acceleration);
  positive(c, "gap/sigma_angular_rate", p.gap_sigma_angular_rate);
  positive(c, "gap/jerk_psd", p.gap_process.jerk_psd);
  positive(c, "gap/angular_accel_psd", p.gap_process.angular_accel_psd);
  p.gap_process.accel_bias_psd = p.process.accel_bias_psd;
  p.gap_process.gyro_bias_psd = p.process.gyro_bias_psd;
  p.gap_process.delta_scale_psd = p.process.delta_scale_psd;
  p.gap_process.delta_direction_psd = p.process.delta_direction_psd;
  p.gap_process.delta_rotation_drift_psd = p.process.delta_rotation_drift_psd;
  p.output_decimation = c.getInt("output_decimation", p.output_decimation);
  if (p.output_decimation < 1) throw ConfigError(c.path() + ": key 'output_decimation' must be >= 1");

  InitParams& i = p.init;
  i.duration_s = c.getDouble("init/duration_s", i.duration_s);
  positive(c, "init/duration_s", i.duration_s);
  i.max_accel_std = c.getDouble("init/max_accel_std", i.max_accel_std);
  i.max_gyro_std = c.getDouble("init/max_gyro_std", i.max_gyro_std);
  i.heading_rad = c.getDouble("init/heading_rad", i.heading_rad);
  if (c.has("init/position")) i.position = c.getMatrix("init/position", 3, 1);
  i.sigma_position = c.getDouble("init/sigma_position", i.sigma_position);
  i.sigma_velocity = c.getDouble("init/sigma_velocity", i.sigma_velocity);
  i.sigma_acceleration = c.getDouble("init/sigma_acceleration", i.sigma_acceleration);
  i.sigma_angular_rate = c.getDouble("init/sigma_angular_rate", i.sigma_angular_rate);
  i.sigma_gyro_bias = c.getDouble("init/sigma_gyro_bias", i.sigma_gyro_bias);
  i.sigma_roll_pitch = c.getDouble("init/sigma_roll_pitch", i.sigma_roll_pitch);
  i.sigma_heading = c.getDouble("init/sigma_heading", i.sigma_heading);
  i.in_motion = c.getBool("init/in_motion", i.in_motion);
  i.moving_sigma_velocity = c.getDouble("init/moving_sigma_velocity", i.moving_sigma_velocity);
  i.moving_sigma_acceleration = c.getDouble("init/moving_sigma_acceleration", i.moving_sigma_acceleration);
  i.moving_sigma_angular_rate = c.getDouble("init/moving_sigma_angular_rate", i.moving_sigma_angular_rate);
  i.moving_sigma_roll_pitch = c.getDouble("init/moving_sigma_roll_pitch", i.moving_sigma_roll_pitch);
  i.motion_window_s = c.getDouble("init/motion_window_s", i.motion_window_s);
  positive(c, "init/motion_window_s", i.motion_window_s);
  i.motion_min_deltas = c.getInt("init/motion_min_deltas", i.motion_min_deltas);
  if (i.motion_min_deltas < 2) throw ConfigError(c.path() + ": key 'init/motion_min_deltas' must be at least 2");
  i.motion_max_gravity_error = c.getDouble("init/motion_max_gravity_error", i.motion_max_gravity_error);
  positive(c, "init/motion_max_gravity_error", i.motion_max_gravity_error);
  for (const char* k : {"init/moving_sigma_velocity", "init/moving_sigma_acceleration",
                        "init/moving_sigma_angular_rate", "init/moving_sigma_roll_pitch"})
    positive(c, k, c.getDouble(k, 1.0));
  for (const char* k : {"init/sigma_position", "init/sigma_velocity", "init/sigma_acceleration",
                        "init/sigma_angular_rate", "init/sigma_gyro_bias", "init/sigma_roll_pitch",
                        "init/sigma_heading", "init/max_accel_std", "init/max_gyro_std"})
    positive(c, k, c.getDouble(k, 1.0));
  return p;
}

FilterParams withHeadSensors(FilterParams p, const StereoCalibration& calib) {
  const double focal_px = 0.5 * (calib.cam0.K(0, 0) + calib.cam0.K(1, 1));
  if (p.tracker_min_sigma_r_px > 0 && focal_px > 0)
    p.tracker_min_sigma_r = std::max(p.tracker_min_sigma_r, p.tracker_min_sigma_r_px / focal_px);
  if (!calib.imu) return p;
  const ImuDescription& imu = *calib.imu;
  p.imu.rate_hz = imu.rate_hz;
  p.imu.gyro_noise_density = imu.gyro_noise_density;
  p.imu.accel_noise_density = imu.accel_noise_density;
  for (ProcessNoise* q : {&p.process, &p.gap_process}) {
    q->gyro_bias_psd = imu.gyro_random_walk * imu.gyro_random_walk;
    q->accel_bias_psd = imu.accel_random_walk * imu.accel_random_walk;
  }
  // At a start the accelerometer's bias is its turn-on bias (at rest a bias and a tilt look alike); the gyro's is
  // unknown until the deltas or a rest have shown it.
  p.init.sigma_accel_bias = imu.accel_bias_sigma;
  p.init.moving_sigma_gyro_bias = imu.gyro_bias_sigma;
  // A gap is a pause of several sample intervals, whatever the rate (a 10 Hz GPS/INS is not in a gap between samples).
  p.imu_gap_s = std::max(p.imu_gap_s, 3.0 / imu.rate_hz);
  p.use_tilt = calib.tilt.has_value();
  if (calib.tilt) {
    p.tilt_sigma = calib.tilt->accuracy;
    p.tilt_offset_noise_sigma = calib.tilt->resolution;
  } else {
    p.estimate_tilt_offset = false;
  }
  return p;
}

}  // namespace ips::filter
