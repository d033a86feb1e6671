#pragma once
// The main job's report as a library: read a run's recording (the results, the states and the bulk bus, each in its
// parts), judge whether it is complete and what disturbed it, and score it section by section, each section a
// function returning its members of report.json. ips_report is a thin main over these; its page only renders what
// they return. Reads recordings through the framework's log reader and decodes the system's message types; it
// never touches a bus.
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <ips/disparity_map_t.hpp>
#include <ips/filter_state_t.hpp>
#include <ips/health_t.hpp>
#include <ips/tracker_delta_t.hpp>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "ips/calibration.hpp"
#include "ips/eval/trajectory.hpp"
#include "ips/framework/log_reader.hpp"

namespace ips::sim {
class World;
}

namespace ips::eval {

// report.json keeps its members in the order the sections write them.
using Json = nlohmann::ordered_json;

// A figure as report.json writes it: six significant digits, null where it is not finite.
Json figure(double v);

// Evenly spaced indices into a series of n samples, at most `max_samples` of them, the last sample included (what the
// page draws of a long series).
std::vector<size_t> subsample(size_t n, size_t max_samples);

// One filter's published states (a posteriori only), as recorded.
struct FilterRun {
  std::string channel;
  int8_t type = 0;
  std::vector<ips::filter_state_t> states;
};

// A process's health over the run.
struct ProcessFigures {
  double rate_sum = 0;
  int rate_n = 0;
  double latency_sum = 0;
  int latency_n = 0;
  ips::health_t last;
  // Over the run, for the page: the stamp of the newest input [s], the mean processing time [ms] and the input rate
  // [Hz] of each report interval.
  std::vector<double> t, latency_ms, rate_hz;
};

// The points the mapper (or E3D from one camera) published for one disparity map.
struct MapPoints {
  int64_t utime = 0;
  std::vector<Eigen::Vector3d> points;
};

// What a run's recording holds, each channel's messages in order (repeats and stamps off the time line left out).
struct RunLog {
  std::vector<FilterRun> runs;  // one per filter channel asked for, in that order (empty where it did not run)
  Trajectory gt;                // GT_POSE, by time, one pose per stamp
  std::map<int64_t, ips::disparity_map_t> gt_disp, est_disp;  // GT_DISPARITY, DISPARITY by utime
  std::map<std::string, ProcessFigures> procs;                // by health's process name
  int64_t deltas = 0, deltas_valid = 0;
  std::vector<ips::tracker_delta_t> delta_msgs;  // TRACKER_DELTA by utime
  std::vector<MapPoints> map_points;             // POINTS: the mapper's points of each disparity map
  std::vector<MapPoints> map_points_gt_poses;    // POINTS_GT_POSES: the same placed with the true poses
  std::vector<MapPoints> mono_points;            // MONO_POINTS: E3D's depth from one camera, filter's poses
  // What makes the figures untrustworthy, found while reading: a damaged part, a recorder restarted.
  std::vector<std::string> failures;
  std::map<std::string, int64_t> last_health_log_us;  // per process: logger time of its last health message
  int64_t last_input_log_us = 0;                      // logger time of the last ground-truth pose (the input)
  int64_t last_log_us = 0;                            // logger time of the recording's last event
  int64_t bad_messages = 0;                           // undecodable, invalid or out of order
  int64_t events = 0;
};

// Calls fn for every message of the LCM log at `path`, in order. A damaged log ends the reading there and is
// recorded in `failures` (what was read before still counts). Returns the messages read.
template <class Fn>
int64_t forEachMessage(const std::string& path, std::vector<std::string>& failures, Fn fn) {
  ips::fw::LogReader reader(path);
  ips::fw::LogMessage m;
  try {
    while (reader.next(&m)) fn(m);
  } catch (const ips::fw::LogError& err) {
    failures.push_back(err.what());
  }
  return reader.events();
}

// The recorders' files, each a list of parts in order (lcm-logger -i starts FILE.00, then FILE.01 when restarted).
struct RunLogFiles {
  std::vector<std::string> results;  // the main recorder (deltas, health, the truth, ...)
  std::vector<std::string> states;   // the states at IMU rate and the truth, where they had a recorder of their own
  std::vector<std::string> bulk;     // the bulk bus's dense maps and points, where it had one
};
RunLog readRunLog(const RunLogFiles& files, const std::vector<std::string>& filter_channels);

// What the report takes from the input log (the log the player played), in one pass: its last ground-truth stamp
// [us] (0 when it has none) and the IMU's samples (those that pass the framework's checks, in time order; an
// IMU-less head has none). A damaged log is named in `failures`.
struct InputLog {
  int64_t truth_end_us = 0;
  std::vector<filter::ImuSample> imu;
};
InputLog readInputLog(const std::string& input_log, std::vector<std::string>& failures);

// Completeness: the recording holds a run's results, every state stream runs to the end of the input without a pause,
// every process kept reporting, the player played its log to the end (by its own account and, where the input log's
// end is known, `input_truth_end_us`), and who cut a recording short. `label` names the recording in a failure.
std::vector<std::string> completenessFailures(const RunLog& log, const std::string& label,
                                              std::optional<int64_t> input_truth_end_us);

// What disturbed a complete run, each named with the process and the time: inputs lost on the way, IMU gaps
// bridged, deltas not fused, pairs dropped, states lost to the recorder, a covariance that jumped.
std::vector<std::string> disturbances(const RunLog& log);

// The time the page's axes start at [s]: the first ground truth or filter state, else the first delta.
double pageStartTime(const RunLog& log);

// distance_m, duration_s, tracker_deltas, tracker_deltas_valid.
Json overviewSection(const RunLog& log);

// A filter's errors against the truth over time, with the bounds its covariance claims: position [m] and attitude
// error (rotation vector in world) [deg] per axis, their 3-sigma, and the position NEES.
struct ErrorSeries {
  std::vector<double> t, nees;
  std::array<std::vector<double>, 3> pos, pos3s, att, att3s;
  double nees_mean = NAN;
  double nees_in_band_pct = NAN;
  // The heading error (the attitude error about the world's vertical) over every state with an attitude covariance:
  // its largest magnitude and the share of states where it lies inside the filter's own 3-sigma bound.
  double heading_error_max_deg = NAN;
  double heading_within_3sigma_pct = NAN;
};

// One filter judged against the truth: its states put on the truth by its first pose, and its errors over time.
struct FilterResult {
  std::string channel, name;  // name: "ekf" or "ukf"
  Trajectory aligned;
  ErrorSeries errors;  // every state's NEES; the page's samples (at most max_error_samples) of the rest
};
struct FiltersSection {
  Json json;  // filters (one entry each), end_error_m, end_error_pct, ate_rmse_m (of the first)
  std::vector<FilterResult> results;
};
// `truth`: the head's true calibration where known (lever arm and camera-alignment errors); `ran_on`: the one the
// processes ran on.
FiltersSection filtersSection(const RunLog& log, const std::optional<ips::StereoCalibration>& truth,
                              const std::optional<ips::StereoCalibration>& ran_on, double t0, size_t max_error_samples);

// The transform that puts an estimate's first pose on the truth at that time: by heading and position for a filter
// in the world frame (roll and pitch are its own), by the whole pose for one in the start frame.
Eigen::Isometry3d startAlignment(const Trajectory& est, const Trajectory& gt, bool whole_pose);
Trajectory statesTrajectory(const FilterRun& run);

// The relative errors' sub-sequence lengths [m] when none are asked for: 10, 20, 40 m on a walk longer than 40 m,
// else 1, 2 m.
std::vector<double> defaultRpeLengths(double distance_m);

// Every estimator against the truth, as recordings are judged: ATE (SE(3)-aligned), relative errors over
// sub-sequences of fixed length and the end error with the first pose aligned; the tracker's chained increments
// (camera 0) against the truth carried to camera 0 by `T_imu_cam0`, with its covariance's honesty.
struct EstimatorsSection {
  Json json;                          // estimators, rpe_lengths_m
  std::vector<std::string> warnings;  // deltas missing from the recording
  Trajectory tracker;                 // the chain, camera 0, in its own start frame
  Trajectory truth_cam0;              // the truth carried to camera 0
  Trajectory tracker_on_truth;        // the chain put on the truth by its first pose (the page draws it)
};
EstimatorsSection estimatorsSection(const RunLog& log, const Eigen::Isometry3d& T_imu_cam0,
                                    const std::vector<double>& lengths);

// The tracker's, the IMU's and the truth's errors over spans of 1, 2, 4 and 8 frames (span_noise.hpp), none taken as
// the reference: at which spans the IMU can correct the tracker. "span_noise": null without an IMU, a truth or the
// tracker's increments, or where the tracker's poses and the truth do not overlap. `imu_white_noise_mm` is what the
// calibration's accelerometer noise density alone gives.
Json spanNoiseSection(const RunLog& log, const std::vector<filter::ImuSample>& imu, const Trajectory& tracker_cam0,
                      const std::optional<ips::StereoCalibration>& truth_calib);

// E3D's maps against the simulator's truth, at E3D's scale, for every map that has one.
struct DisparityScore {
  int64_t seq = 0;
  double bad2_pct = 0;
  double density_pct = 0;
  int64_t evaluated = 0;
};
// Pixels this far off the truth are bad; the pictures' error scale is twice it.
constexpr double kBadDisparityPx = 2.0;
std::vector<DisparityScore> disparityScores(const RunLog& log);
// disparity_maps, disparity_maps_with_ground_truth, disparity_bad2_pct, disparity_density_pct.
Json disparitySection(const RunLog& log, const std::vector<DisparityScore>& scores);

// The mapper's map: its size, its points against the simulated world's surfaces where it is known (placed with the
// filter's poses and put on the truth by the first filter's start alignment; and, where given, the map placed with
// the true poses), the later half of the run against the earlier, and depth from one camera beside the stereo points.
// map_points, map_*_surface_error_m, map_within_5cm_pct, map_consistency_*, mono_maps, mono_*/stereo_* (with suffix
// _gt_poses for the map on the true poses).
Json mapSection(const RunLog& log, const std::vector<Eigen::Vector3d>& map,
                const std::optional<std::vector<Eigen::Vector3d>>& map_gt_poses, const ips::sim::World* world);
// The body's up at the tracker's first increment, by the truth: the map's world up when its world is that body.
Eigen::Vector3d mapUpFromTruth(const RunLog& log);

// processes: each one's mean rate and latency, its last totals and counters.
Json processesSection(const RunLog& log);

// The figures the calibration tools wrote into a calibration file (its top-level "*_figures" blocks, their numbers
// and words), so that a run on an estimated calibration says how good it was; {} when the file has none.
Json calibrationFigures(const std::string& calibration_path);

// "failed" where anything makes the figures untrustworthy, "disturbed" where something disturbed a complete run,
// else "ok".
std::string runStatus(const std::vector<std::string>& failures, const std::vector<std::string>& warnings);

}  // namespace ips::eval
