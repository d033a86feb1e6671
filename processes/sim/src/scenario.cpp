#include "ips/sim/scenario.hpp"

#include <stdexcept>

#include "ips/config.hpp"

namespace ips::sim {

ImuFigures ImuFigures::ideal() {
  ImuFigures f;
  f.gyro_arw_deg_sqrt_h = 0;
  f.accel_vrw_mg_sqrt_hz = 0;
  f.gyro_bias_deg_s = 0;
  f.accel_bias_mg = 0;
  f.gyro_bias_walk_deg_s_sqrt_s = 0;
  f.accel_bias_walk_mg_sqrt_s = 0;
  f.gyro_lsb_deg_s = 0;
  f.accel_lsb_mg = 0;
  f.gyro_range_deg_s = 1e9;
  f.accel_range_g = 1e9;
  f.misalignment_mrad = 0;
  f.latency_us = 0;
  f.stamp_offset_us = 0;
  f.jitter_us = 0;
  return f;
}

TiltFigures TiltFigures::ideal() {
  TiltFigures f;
  f.resolution_deg = 0;
  f.accuracy_deg = 0;
  f.noise_deg = 0;
  f.time_constant_s = 0;
  f.misalignment_deg = 0;
  f.latency_us = 0;
  f.stamp_offset_us = 0;
  f.jitter_us = 0;
  return f;
}

std::vector<Eigen::Vector2d> TrajectoryConfig::defaultWaypoints() {
  // Through the default building (WorldConfig): along the south corridor, a loop through the room south of it,
  // then round the corridor ring anticlockwise. About 90 m.
  return {{3.0, 1.2},   {12.9, 1.2}, {12.9, -1.2}, {14.3, -2.5}, {14.3, -4.5}, {11.5, -4.5}, {11.5, -2.5},
          {12.9, -1.2}, {12.9, 1.2}, {28.8, 1.2},  {28.8, 12.8}, {1.2, 12.8},  {1.2, 3.0}};
}

Scenario Scenario::defaults() {
  Scenario s;
  s.trajectory.waypoints = TrajectoryConfig::defaultWaypoints();
  return s;
}

namespace {

void get(const Config& c, const std::string& key, double& v) { v = c.getDouble(key, v); }
void get(const Config& c, const std::string& key, int& v) { v = c.getInt(key, v); }
void get(const Config& c, const std::string& key, std::string& v) { v = c.getString(key, v); }
void get(const Config& c, const std::string& key, bool& v) { v = c.getBool(key, v); }
template <int N>
void get(const Config& c, const std::string& key, Eigen::Matrix<double, N, 1>& v) {
  if (c.has(key)) v = c.getMatrix(key, N, 1);
}

// A key holding a flat list of records of `fields` numbers each ([] : none), one row per record; false when the
// key is absent (the default stays). `layout` names the fields for the error message.
bool getRecords(const Config& c, const std::string& key, int fields, const std::string& layout, cv::Mat& records) {
  if (!c.has(key)) return false;
  cv::Mat flat = c.getMat(key);
  if (flat.total() % fields != 0)
    throw ConfigError(c.path() + ": key '" + key + "' must be a flat list " + layout + ", ...");
  records = flat.empty() ? cv::Mat(0, fields, CV_64F) : flat.reshape(1, static_cast<int>(flat.total()) / fields);
  return true;
}

// The keys of the file at `path` over `s`. A file may name another scenario as its `base` (a path relative to its
// own folder): that one is read first, so a variant says only what differs (the head of the walk, waved instead of
// walked). Bases nest up to kMaxBaseDepth deep (a loop of bases is an error).
constexpr int kMaxBaseDepth = 4;
Scenario loadOver(const std::string& path, int depth) {
  Config c(path);
  Scenario s = Scenario::defaults();
  if (c.has("base")) {
    if (depth >= kMaxBaseDepth)
      throw ConfigError(path + ": key 'base' nests deeper than " + std::to_string(kMaxBaseDepth) + " files");
    std::string base = c.getString("base");
    if (!base.empty() && base.front() != '/') {
      const auto slash = path.find_last_of('/');
      if (slash != std::string::npos) base = path.substr(0, slash + 1) + base;
    }
    s = loadOver(base, depth + 1);
  }
  s.source = path;
  get(c, "name", s.name);
  if (c.has("seed")) {
    const int seed = c.getInt("seed");
    if (seed < 0) throw ConfigError(path + ": key 'seed' must not be negative");
    s.seed = static_cast<uint64_t>(seed);
  }
  if (c.has("start_utime")) s.start_utime = static_cast<int64_t>(c.getDouble("start_utime"));
  get(c, "gravity", s.gravity);

  CameraFigures& cam = s.camera;
  get(c, "camera/width", cam.width);
  get(c, "camera/height", cam.height);
  get(c, "camera/focal_px", cam.focal_px);
  get(c, "camera/baseline_m", cam.baseline_m);
  get(c, "camera/rate_hz", cam.rate_hz);
  get(c, "camera/distortion_left", cam.distortion_left);
  get(c, "camera/distortion_right", cam.distortion_right);
  get(c, "camera/principal_offset_left", cam.principal_offset_left);
  get(c, "camera/principal_offset_right", cam.principal_offset_right);
  get(c, "camera/focal_ratio_right", cam.focal_ratio_right);
  get(c, "camera/relative_rotation_deg", cam.relative_rotation_deg);
  get(c, "camera/baseline_offset_m", cam.baseline_offset_m);
  get(c, "camera/relative_rotation_step_deg", cam.relative_rotation_step_deg);
  get(c, "camera/relative_rotation_step_s", cam.relative_rotation_step_s);
  get(c, "camera/relative_rotation_drift_deg_per_min", cam.relative_rotation_drift_deg_per_min);
  get(c, "camera/noise_sigma", cam.noise_sigma);
  get(c, "camera/gain_left_db", cam.gain_left_db);
  get(c, "camera/gain_right_db", cam.gain_right_db);
  get(c, "camera/exposure_us", cam.exposure_us);
  get(c, "camera/motion_blur", cam.motion_blur);
  get(c, "camera/blur_step_px", cam.blur_step_px);
  get(c, "camera/max_blur_samples", cam.max_blur_samples);
  get(c, "camera/auto_exposure", cam.auto_exposure);
  get(c, "camera/ae_target_grey", cam.ae_target_grey);
  get(c, "camera/ae_min_exposure_us", cam.ae_min_exposure_us);
  get(c, "camera/ae_max_exposure_us", cam.ae_max_exposure_us);
  get(c, "camera/ae_max_gain_db", cam.ae_max_gain_db);
  get(c, "camera/vignetting", cam.vignetting);
  get(c, "camera/frame_loss", cam.frame_loss);
  get(c, "camera/latency_us", cam.latency_us);
  get(c, "camera/stamp_offset_us", cam.stamp_offset_us);
  get(c, "camera/jitter_us", cam.jitter_us);
  get(c, "camera/near_m", cam.near_m);

  ImuFigures& imu = s.imu;
  get(c, "imu/rate_hz", imu.rate_hz);
  get(c, "imu/gyro_arw_deg_sqrt_h", imu.gyro_arw_deg_sqrt_h);
  get(c, "imu/accel_vrw_mg_sqrt_hz", imu.accel_vrw_mg_sqrt_hz);
  get(c, "imu/gyro_bias_deg_s", imu.gyro_bias_deg_s);
  get(c, "imu/accel_bias_mg", imu.accel_bias_mg);
  get(c, "imu/gyro_bias_walk_deg_s_sqrt_s", imu.gyro_bias_walk_deg_s_sqrt_s);
  get(c, "imu/accel_bias_walk_mg_sqrt_s", imu.accel_bias_walk_mg_sqrt_s);
  get(c, "imu/gyro_lsb_deg_s", imu.gyro_lsb_deg_s);
  get(c, "imu/accel_lsb_mg", imu.accel_lsb_mg);
  get(c, "imu/gyro_range_deg_s", imu.gyro_range_deg_s);
  get(c, "imu/accel_range_g", imu.accel_range_g);
  get(c, "imu/misalignment_mrad", imu.misalignment_mrad);
  get(c, "imu/lever_arm_m", imu.lever_arm_m);
  get(c, "imu/latency_us", imu.latency_us);
  get(c, "imu/stamp_offset_us", imu.stamp_offset_us);
  get(c, "imu/jitter_us", imu.jitter_us);

  TiltFigures& tilt = s.tilt;
  get(c, "tilt/rate_hz", tilt.rate_hz);
  get(c, "tilt/resolution_deg", tilt.resolution_deg);
  get(c, "tilt/accuracy_deg", tilt.accuracy_deg);
  get(c, "tilt/noise_deg", tilt.noise_deg);
  get(c, "tilt/time_constant_s", tilt.time_constant_s);
  get(c, "tilt/misalignment_deg", tilt.misalignment_deg);
  get(c, "tilt/latency_us", tilt.latency_us);
  get(c, "tilt/stamp_offset_us", tilt.stamp_offset_us);
  get(c, "tilt/jitter_us", tilt.jitter_us);

  CalibrationErrors& ce = s.calibration_errors;
  get(c, "calibration_errors/focal_rel", ce.focal_rel);
  get(c, "calibration_errors/principal_px", ce.principal_px);
  get(c, "calibration_errors/stereo_rotation_deg", ce.stereo_rotation_deg);
  get(c, "calibration_errors/imu_rotation_deg", ce.imu_rotation_deg);
  get(c, "calibration_errors/tilt_rotation_deg", ce.tilt_rotation_deg);

  TrajectoryConfig& tr = s.trajectory;
  get(c, "trajectory/type", tr.type);
  if (c.has("trajectory/waypoints")) {
    cv::Mat w = c.getMat("trajectory/waypoints");
    if (w.total() < 2 || w.total() % 2 != 0)
      throw ConfigError(path + ": key 'trajectory/waypoints' must be a flat list x0, y0, x1, y1, ...");
    w = w.reshape(1, 1);
    tr.waypoints.clear();
    for (size_t i = 0; i + 1 < w.total(); i += 2)
      tr.waypoints.emplace_back(w.at<double>(0, static_cast<int>(i)), w.at<double>(0, static_cast<int>(i + 1)));
  }
  get(c, "trajectory/speed_mps", tr.speed_mps);
  get(c, "trajectory/height_m", tr.height_m);
  get(c, "trajectory/knot_spacing_s", tr.knot_spacing_s);
  get(c, "trajectory/still_duration_s", tr.still_duration_s);
  get(c, "trajectory/start_still_s", tr.start_still_s);
  get(c, "trajectory/yaw_deg", tr.yaw_deg);
  get(c, "trajectory/pitch_down_deg", tr.pitch_down_deg);
  get(c, "trajectory/roll_deg", tr.roll_deg);
  get(c, "trajectory/step_frequency_hz", tr.step_frequency_hz);
  get(c, "trajectory/bounce_m", tr.bounce_m);
  get(c, "trajectory/sway_m", tr.sway_m);
  get(c, "trajectory/nod_deg", tr.nod_deg);
  get(c, "trajectory/roll_sway_deg", tr.roll_sway_deg);
  get(c, "trajectory/yaw_sway_deg", tr.yaw_sway_deg);
  get(c, "trajectory/ramp_s", tr.ramp_s);
  get(c, "trajectory/wave_amplitude_deg", tr.wave_amplitude_deg);
  get(c, "trajectory/wave_period_s", tr.wave_period_s);
  if (c.has("trajectory/stations")) {
    cv::Mat st = c.getMat("trajectory/stations");
    if (st.total() < 6 || st.total() % 6 != 0)
      throw ConfigError(path + ": key 'trajectory/stations' must be a flat list x, y, z, roll, pitch, yaw, ...");
    st = st.reshape(1, 1);
    tr.stations.clear();
    for (int i = 0; i + 5 < static_cast<int>(st.total()); i += 6)
      tr.stations.push_back({{st.at<double>(0, i), st.at<double>(0, i + 1), st.at<double>(0, i + 2)},
                             {st.at<double>(0, i + 3), st.at<double>(0, i + 4), st.at<double>(0, i + 5)}});
  }
  get(c, "trajectory/station_hold_s", tr.station_hold_s);
  get(c, "trajectory/station_move_s", tr.station_move_s);

  WorldConfig& w = s.world;
  get(c, "world/data_dir", w.data_dir);
  get(c, "world/wall_height_m", w.wall_height_m);
  get(c, "world/corridor_width_m", w.corridor_width_m);
  get(c, "world/building_size_m", w.building_size_m);
  get(c, "world/weak_texture_share", w.weak_texture_share);
  get(c, "world/weak_floor", w.weak_floor);
  get(c, "world/poster_spacing_m", w.poster_spacing_m);
  get(c, "world/object_spacing_m", w.object_spacing_m);
  get(c, "world/texel_m", w.texel_m);
  get(c, "world/chart_inner_corners", w.chart_inner_corners);
  get(c, "world/chart_square_m", w.chart_square_m);
  get(c, "world/chart_centre_m", w.chart_centre_m);
  get(c, "world/chart_facing_deg", w.chart_facing_deg);
  get(c, "world/type", w.type);
  get(c, "world/street_half_width_m", w.street_half_width_m);
  get(c, "world/street_facade_height_m", w.street_facade_height_m);
  get(c, "world/street_gap_share", w.street_gap_share);
  get(c, "world/far_buildings", w.far_buildings);
  get(c, "world/far_distance_m", w.far_distance_m);
  get(c, "world/far_height_m", w.far_height_m);
  get(c, "world/sky_distance_m", w.sky_distance_m);
  cv::Mat lanes;
  if (getRecords(c, "world/people", 6, "x0, y0, x1, y1, speed_mps, dwell_s", lanes)) {
    w.people.clear();
    for (int i = 0; i < lanes.rows; ++i)
      w.people.push_back({{lanes.at<double>(i, 0), lanes.at<double>(i, 1)},
                          {lanes.at<double>(i, 2), lanes.at<double>(i, 3)},
                          lanes.at<double>(i, 4),
                          lanes.at<double>(i, 5)});
  }
  get(c, "world/person_size_m", w.person_size_m);
  get(c, "world/person_clearance_m", w.person_clearance_m);
  cv::Mat zones;
  if (getRecords(c, "world/lighting_zones", 5, "x0, y0, x1, y1, ratio", zones)) {
    w.lighting_zones.clear();
    for (int i = 0; i < zones.rows; ++i)
      w.lighting_zones.push_back({{zones.at<double>(i, 0), zones.at<double>(i, 1)},
                                  {zones.at<double>(i, 2), zones.at<double>(i, 3)},
                                  zones.at<double>(i, 4)});
  }
  get(c, "world/lighting_transition_m", w.lighting_transition_m);
  get(c, "world/ramp_start_m", w.ramp.start_m);
  get(c, "world/ramp_heading_deg", w.ramp.heading_deg);
  get(c, "world/ramp_width_m", w.ramp.width_m);
  get(c, "world/ramp_rise_m", w.ramp.rise_m);
  get(c, "world/ramp_slope", w.ramp.slope);
  get(c, "world/ramp_plateau_m", w.ramp.plateau_m);
  get(c, "world/ramp_blend_m", w.ramp.blend_m);
  get(c, "world/weak_stretch_m", w.weak_stretch_m);
  if (w.type == "street") w.route = tr.waypoints;
  tr.floor_ramp = w.ramp;  // the walker walks on the world's floor
  c.refuseUnreadKeys();    // a misspelled key would leave the default world or head in place

  try {
    s.validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(path + ": " + e.what());
  }
  return s;
}

}  // namespace

Scenario Scenario::load(const std::string& path) { return loadOver(path, 0); }

void Scenario::validate() const {
  auto require = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(what);
  };
  require(camera.width >= 16 && camera.height >= 16 && camera.width <= 8192 && camera.height <= 8192,
          "camera/width, height must be in 16..8192");
  require(camera.focal_px > 0, "camera/focal_px must be positive");
  require(camera.baseline_m > 0, "camera/baseline_m must be positive");
  require(camera.rate_hz > 0 && camera.rate_hz <= 120, "camera/rate_hz must be in (0, 120]");
  require(camera.noise_sigma >= 0, "camera/noise_sigma must not be negative");
  require(camera.latency_us >= 0 && imu.latency_us >= 0 && tilt.latency_us >= 0, "latency_us must not be negative");
  require(camera.near_m > 0, "camera/near_m must be positive");
  require(camera.exposure_us > 0 && camera.exposure_us < 1e6 / camera.rate_hz,
          "camera/exposure_us must be positive and shorter than the frame interval");
  const int blur_bound = camera.max_blur_samples;
  require(camera.blur_step_px > 0 &&
              (blur_bound == 1 || blur_bound == 3 || blur_bound == 9 || blur_bound == 27 || blur_bound == 81),
          "camera/blur_step_px must be positive, max_blur_samples a power of 3 in 1..81");
  require(camera.ae_target_grey > 0 && camera.ae_target_grey < 255 && camera.ae_min_exposure_us > 0 &&
              camera.ae_min_exposure_us <= camera.ae_max_exposure_us &&
              camera.ae_max_exposure_us < 1e6 / camera.rate_hz && camera.ae_max_gain_db >= 0,
          "camera/ae_*: target grey in (0, 255), 0 < min <= max exposure < the frame interval, max gain >= 0 dB");
  require(camera.frame_loss >= 0 && camera.frame_loss < 1, "camera/frame_loss must be in [0, 1)");
  require(camera.relative_rotation_step_deg.norm() < 5 && camera.relative_rotation_drift_deg_per_min.norm() < 5 &&
              camera.relative_rotation_step_s >= 0,
          "camera/relative_rotation_step_deg and _drift_deg_per_min must be below 5 deg, the step time not negative");
  require(imu.rate_hz > 0 && imu.rate_hz <= 10000, "imu/rate_hz must be in (0, 10000]");
  require(tilt.rate_hz > 0 && tilt.rate_hz <= 1000, "tilt/rate_hz must be in (0, 1000]");
  require(tilt.time_constant_s >= 0, "tilt/time_constant_s must not be negative");
  const CalibrationErrors& ce = calibration_errors;
  require(ce.focal_rel >= 0 && ce.focal_rel < 0.1 && ce.principal_px >= 0 && ce.principal_px < 50 &&
              ce.stereo_rotation_deg >= 0 && ce.stereo_rotation_deg < 5 && ce.imu_rotation_deg >= 0 &&
              ce.imu_rotation_deg < 5 && ce.tilt_rotation_deg >= 0 && ce.tilt_rotation_deg < 5,
          "calibration_errors must be non-negative and small (focal_rel < 0.1, principal_px < 50, rotations < 5 deg)");
  require(trajectory.type == "walk" || trajectory.type == "vehicle" || trajectory.type == "still" ||
              trajectory.type == "wave" || trajectory.type == "stations",
          "trajectory/type must be walk, vehicle, still, wave or stations");
  require(trajectory.type != "stations" ||
              (!trajectory.stations.empty() && trajectory.station_hold_s > 0 && trajectory.station_move_s > 0),
          "trajectory/type stations needs trajectory/stations and positive station_hold_s, station_move_s");
  require(trajectory.wave_amplitude_deg.cwiseAbs().maxCoeff() <= 60 && trajectory.wave_period_s.minCoeff() > 0,
          "trajectory/wave_amplitude_deg must be within 60 deg, wave_period_s positive");
  require(!trajectory.waypoints.empty(), "trajectory/waypoints must not be empty");
  require(trajectory.speed_mps > 0, "trajectory/speed_mps must be positive");
  require(trajectory.knot_spacing_s > 0, "trajectory/knot_spacing_s must be positive");
  require(trajectory.still_duration_s >= 0, "trajectory/still_duration_s must not be negative");
  require(trajectory.start_still_s >= 0, "trajectory/start_still_s must not be negative");
  require(world.wall_height_m > 0.5 && world.corridor_width_m > 0.5, "world/wall_height_m, corridor_width_m too small");
  require(world.building_size_m.x() > 2 * world.corridor_width_m + 1 &&
              world.building_size_m.y() > 2 * world.corridor_width_m + 1,
          "world/building_size_m must leave room for the inner block");
  require(world.texel_m > 0, "world/texel_m must be positive");
  require(world.chart_inner_corners.isZero() ||
              (world.chart_inner_corners.minCoeff() >= 2 && world.chart_inner_corners.maxCoeff() <= 30 &&
               world.chart_inner_corners == world.chart_inner_corners.array().round().matrix() &&
               world.chart_square_m > 0.005 && world.chart_square_m < 1),
          "world/chart_inner_corners must be 0 0 or whole numbers in 2..30, chart_square_m in (0.005, 1) m");
  require(world.type == "building" || world.type == "street", "world/type must be building or street");
  if (world.type == "street") {
    require(world.route.size() >= 2, "world/type street needs at least two trajectory/waypoints (the streets)");
    require(world.street_half_width_m > 2, "world/street_half_width_m must exceed 2 m");
    require(
        world.street_facade_height_m.x() > 0 && world.street_facade_height_m.y() >= world.street_facade_height_m.x(),
        "world/street_facade_height_m must be [low, high] with 0 < low <= high");
    require(world.street_gap_share >= 0 && world.street_gap_share < 1, "world/street_gap_share must be in [0, 1)");
    require(world.far_buildings >= 0 && world.far_buildings <= 1000, "world/far_buildings must be in 0..1000");
    require(
        world.far_distance_m.x() > world.street_half_width_m && world.far_distance_m.y() >= world.far_distance_m.x(),
        "world/far_distance_m must be [near, far] beyond the street");
    require(world.far_height_m.x() > 0 && world.far_height_m.y() >= world.far_height_m.x(),
            "world/far_height_m must be [low, high] with 0 < low <= high");
    require(world.sky_distance_m > 2 * world.far_distance_m.y(),
            "world/sky_distance_m must be beyond the far buildings");
  }
  require(world.poster_spacing_m > 0 && world.object_spacing_m > 0,
          "world/poster_spacing_m, object_spacing_m must be positive");
  for (const PersonLane& lane : world.people)
    require((lane.to - lane.from).norm() > 0.1 && lane.speed_mps > 0 && lane.speed_mps < 5 && lane.dwell_s >= 0,
            "world/people: each lane longer than 0.1 m, speed in (0, 5) m/s, dwell not negative");
  require(world.person_size_m.minCoeff() > 0.05 && world.person_size_m.maxCoeff() < 3 && world.person_clearance_m >= 0,
          "world/person_size_m must be in (0.05, 3) m, person_clearance_m not negative");
  for (const LightingZone& zone : world.lighting_zones)
    require(zone.high.x() > zone.low.x() && zone.high.y() > zone.low.y() && zone.ratio >= 0 && zone.ratio <= 100,
            "world/lighting_zones: each x0 < x1, y0 < y1, ratio in [0, 100]");
  require(world.lighting_transition_m > 0, "world/lighting_transition_m must be positive");
  const Ramp& ramp = world.ramp;
  require(
      ramp.rise_m >= 0 && ramp.slope > 0 && ramp.slope < 1 && ramp.width_m > 0 && ramp.plateau_m >= 0 &&
          ramp.blend_m > 0 && (!ramp.any() || (ramp.blend_m <= ramp.run() && ramp.blend_m <= ramp.plateau_m)),
      "world/ramp_*: rise not negative, slope in (0, 1), width positive, blend positive and at most the slope's run "
      "and the plateau");
  require(trajectory.floor_ramp == world.ramp,
          "trajectory/floor_ramp must be world/ramp (the walker walks on the world's floor; Scenario::load copies it)");
  const Eigen::Matrix<double, 4, 1>& weak = world.weak_stretch_m;
  require(weak.isZero() || (weak[2] > weak[0] && weak[3] > weak[1]),
          "world/weak_stretch_m must be 0 0 0 0 or x0, y0, x1, y1 with x0 < x1, y0 < y1");
}

std::vector<std::string> simEffects(const Scenario& sc) {
  const Scenario walk = Scenario::defaults();
  const CameraFigures& c = sc.camera;
  std::vector<std::string> on;
  auto add = [&](bool is_on, const char* name) {
    if (is_on) on.push_back(name);
  };
  add(c.motion_blur, "motion_blur");
  add(c.auto_exposure, "auto_exposure");
  add(c.vignetting, "vignetting");
  add(c.frame_loss > 0, "frame_loss");
  add(c.stamp_offset_us != 0 || sc.imu.stamp_offset_us != 0 || sc.tilt.stamp_offset_us != 0, "stamp_offsets");
  add(sc.calibration_errors.any(), "perturbed_calibration");
  add(c.relative_rotation_step_deg.norm() > 0, "camera_knock");
  add(c.relative_rotation_drift_deg_per_min.norm() > 0, "camera_drift");
  add(sc.world.weak_texture_share > walk.world.weak_texture_share, "weak_texture");
  add(!sc.world.people.empty(), "people");
  bool lighting = false;
  for (const LightingZone& zone : sc.world.lighting_zones) lighting |= zone.ratio != 1.0;
  add(lighting, "lighting_zones");
  add(sc.world.ramp.any(), "ramp");
  add(!sc.world.weak_stretch_m.isZero(), "weak_stretch");
  return on;
}

}  // namespace ips::sim
