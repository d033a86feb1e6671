// ips_report: the main job's report. Reads the LCM log recorded while the system ran (filter states, tracker
// deltas, disparity maps, health, and the simulator's ground truth) and writes report.json with the figures
// of the run, and report.html: one self-contained page (report_page.html filled with the run's data) that draws
// the figures table, the trajectories against ground truth, the filters' errors with their 3-sigma bounds and
// NEES, the tracker's inliers and the processes' latency over time, disparity examples with colour bars beside
// ground truth and the error map, and one of them triangulated into a 3D point cloud. The run's PNG pictures
// are screenshots of that page (tools/report/render_pictures.sh).
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <ips/disparity_map_t.hpp>
#include <ips/filter_state_t.hpp>
#include <ips/ground_truth_t.hpp>
#include <ips/health_t.hpp>
#include <ips/point_cloud_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <ips/tracker_delta_t.hpp>
#include <iterator>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <set>
#include <sstream>

#include "ips/calibration.hpp"
#include "ips/data_dir.hpp"
#include "ips/eval/disparity.hpp"
#include "ips/eval/map_errors.hpp"
#include "ips/eval/trajectory.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/log_reader.hpp"
#include "ips/framework/message_arrays.hpp"
#include "ips/framework/process.hpp"
#include "ips/framework/validate.hpp"
#include "ips/mapper/voxel_map.hpp"
#include "ips/sim/scenario.hpp"
#include "ips/tracker/delta_chain.hpp"
#include "report_page.hpp"

namespace {

using ips::eval::Trajectory;
using ips::eval::TrajPoint;

// The figures the calibration tools wrote into the calibration file (its top-level "*_figures" blocks, their
// numbers and words; lists such as the views are left out) as a JSON object, so that a run on an estimated
// calibration says how good it was. "{}" when the file has none.
std::string calibrationFiguresJson(const std::string& path) {
  cv::FileStorage fs;
  try {
    if (path.empty() || !fs.open(path, cv::FileStorage::READ)) return "{}";
  } catch (const cv::Exception&) {
    return "{}";
  }
  std::ostringstream js;
  js << std::setprecision(6) << "{";
  bool first_block = true;
  for (const cv::FileNode& block : fs.root()) {
    const std::string name = block.name();
    if (!block.isMap() || name.size() < 8 || name.compare(name.size() - 8, 8, "_figures") != 0) continue;
    js << (first_block ? "" : ", ") << ips::report::jsonString(name) << ": {";
    first_block = false;
    bool first = true;
    for (const cv::FileNode& item : block) {
      if (!(item.isInt() || item.isReal() || item.isString())) continue;
      js << (first ? "" : ", ") << ips::report::jsonString(item.name()) << ": ";
      if (item.isString())
        js << ips::report::jsonString(static_cast<std::string>(item));
      else
        js << static_cast<double>(item);
      first = false;
    }
    js << "}";
  }
  js << "}";
  return js.str();
}

template <class Msg>
bool decode(const ips::fw::LogMessage& e, Msg* m) {
  return m->decode(e.data.data(), 0, static_cast<int>(e.data.size())) >= 0;
}

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

// A state stream that pauses this long, or ends this long before the input does, means the estimator died,
// restarted or stalled: its figures would describe part of the run as if it were all of it. Longer than the
// filter's reordering window (0.5 s) and its paced flush at shutdown.
constexpr double kMaxStateGapS = 2.0;
// A process whose health messages (sent every second while it runs) stop this long before the input ends died.
constexpr double kMaxHealthSilenceS = 10.0;
// A recording whose every channel ends within this of its input's last event was cut by the recorder (the disk
// full, the logger killed): where the player stops first, the processes go on sending their health every second and
// the recorder keeps recording it. Two and a half health periods.
constexpr double kRecordingCutS = 2.5;
// What the page draws per series: enough for a line that looks continuous at a screen's width (a few thousand
// pixels), few enough that the self-contained page stays a few megabytes for a run of hours.
constexpr size_t kMaxPageTrajectoryPoints = 3000;
constexpr size_t kMaxPageErrorSamples = 2000;
// The 3D view's point cloud (one disparity map triangulated): enough to see the scene's surfaces, few enough
// to rotate smoothly in a laptop's browser.
constexpr size_t kMaxCloudPoints = 40000;
// The map on the page: every voxel up to this many (a building's map of a few 100 000 voxels is thinned evenly).
constexpr size_t kMaxMapPagePoints = 120000;
// A map point "on" the surface: within the map's voxel size.
constexpr double kMapWithinM = 0.05;
// The later part of a run "sees the same surface" as the earlier one where their points are this close: a few
// voxels, more than the drift of a good run, less than the distance between walls.
constexpr double kMapOverlapM = 0.25;
// Points drawn evenly from all published clouds of one kind for their distances to the true surfaces.
constexpr size_t kSurfaceSamplePoints = 200000;
// Disparities below one pixel are not triangulated: there a quarter-pixel matching error moves the point by more
// than a quarter of its depth.
constexpr double kMinCloudDisparityPx = 1.0;
// The disparity error map's scale: twice the bad-pixel threshold of the figures, so that its middle is the
// threshold.
constexpr double kBadDisparityPx = 2.0;

struct FilterRun {
  std::string channel;
  int8_t type = 0;
  std::vector<ips::filter_state_t> states;
};

struct ProcessFigures {
  double rate_sum = 0;
  int rate_n = 0;
  double latency_sum = 0;
  int latency_n = 0;
  ips::health_t last;
  // Over the run, for the page: the stamp of the newest input [s], the mean processing time [ms] and the
  // input rate [Hz] of each report interval.
  std::vector<double> t, latency_ms, rate_hz;
};

struct DisparityScore {
  int64_t seq = 0;
  double bad2_pct = 0;
  double density_pct = 0;
  int64_t evaluated = 0;
};

TrajPoint toPoint(int64_t utime, const double* p, const double* q) {
  TrajPoint t;
  t.t = utime * 1e-6;
  t.p = Eigen::Vector3d(p[0], p[1], p[2]);
  t.q = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized();
  return t;
}

// The truth's position and attitude at time t (ips::eval::interpolate: linear, slerp; the end poses outside).
Eigen::Vector3d truthAt(const Trajectory& gt, double t) { return ips::eval::interpolate(gt, t).p; }
Eigen::Quaterniond truthAttitudeAt(const Trajectory& gt, double t) { return ips::eval::interpolate(gt, t).q; }

// The transform that puts an estimate's first pose on the ground truth at that time: how a dead-reckoning system is
// judged, the start being known. By heading and position for a filter in the world frame (roll and pitch are its
// own: gravity makes them observable); by the whole pose for one in the start frame (its roll and pitch are the
// start's by construction, and its covariance is that of the motion since).
Eigen::Isometry3d startAlignment(const Trajectory& est, const Trajectory& gt, bool whole_pose) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (est.empty() || gt.empty()) return T;
  const TrajPoint& e0 = est.front();
  Eigen::Quaterniond qg = gt.front().q;
  for (const auto& g : gt)
    if (g.t >= e0.t) {
      qg = g.q;
      break;
    }
  const Eigen::Vector3d pg = truthAt(gt, e0.t);
  auto yaw = [](const Eigen::Quaterniond& q) {
    const Eigen::Vector3d x = q * Eigen::Vector3d::UnitX();
    return std::atan2(x.y(), x.x());
  };
  T.linear() = whole_pose ? (qg * e0.q.inverse()).toRotationMatrix()
                          : Eigen::AngleAxisd(yaw(qg) - yaw(e0.q), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = pg - T.linear() * e0.p;
  return T;
}

Trajectory alignStart(const Trajectory& est, const Trajectory& gt, bool whole_pose) {
  const Eigen::Isometry3d T = startAlignment(est, gt, whole_pose);
  Trajectory out = est;
  for (auto& p : out) {
    p.p = T * p.p;
    p.q = Eigen::Quaterniond(T.linear()) * p.q;
  }
  return out;
}

// Where filter_state_t's error-state covariance holds the position and the attitude error (see its .lcm).
constexpr int kCovPosition = 0;
constexpr int kCovAttitude = 18;
// The two-sided 95 % band of a chi-square variable with 3 degrees of freedom (the position NEES of a
// consistent filter, one sample): 2.5 % and 97.5 % quantiles.
constexpr double kChi2Dof3Lo = 0.2158, kChi2Dof3Hi = 9.3484;

// A filter's errors against the truth over time, with the bounds its covariance claims: position [m] and
// attitude error (rotation vector in world) [deg] per axis, their 3-sigma, and the position NEES.
struct ErrorSeries {
  std::vector<double> t, nees;
  std::array<std::vector<double>, 3> pos, pos3s, att, att3s;
  double nees_mean = NAN;
  double nees_in_band_pct = NAN;
};

ErrorSeries errorSeries(const FilterRun& run, const Trajectory& est, const Trajectory& aligned, const Trajectory& gt,
                        double t0, size_t max_samples) {
  ErrorSeries out;
  const size_t n = std::min({run.states.size(), est.size(), aligned.size()});
  if (n == 0 || gt.empty()) return out;
  // The start alignment's rotation carries the filter's covariance into the truth's frame as well.
  const Eigen::Matrix3d R = (aligned.front().q * est.front().q.inverse()).toRotationMatrix();
  auto block = [](const ips::filter_state_t& s, int at) {
    Eigen::Matrix3d P;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) P(r, c) = s.covariance[at + r][at + c];
    return P;
  };
  const std::vector<size_t> shown = ips::report::subsample(n, max_samples);
  size_t next_shown = 0;
  double nees_sum = 0;
  int64_t nees_n = 0, nees_in = 0;
  for (size_t i = 0; i < n; ++i) {
    const ips::filter_state_t& s = run.states[i];
    const TrajPoint& p = aligned[i];
    const Eigen::Vector3d e = p.p - truthAt(gt, p.t);
    const bool has_pos = s.cov_dim >= kCovPosition + 3, has_att = s.cov_dim >= kCovAttitude + 3;
    Eigen::Matrix3d Pp = Eigen::Matrix3d::Constant(NAN), Pa = Eigen::Matrix3d::Constant(NAN);
    double nees = NAN;
    if (has_pos) {
      Pp = R * block(s, kCovPosition) * R.transpose();
      Eigen::LDLT<Eigen::Matrix3d> ldlt(Pp);
      if (ldlt.info() == Eigen::Success && ldlt.isPositive() && Pp.determinant() > 0) {
        nees = e.dot(ldlt.solve(e));
        nees_sum += nees, ++nees_n;
        nees_in += nees >= kChi2Dof3Lo && nees <= kChi2Dof3Hi ? 1 : 0;
      }
    }
    if (next_shown >= shown.size() || shown[next_shown] != i) continue;
    ++next_shown;
    if (has_att) Pa = R * block(s, kCovAttitude) * R.transpose();
    // q_true = exp(dtheta) * q_est: the attitude error as a rotation vector in world, as the covariance has it.
    // (Eigen's angle-axis of a quaternion has its angle in [0, pi]: the shortest rotation.)
    const Eigen::AngleAxisd d(truthAttitudeAt(gt, p.t) * p.q.inverse());
    const Eigen::Vector3d dtheta_w = d.angle() * d.axis();
    out.t.push_back(p.t - t0);
    out.nees.push_back(nees);
    for (int a = 0; a < 3; ++a) {
      out.pos[a].push_back(e[a]);
      out.pos3s[a].push_back(has_pos ? 3 * std::sqrt(std::max(0.0, Pp(a, a))) : NAN);
      out.att[a].push_back(dtheta_w[a] * 180 / M_PI);
      out.att3s[a].push_back(has_att ? 3 * std::sqrt(std::max(0.0, Pa(a, a))) * 180 / M_PI : NAN);
    }
  }
  if (nees_n) out.nees_mean = nees_sum / nees_n, out.nees_in_band_pct = 100.0 * nees_in / nees_n;
  return out;
}

// E3D's map against the true one, at E3D's scale (output_scale) and in its pixels, as stereo benchmarks at a
// reduced resolution count.
DisparityScore score(const ips::disparity_map_t& est, const ips::disparity_map_t& gt_msg) {
  const cv::Mat e = ips::fw::disparityImage(est);
  const cv::Mat g = ips::eval::truthAtSize(ips::fw::disparityImage(gt_msg), e.size());
  const ips::eval::DisparityErrors err = ips::eval::disparityErrors(e, g, {kBadDisparityPx});
  DisparityScore sc;
  sc.seq = est.seq;
  sc.bad2_pct = err.badPct(0);
  sc.density_pct = err.densityPct();
  sc.evaluated = err.evaluated;
  return sc;
}

std::string jsonNumber(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream os;
  os << std::setprecision(6) << v;
  return os.str();
}

// A counter of a health message, 0 when absent.
int64_t counterOf(const ips::health_t& h, const std::string& name) {
  for (int i = 0; i < h.num_counters; ++i)
    if (h.counter_names[i] == name) return h.counter_values[i];
  return 0;
}

// The time [s] of the first state of `run` at which a covariance block's standard deviation (sqrt of its trace,
// rows at `at`) has risen by more than `factor` and by more than `floor` within a second, and the two values; NAN
// when it never does. A filter's covariance grows smoothly between its measurements; a jump is a reset (an IMU gap
// bridged by resetting the rates, a restart) or a divergence.
struct CovarianceJump {
  double t = NAN, from = 0, to = 0;
};
CovarianceJump firstJump(const FilterRun& run, int at, double factor, double floor) {
  CovarianceJump jump;
  std::deque<std::pair<double, double>> window;  // (t, sigma), the second before, its minimum in front
  for (const auto& s : run.states) {
    if (s.cov_dim < at + 3) continue;
    const double t = s.utime * 1e-6;
    const double sigma =
        std::sqrt(std::max(0.0, s.covariance[at][at] + s.covariance[at + 1][at + 1] + s.covariance[at + 2][at + 2]));
    while (!window.empty() && window.front().first < t - 1.0) window.pop_front();
    while (!window.empty() && window.back().second >= sigma) window.pop_back();
    if (!window.empty() && sigma > factor * window.front().second && sigma - window.front().second > floor) {
      jump = {t, window.front().second, sigma};
      return jump;
    }
    window.emplace_back(t, sigma);
  }
  return jump;
}

std::vector<std::string> disturbances(const std::vector<FilterRun>& runs,
                                      const std::map<std::string, ProcessFigures>& procs, int64_t deltas_valid) {
  std::vector<std::string> out;
  auto fmt = [](double v, int decimals) {
    std::ostringstream os;
    os << std::fixed << std::setprecision(decimals) << v;
    return os.str();
  };
  for (const auto& [name, f] : procs) {
    const ips::health_t& h = f.last;
    // Inputs lost on the way to a process, bridged gaps in its IMU, deltas that came too late or were not fused.
    if (const int64_t lost = counterOf(h, "imu_seq_gap"))
      out.push_back(name + ": " + std::to_string(lost) + " IMU samples lost on the way (imu_seq_gap)");
    if (const int64_t gaps = counterOf(h, "imu_gaps"))
      out.push_back(name + ": " + std::to_string(gaps) + " gaps in the IMU bridged (imu_gaps)");
    const int64_t fused = counterOf(h, "tracker_accepted"), late = counterOf(h, "tracker_too_late");
    if (deltas_valid > 20 && h.num_counters > 0 && counterOf(h, "image_accepted") > 0 && fused < 0.9 * deltas_valid)
      out.push_back(name + ": fused " + std::to_string(fused) + " of " + std::to_string(deltas_valid) +
                    " valid tracker deltas (" + std::to_string(late) + " too late)");
    // Pairs lost on the bus before the tracker saw them: beyond what a camera loses itself (the simulated head drops
    // 1-2 %), navigation went without them. The dense products skip pairs by design.
    if (const int64_t lost = counterOf(h, "stereo_seq_gap");
        name == "tracker" && lost > 0.05 * static_cast<double>(lost + h.received))
      out.push_back(name + ": " + std::to_string(lost) + " pairs lost on the way (stereo_seq_gap)");
    if (const int64_t stale = counterOf(h, "stale_pair"); stale > 0 && stale > 0.005 * std::max<int64_t>(1, h.received))
      out.push_back(name + ": dropped " + std::to_string(stale) + " of " + std::to_string(h.received) +
                    " pairs it fell behind on (stale_pair)");
  }
  // States a filter sent (its health's published_<channel>) that the recording does not hold: lost between them.
  for (const auto& run : runs)
    for (const auto& [name, f] : procs)
      if (const int64_t sent = counterOf(f.last, "published_" + run.channel);
          sent > static_cast<int64_t>(run.states.size()))
        out.push_back(run.channel + ": the recording holds " + std::to_string(run.states.size()) + " of the " +
                      std::to_string(sent) + " states " + name + " published");
  constexpr int kPosition = 0, kAttitude = 18;  // filter_state_t's covariance layout
  for (const auto& run : runs) {
    if (run.states.empty()) continue;
    const double t0 = run.states.front().utime * 1e-6;
    const CovarianceJump p = firstJump(run, kPosition, 2.0, 0.01);
    if (std::isfinite(p.t))
      out.push_back(run.channel + ": position sigma rose from " + fmt(p.from, 3) + " to " + fmt(p.to, 3) +
                    " m within a second, at t=" + fmt(p.t - t0, 1) + " s of its states");
    const CovarianceJump a = firstJump(run, kAttitude, 2.0, 0.5 * M_PI / 180);
    if (std::isfinite(a.t))
      out.push_back(run.channel + ": attitude sigma rose from " + fmt(a.from * 180 / M_PI, 2) + " to " +
                    fmt(a.to * 180 / M_PI, 2) + " deg within a second, at t=" + fmt(a.t - t0, 1) + " s of its states");
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  return ips::fw::guardedMain("ips_report", [&]() {
    ips::Args args(argc, argv, "report of a run: trajectory errors, disparity quality, process figures");
    args.required(
            "--log", "FILE[,FILE]",
            "LCM log recorded during the run (filter states, deltas, disparity, health, GT), or its parts in order")
        .option("--states-log", "FILE[,FILE]",
                "the recording of the filters' states and the ground truth, or its parts in order, where the run had a "
                "recorder of its own for them")
        .option("--bulk-log", "FILE[,FILE]",
                "the recording of the bulk bus (disparity maps, points), or its parts in order, where the run had one")
        .option("--images", "FILE", "the input log with STEREO pairs (for the disparity pictures)")
        .option("--calib", "FILE", "the head's true calibration (for evaluation: rectifying the pictures' images)")
        .option("--process-calib", "FILE",
                "the calibration the processes ran on, whose source the report names; default: --calib")
        .option("--filters", "CH[,CH]", "filter state channels and their names", "FILTER_STATE,FILTER_STATE_UKF")
        .option("--pictures", "N", "disparity maps shown as examples on the page", "3")
        .option("--map", "FILE", "the mapper's map (PLY/PCD) placed with the filter's poses, shown and scored")
        .option("--map-gt-poses", "FILE", "the same maps placed with the ground truth's poses (scored beside it)")
        .option("--map-poses", "filter|tracker",
                "what placed the --map: the filter's states or the tracker's increments", "filter")
        .option(
            "--world-seed", "N",
            "the simulated world the run saw (the sim's --seed): the maps' points are scored against its surfaces,\n"
            "and sim_effects lists what its scenario switched on")
        .option("--world-scenario", "FILE", "its scenario file (default: the built-in walk)")
        .option("--map-up", "X,Y,Z|truth",
                "the map's up direction, for the top view, in a world not levelled by an IMU: e.g. 0,-1,0 for a "
                "camera frame; truth: the map's world is the body at the first image and the ground truth's "
                "attitude there says where up is",
                "0,0,1")
        .option("--lengths", "M[,M]",
                "sub-sequence lengths of the relative errors (KITTI devkit style); default 10,20,40 m when the "
                "ground truth is longer than 40 m, else 1,2 m")
        .option("--page-template", "FILE",
                "the report page's HTML template (default: PREFIX/share/ips/report/report_page.html when installed)",
                ips::installedFile("report/report_page.html", IPS_REPORT_PAGE_TEMPLATE))
        .option("--js-dir", "DIR",
                "where Debian's libjs-chart.js and libjs-three are (chart.js/, three/), inlined into the page",
                IPS_JS_DIR)
        .required("--out", "DIR", "output folder (report.json and report.html)");
    if (!args.parse()) return 0;
    if (args.getInt("--pictures") < 0) throw ips::ArgError("ips_report: --pictures must not be negative");
    const std::string out = args.get("--out");
    std::error_code mkdir_error;
    std::filesystem::create_directories(out, mkdir_error);
    if (mkdir_error) throw std::runtime_error("cannot create the output folder " + out + ": " + mkdir_error.message());
    // The simulated world's scenario (--world-seed), read once: its effects and its surfaces for the map.
    std::optional<ips::sim::Scenario> world_scenario;
    if (args.has("--world-seed")) {
      world_scenario = args.has("--world-scenario") ? ips::sim::Scenario::load(args.get("--world-scenario"))
                                                    : ips::sim::Scenario::defaults();
      world_scenario->seed = static_cast<uint64_t>(args.getInt("--world-seed"));
    }
    // Both calibrations read once, before any log: a bad file ends the report at once, naming itself.
    std::optional<ips::StereoCalibration> truth_calib;
    if (args.has("--calib")) truth_calib = ips::loadCalibration(args.get("--calib"));
    // What the processes ran on: "true", "perturbed", "estimated", "converted", or "unspecified".
    std::string calibration_source = "unspecified";
    const std::optional<ips::StereoCalibration> ran_on =
        args.has("--process-calib") ? std::optional(ips::loadCalibration(args.get("--process-calib"))) : truth_calib;
    if (ran_on && !ran_on->source.empty()) calibration_source = ran_on->source;

    std::vector<FilterRun> runs;
    {
      std::stringstream ss(args.get("--filters"));
      std::string ch;
      while (std::getline(ss, ch, ',')) runs.push_back(FilterRun{ch, 0, {}});
    }
    Trajectory gt;
    std::map<int64_t, ips::disparity_map_t> gt_disp, est_disp;  // by utime
    std::map<std::string, ProcessFigures> procs;
    int64_t deltas = 0, deltas_valid = 0;
    std::vector<ips::tracker_delta_t> delta_msgs;
    struct MapPoints {
      int64_t utime = 0;
      std::vector<Eigen::Vector3d> points;
    };
    std::vector<MapPoints> map_points;           // POINTS: the mapper's points of each disparity map
    std::vector<MapPoints> map_points_gt_poses;  // POINTS_GT_POSES: the same placed with the true poses
    std::vector<MapPoints> mono_points;          // MONO_POINTS: E3D's depth from one camera, filter's poses
    // What makes the run's figures untrustworthy: named in report.json ("failures") and on stderr, exit 4.
    std::vector<std::string> failures;
    std::map<std::string, int64_t> last_health_log_us;  // per process: logger time of its last health message
    int64_t last_input_log_us = 0;                      // logger time of the last ground-truth pose (the input)
    int64_t last_log_us = 0;                            // logger time of the recording's last event
    int64_t bad_messages = 0;
    // The recording may come in parts (lcm-logger -i starts FILE.00, then FILE.01 when it is restarted): read in
    // order; more than one part means the recorder restarted and what was published in between is missing.
    std::vector<std::string> parts;
    {
      std::stringstream ss(args.get("--log"));
      for (std::string part; std::getline(ss, part, ',');)
        if (!part.empty()) parts.push_back(part);
    }
    if (parts.empty()) throw ips::ArgError("--log: no file given");
    if (parts.size() > 1)
      failures.push_back("the recorder restarted (" + std::to_string(parts.size()) +
                         " parts): messages published between the parts are missing");
    // The other recorders (the states at IMU rate, the bulk bus's dense maps and points), read after the first:
    // each holds its own channels, so every channel's messages stay in order.
    for (const auto& [option, what] : {std::pair<std::string, std::string>{"--states-log", "the states' recorder"},
                                       {"--bulk-log", "the bulk bus's recorder"}}) {
      std::stringstream ss(args.get(option));
      std::vector<std::string> more;
      for (std::string part; std::getline(ss, part, ',');)
        if (!part.empty()) more.push_back(part);
      if (more.size() > 1)
        failures.push_back(what + " restarted (" + std::to_string(more.size()) +
                           " parts): messages published between the parts are missing");
      parts.insert(parts.end(), more.begin(), more.end());
    }
    int64_t events = 0;
    // The recording holds whatever was on the bus, damaged, repeated or forged messages included: each channel's
    // stamps pass the same checks as in the processes, so a repeat or a stamp off the time line is not counted.
    std::map<std::string, ips::fw::StreamOrder> order;
    auto inOrder = [&](const std::string& ch, int64_t utime) {
      if (order[ch].check(utime, 0).accept) return true;
      ++bad_messages;
      return false;
    };
    for (const auto& part : parts)
      events += forEachMessage(part, failures, [&](const ips::fw::LogMessage& m) {
        last_log_us = std::max(last_log_us, m.timestamp);
        const std::string& ch = m.channel;
        if (ch == "GT_POSE") {
          last_input_log_us = std::max(last_input_log_us, m.timestamp);
          ips::ground_truth_t g{};
          if (decode(m, &g) && inOrder(ch, g.utime)) gt.push_back(toPoint(g.utime, g.position, g.orientation));
        } else if (ch == "GT_DISPARITY" || ch == "DISPARITY") {
          ips::disparity_map_t d;
          if (!decode(m, &d) || !ips::fw::validate(d).ok()) {
            ++bad_messages;
            return;
          }
          if (inOrder(ch, d.utime)) (ch == "DISPARITY" ? est_disp : gt_disp)[d.utime] = std::move(d);
        } else if (ch == "POINTS" || ch == "POINTS_GT_POSES" || ch == "MONO_POINTS") {
          ips::point_cloud_t pc;
          if (!decode(m, &pc) || pc.num_points < 0) {
            ++bad_messages;
            return;
          }
          if (!inOrder(ch, pc.utime)) return;
          MapPoints mp;
          mp.utime = pc.utime;
          for (const auto& q : pc.points)
            if (std::isfinite(q[0]) && std::isfinite(q[1]) && std::isfinite(q[2]))
              mp.points.emplace_back(q[0], q[1], q[2]);
          (ch == "POINTS"        ? map_points
           : ch == "MONO_POINTS" ? mono_points
                                 : map_points_gt_poses)
              .push_back(std::move(mp));
        } else if (ch == "TRACKER_DELTA") {
          ips::tracker_delta_t d;
          if (!decode(m, &d) || !ips::fw::validate(d).ok()) {
            ++bad_messages;
            return;
          }
          if (inOrder(ch, d.utime)) {
            delta_msgs.push_back(d);
            ++deltas;
            deltas_valid += d.valid ? 1 : 0;
          }
        } else if (ch.rfind("HEALTH_", 0) == 0) {
          ips::health_t h;
          if (!decode(m, &h) || !ips::fw::validate(h, ch).ok()) {
            ++bad_messages;
            return;
          }
          last_health_log_us[h.process] = m.timestamp;
          ProcessFigures& f = procs[h.process];
          if (h.input_rate_hz > 0) f.rate_sum += h.input_rate_hz, ++f.rate_n;
          if (h.latency_ms > 0) f.latency_sum += h.latency_ms, ++f.latency_n;
          f.last = h;
          if (h.utime > 0 && h.latency_ms > 0) {  // intervals without an input processed have no latency
            f.t.push_back(h.utime * 1e-6);
            f.latency_ms.push_back(h.latency_ms);
            f.rate_hz.push_back(h.input_rate_hz);
          }
        } else {
          for (auto& run : runs)
            if (ch == run.channel) {
              ips::filter_state_t s;
              if (!decode(m, &s) || !ips::fw::validate(s).ok()) {
                ++bad_messages;
              } else if (!s.a_priori && inOrder(ch, s.utime)) {
                run.type = s.filter_type;
                run.states.push_back(std::move(s));
              }
            }
        }
      });
    if (events == 0 || (gt.empty() && deltas == 0 && est_disp.empty() &&
                        std::all_of(runs.begin(), runs.end(), [](const FilterRun& r) { return r.states.empty(); })))
      failures.push_back(args.get("--log") +
                         ": holds none of a run's results (no ground truth, deltas, maps or states)");
    // Who cut a recording short: nothing recorded after the input stopped means the recorder stopped with it.
    auto recordingCut = [&] { return (last_log_us - last_input_log_us) * 1e-6 < kRecordingCutS; };
    // Completeness: every state stream runs to the end of the input without a pause, every process kept reporting.
    if (!gt.empty()) {
      const double input_end =
          std::max_element(gt.begin(), gt.end(), [](const TrajPoint& a, const TrajPoint& b) { return a.t < b.t; })->t;
      for (const auto& run : runs) {
        if (run.states.empty()) continue;  // this estimator did not run (no IMU in the recording)
        double prev = run.states.front().utime * 1e-6;
        for (const auto& st : run.states) {
          const double t = st.utime * 1e-6;
          if (t - prev > kMaxStateGapS)
            failures.push_back(run.channel + ": no states for " + std::to_string(t - prev) +
                               " s from t=" + std::to_string(prev) + " s (the filter died or restarted)");
          prev = std::max(prev, t);
        }
        if (input_end - prev > kMaxStateGapS)
          failures.push_back(run.channel + ": states stop " + std::to_string(input_end - prev) +
                             " s before the end of the input");
      }
      for (const auto& [process, last_us] : last_health_log_us)
        if ((last_input_log_us - last_us) * 1e-6 > kMaxHealthSilenceS)
          failures.push_back("process " + process + " stopped reporting " +
                             std::to_string((last_input_log_us - last_us) * 1e-6) + " s before the end of the input");
      // The input itself played to its end: a player stopped early (its deputy killed, the disk full) leaves a
      // recording that is complete in itself but covers part of the walk.
      if (args.has("--images")) {
        int64_t input_log_gt_end = 0;
        forEachMessage(args.get("--images"), failures, [&](const ips::fw::LogMessage& m) {
          ips::ground_truth_t g{};
          if (m.channel == "GT_POSE" && decode(m, &g)) input_log_gt_end = std::max(input_log_gt_end, g.utime);
        });
        if (input_log_gt_end * 1e-6 - input_end > kMaxStateGapS)
          failures.push_back(recordingCut()
                                 ? "the recording ends at t=" + std::to_string(input_end) + " s of the input's " +
                                       std::to_string(input_log_gt_end * 1e-6) +
                                       " s, every channel at once: the recorder stopped (disk full, or "
                                       "killed), not the player"
                                 : "the input was played to t=" + std::to_string(input_end) + " s of its " +
                                       std::to_string(input_log_gt_end * 1e-6) + " s (the player stopped early)");
      }
    }
    // The player's own account (log_player's health): a recording cut short, or a player stopped early, is
    // incomplete whether or not the input log is at hand.
    if (const auto player = procs.find("log_player");
        player != procs.end() && counterOf(player->second.last, "played_to_end") != 1)
      failures.push_back(recordingCut()
                             ? "the recording ends, every channel at once, before the player's account of the end of "
                               "its log (its last: events_played " +
                                   std::to_string(counterOf(player->second.last, "events_played")) +
                                   "): the recorder stopped (disk full, or killed), not the player"
                             : "the player's last account (events_played " +
                                   std::to_string(counterOf(player->second.last, "events_played")) +
                                   ") says it did not play its log to the end: the recording covers part of the input");
    // What disturbed a run that is complete: named with the time, and the run's status says so.
    std::vector<std::string> warnings = disturbances(runs, procs, deltas_valid);

    std::sort(gt.begin(), gt.end(), [](const TrajPoint& a, const TrajPoint& b) { return a.t < b.t; });
    gt.erase(std::unique(gt.begin(), gt.end(), [](const TrajPoint& a, const TrajPoint& b) { return a.t == b.t; }),
             gt.end());

    // The page's data beside report.json's figures: the series it draws, as "key": value fields.
    std::vector<std::string> page;
    double t0 = gt.empty() ? NAN : gt.front().t;  // the page's time axis starts at the first ground truth
    for (const auto& run : runs)
      if (!run.states.empty() && !(t0 <= run.states.front().utime * 1e-6)) t0 = run.states.front().utime * 1e-6;
    if (!std::isfinite(t0)) t0 = delta_msgs.empty() ? 0.0 : delta_msgs.front().utime * 1e-6;
    std::vector<std::string> page_trajectories, page_errors;
    auto trajectoryJson = [&](const std::string& name, const std::string& kind, const Trajectory& tr) {
      std::vector<double> t, x, y, z;
      for (size_t i : ips::report::subsample(tr.size(), kMaxPageTrajectoryPoints)) {
        t.push_back(tr[i].t - t0);
        x.push_back(tr[i].p.x()), y.push_back(tr[i].p.y()), z.push_back(tr[i].p.z());
      }
      page_trajectories.push_back(
          "{\"name\": " + ips::report::jsonString(name) + ", \"kind\": \"" + kind +
          "\", \"poses\": " + std::to_string(tr.size()) + ", \"t\": " + ips::report::jsonArray(t, 7) +
          ", \"x\": " + ips::report::jsonArray(x, 6) + ", \"y\": " + ips::report::jsonArray(y, 6) +
          ", \"z\": " + ips::report::jsonArray(z, 6) + "}");
    };
    if (!gt.empty()) trajectoryJson("ground truth", "truth", gt);

    std::ostringstream js;
    js << "{\n";
    double distance = 0;
    for (size_t i = 1; i < gt.size(); ++i) distance += (gt[i].p - gt[i - 1].p).norm();
    js << "  \"distance_m\": " << jsonNumber(distance) << ",\n";
    js << "  \"duration_s\": " << jsonNumber(gt.empty() ? 0 : gt.back().t - gt.front().t) << ",\n";
    js << "  \"tracker_deltas\": " << deltas << ",\n  \"tracker_deltas_valid\": " << deltas_valid << ",\n";
    js << "  \"filters\": [\n";
    bool first_run = true;
    double first_end_err = NAN, first_end_pct = NAN, first_ate = NAN;
    for (auto& run : runs) {
      Trajectory est;
      for (const auto& s : run.states) est.push_back(toPoint(s.utime, s.position, s.orientation));
      const bool start_frame = !run.states.empty() && run.states.back().frame == ips::filter_state_t::FRAME_START;
      Trajectory aligned = alignStart(est, gt, start_frame);
      const std::string name = run.type == ips::filter_state_t::FILTER_UKF ? "ukf" : "ekf";
      double ate = NAN, end_err = NAN, end_pct = NAN;
      if (est.size() >= 3 && gt.size() >= 3) {
        Trajectory ea, ra;
        ips::eval::associate(aligned, gt, 0.05, &ea, &ra);
        if (ea.size() >= 3) {
          ate = ips::eval::ateRmse(ea, ra);
          end_err = (ea.back().p - ra.back().p).norm();
          end_pct = distance > 0 ? 100.0 * end_err / distance : NAN;
        }
      }
      if (first_run) first_end_err = end_err, first_end_pct = end_pct, first_ate = ate;
      const ErrorSeries err = errorSeries(run, est, aligned, gt, t0, kMaxPageErrorSamples);
      {
        // The NEES over time for a Monte Carlo over seeds (ips_seeds, IPS_SEEDS in the main job).
        std::ofstream nees_file(out + "/nees_" + run.channel + ".tsv");
        nees_file << "# t [s since the run's first state] and the position NEES (3 dof) of " << run.channel << "\n";
        for (size_t i = 0; i < err.t.size(); ++i)
          nees_file << err.t[i] << " " << (std::isfinite(err.nees[i]) ? std::to_string(err.nees[i]) : "nan") << "\n";
      }
      js << (first_run ? "" : ",\n") << "    {\"channel\": \"" << run.channel << "\", \"filter\": \"" << name
         << "\", \"states\": " << run.states.size() << ", \"end_error_m\": " << jsonNumber(end_err)
         << ", \"end_error_pct\": " << jsonNumber(end_pct) << ", \"ate_rmse_m\": " << jsonNumber(ate)
         << ", \"nees_position_mean\": " << jsonNumber(err.nees_mean)
         << ", \"nees_position_in_95_band_pct\": " << jsonNumber(err.nees_in_band_pct);
      // Roll and pitch against the truth at the first and the last state: the angle between the body's up as the
      // filter and as the truth have it (both worlds are level; heading does not enter). A start that takes the
      // accelerometer's bias for gravity shows here, and how far the run learnt it.
      if (!run.states.empty() && !gt.empty()) {
        auto tiltError = [&gt](const ips::filter_state_t& st) {
          const Eigen::Vector3d up_est =
              ips::fw::quaternionFromArray(st.orientation).conjugate() * ips::fw::vectorFromArray(st.up);
          const Eigen::Vector3d up_gt = truthAttitudeAt(gt, st.utime * 1e-6).conjugate() * Eigen::Vector3d::UnitZ();
          return 1e3 * std::atan2(up_est.cross(up_gt).norm(), up_est.dot(up_gt));
        };
        js << ", \"tilt_error_start_mrad\": " << jsonNumber(tiltError(run.states.front()))
           << ", \"tilt_error_end_mrad\": " << jsonNumber(tiltError(run.states.back()));
      }
      // The head's calibration as the filter estimated it online, at the end, where it did (config lever_arm,
      // delta_scale, delta_direction, delta_rotation_drift, tilt/estimate_offset, camera_alignment), beside the truth
      // where the head is simulated.
      if (!run.states.empty()) {
        const ips::filter_state_t& last = run.states.back();
        // "key": [values], "sigma_key": [sigmas] of an estimated block (the message's fixed arrays).
        auto estimatedBlock = [&js](const char* key, const char* sigma_key, const auto& values, const auto& sigmas,
                                    int digits) {
          js << ", \"" << key
             << "\": " << ips::report::jsonArray(std::vector<double>(std::begin(values), std::end(values)), digits)
             << ", \"" << sigma_key
             << "\": " << ips::report::jsonArray(std::vector<double>(std::begin(sigmas), std::end(sigmas)), digits);
        };
        if (last.lever_arm_estimated) {
          estimatedBlock("lever_arm_m", "lever_arm_sigma_m", last.lever_arm, last.lever_arm_sigma, 5);
          if (truth_calib) {
            std::vector<double> error(3);
            for (int k = 0; k < 3; ++k) error[k] = last.lever_arm[k] - truth_calib->T_imu_cam0.translation()(k);
            js << ", \"lever_arm_error_m\": " << ips::report::jsonArray(error, 5);
          }
        }
        if (last.delta_scale_estimated)
          js << ", \"delta_scale\": " << jsonNumber(last.delta_scale)
             << ", \"delta_scale_sigma\": " << jsonNumber(last.delta_scale_sigma);
        if (last.delta_direction_estimated)
          estimatedBlock("delta_direction_rad", "delta_direction_sigma_rad", last.delta_direction,
                         last.delta_direction_sigma, 6);
        if (last.delta_rotation_drift_estimated)
          estimatedBlock("delta_rotation_drift_rad_per_m", "delta_rotation_drift_sigma_rad_per_m",
                         last.delta_rotation_drift, last.delta_rotation_drift_sigma, 7);
        if (last.tilt_offset_estimated)
          estimatedBlock("tilt_offset_rad", "tilt_offset_sigma_rad", last.tilt_offset, last.tilt_offset_sigma, 6);
        if (last.camera_alignment_estimated) {
          estimatedBlock("camera_alignment_rad", "camera_alignment_sigma_rad", last.camera_alignment,
                         last.camera_alignment_sigma, 6);
          // The camera-to-IMU rotation's own error in the file the processes ran on (the principal points' part of
          // the alignment is not in it).
          if (truth_calib && ran_on) {
            const Eigen::AngleAxisd err(ran_on->T_imu_cam0.linear().transpose() * truth_calib->T_imu_cam0.linear());
            const Eigen::Vector3d v = err.angle() * err.axis();
            js << ", \"camera_alignment_calibration_error_rad\": " << ips::report::jsonArray({v.x(), v.y(), v.z()}, 6);
          }
        }
      }
      js << "}";
      if (!aligned.empty()) {
        const std::string label = (name == "ukf" ? "UKF (" : "EKF (") + run.channel + ")";
        trajectoryJson(label, name, aligned);
        std::ostringstream e;
        e << "{\"name\": " << ips::report::jsonString(label) << ", \"kind\": \"" << name
          << "\", \"t\": " << ips::report::jsonArray(err.t, 7) << ", \"nees\": " << ips::report::jsonArray(err.nees, 4);
        const char* keys[] = {"pos", "pos3s", "att", "att3s"};
        const std::array<std::vector<double>, 3>* series[] = {&err.pos, &err.pos3s, &err.att, &err.att3s};
        for (int k = 0; k < 4; ++k) {
          e << ", \"" << keys[k] << "\": [";
          for (int a = 0; a < 3; ++a) e << (a ? "," : "") << ips::report::jsonArray((*series[k])[a], 4);
          e << "]";
        }
        e << "}";
        page_errors.push_back(e.str());
      }
      first_run = false;
      ips::eval::writeTum(out + "/trajectory_" + run.channel + ".tum", aligned);
    }
    js << "\n  ],\n";
    js << "  \"end_error_m\": " << jsonNumber(first_end_err) << ",\n  \"end_error_pct\": " << jsonNumber(first_end_pct)
       << ",\n  \"ate_rmse_m\": " << jsonNumber(first_ate) << ",\n";
    if (!gt.empty()) ips::eval::writeTum(out + "/trajectory_ground_truth.tum", gt);

    // Every estimator that ran against the ground truth, as recordings are judged: ATE (SE(3)-aligned), relative
    // errors over sub-sequences of fixed length (KITTI devkit, every pose a start) and the end-point error with
    // only the first pose aligned. The filters estimate the body (IMU frame) like the ground truth; the tracker's
    // chained increments give camera 0, judged against the ground truth carried to camera 0 (T_imu_cam0).
    {
      std::vector<double> lengths;
      if (args.has("--lengths")) {
        std::stringstream ss(args.get("--lengths"));
        std::string item;
        while (std::getline(ss, item, ',')) lengths.push_back(std::stod(item));
      } else {
        lengths = distance > 40 ? std::vector<double>{10, 20, 40} : std::vector<double>{1, 2};
      }
      Eigen::Isometry3d T_imu_cam0 = Eigen::Isometry3d::Identity();
      if (truth_calib) T_imu_cam0 = truth_calib->T_imu_cam0;
      struct Estimate {
        std::string name;
        Trajectory est, ref;
        int64_t lost = 0;
      };
      ips::eval::DeltaConsistency delta_consistency;
      std::vector<Estimate> estimates;
      if (!delta_msgs.empty()) {
        std::sort(delta_msgs.begin(), delta_msgs.end(),
                  [](const ips::tracker_delta_t& a, const ips::tracker_delta_t& b) { return a.utime < b.utime; });
        ips::tracker::DeltaChain chain;
        // The origin is the first pair; when the recording starts with a valid increment, its reference pair.
        if (delta_msgs.front().valid)
          chain.add(delta_msgs.front().utime_prev, 0, false, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero());
        for (const auto& d : delta_msgs)
          chain.add(d.utime, d.utime_prev, d.valid, ips::fw::quaternionFromArray(d.rotation),
                    ips::fw::vectorFromArray(d.translation));
        // Each delta starts at a pair the ones before reached (a dropped pair is bridged by the next delta, a pair
        // too poor to be a reference is skipped): one whose reference is unknown follows a delta missing from the
        // recording, which the recorder lost (its queue full while the machine was loaded).
        if (chain.unreferenced() > 0)
          warnings.push_back("the recording misses tracker deltas: the chain breaks " +
                             std::to_string(chain.unreferenced()) + " times in " + std::to_string(delta_msgs.size()) +
                             " (the recorder fell behind)");
        Estimate t{"tracker", {}, {}, chain.invalid()};
        for (const auto& p : chain.poses()) {
          TrajPoint q;
          q.t = p.utime * 1e-6;
          q.p = p.T_world_cam0.translation();
          q.q = Eigen::Quaterniond(p.T_world_cam0.linear());
          t.est.push_back(q);
        }
        for (const auto& g : gt) {
          Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
          T.linear() = g.q.toRotationMatrix();
          T.translation() = g.p;
          T = T * T_imu_cam0;
          TrajPoint q;
          q.t = g.t;
          q.p = T.translation();
          q.q = Eigen::Quaterniond(T.linear());
          t.ref.push_back(q);
        }
        if (!t.ref.empty()) ips::eval::writeTum(out + "/trajectory_ground_truth_cam0.tum", t.ref);
        std::vector<ips::eval::RelativePoseMeasurement> steps;
        for (const auto& d : delta_msgs) {
          if (!d.valid) continue;
          ips::eval::RelativePoseMeasurement m;
          m.t0 = d.utime_prev * 1e-6;
          m.t1 = d.utime * 1e-6;
          m.T.linear() = ips::fw::quaternionFromArray(d.rotation).toRotationMatrix();
          m.T.translation() = ips::fw::vectorFromArray(d.translation);
          m.covariance = Eigen::Map<const Eigen::Matrix<double, 6, 6, Eigen::RowMajor>>(d.covariance);
          steps.push_back(m);
        }
        delta_consistency = ips::eval::deltaConsistency(steps, t.ref);
        ips::eval::writeTum(out + "/trajectory_tracker.tum", t.est);
        {
          // On the page beside the truth: the chain placed at the truth's camera-0 pose at its first pair, as its
          // end error is judged (the camera is a lever arm away from the body the filters and the truth give).
          Trajectory ea, ra;
          if (t.ref.size() >= 3) ips::eval::associate(t.est, t.ref, 0.05, &ea, &ra);
          trajectoryJson("tracker (camera 0, chained increments)", "tracker",
                         ea.empty() ? t.est : ips::eval::alignFirstPose(ea, ra));
        }
        estimates.push_back(std::move(t));
      }
      for (const auto& run : runs) {
        if (run.states.empty()) continue;
        Estimate f{run.type == ips::filter_state_t::FILTER_UKF ? "ukf" : "ekf", {}, gt, 0};
        for (const auto& st : run.states) f.est.push_back(toPoint(st.utime, st.position, st.orientation));
        estimates.push_back(std::move(f));
      }
      js << "  \"estimators\": [";
      bool first_est = true;
      for (const auto& est : estimates) {
        Trajectory ea, ra;
        if (est.ref.size() >= 3) ips::eval::associate(est.est, est.ref, 0.05, &ea, &ra);
        double ate = NAN, end_m = NAN, end_pct = NAN, dist = 0;
        ips::eval::RelativeErrors rel;
        if (ea.size() >= 3) {
          const ips::eval::TrajectoryErrors err = ips::eval::evaluate(ea, ra, lengths.front());
          ate = err.ate_rmse_m;
          dist = err.distance_m;
          rel = ips::eval::relativeErrors(ea, ra, lengths);
          end_m = ips::eval::endErrorFirstPoseAligned(ea, ra);
          end_pct = dist > 0 ? 100.0 * end_m / dist : NAN;
        }
        js << (first_est ? "\n" : ",\n") << "    {\"name\": \"" << est.name << "\", \"poses\": " << est.est.size()
           << ", \"matched\": " << ea.size() << ", \"lost\": " << est.lost << ", \"distance_m\": " << jsonNumber(dist)
           << ", \"ate_rmse_m\": " << jsonNumber(ate) << ", \"rpe_trans_pct\": " << jsonNumber(rel.trans_pct)
           << ", \"rpe_rot_deg_per_m\": " << jsonNumber(rel.rot_deg_per_m)
           << ", \"rpe_subsequences\": " << rel.subsequences << ", \"end_error_m\": " << jsonNumber(end_m)
           << ", \"end_error_pct\": " << jsonNumber(end_pct);
        if (est.name == "tracker" && delta_consistency.deltas > 0)
          js << ", \"delta_nees_translation\": " << jsonNumber(delta_consistency.nees_translation)
             << ", \"delta_nees_rotation\": " << jsonNumber(delta_consistency.nees_rotation)
             << ", \"delta_error_lag1_correlation\": " << jsonNumber(delta_consistency.lag1_correlation);
        js << "}";
        first_est = false;
      }
      js << "\n  ],\n  \"rpe_lengths_m\": [";
      for (size_t i = 0; i < lengths.size(); ++i) js << (i ? ", " : "") << jsonNumber(lengths[i]);
      js << "],\n";
    }

    // Disparity against the simulator's ground truth, for every map that has one.
    std::vector<DisparityScore> scores;
    for (const auto& kv : est_disp) {
      auto g = gt_disp.find(kv.first);
      if (g != gt_disp.end()) scores.push_back(score(kv.second, g->second));
    }
    double bad2 = 0, density = 0;
    int64_t evaluated = 0;
    for (const auto& s : scores) bad2 += s.bad2_pct * s.evaluated, density += s.density_pct, evaluated += s.evaluated;
    js << "  \"disparity_maps\": " << est_disp.size() << ",\n  \"disparity_maps_with_ground_truth\": " << scores.size()
       << ",\n";
    js << "  \"disparity_bad2_pct\": " << jsonNumber(evaluated ? bad2 / evaluated : NAN) << ",\n";
    js << "  \"disparity_density_pct\": " << jsonNumber(scores.empty() ? NAN : density / scores.size()) << ",\n";

    // The map: its size, its points against the simulated world's surfaces (with the filter's poses, the map
    // put on the truth by the filter's start alignment; and with the true poses, which leaves the stereo error
    // alone), and where the later part of the run saw the surfaces of the earlier part, how far apart.
    std::string page_map = "null";
    if (args.has("--map")) {
      std::vector<uint8_t> grey;
      const std::vector<Eigen::Vector3d> map = ips::mapper::VoxelMap::load(args.get("--map"), &grey);
      js << "  \"map_points\": " << map.size() << ",\n";
      std::optional<ips::sim::World> world;
      if (world_scenario) world = ips::sim::World::build(world_scenario->world, world_scenario->seed);
      Eigen::Isometry3d T_truth_map = Eigen::Isometry3d::Identity();
      if (!runs.empty() && !runs.front().states.empty()) {
        Trajectory est;
        for (const auto& st : runs.front().states) est.push_back(toPoint(st.utime, st.position, st.orientation));
        T_truth_map = startAlignment(est, gt, runs.front().states.back().frame == ips::filter_state_t::FRAME_START);
      }
      auto surfaceKeys = [&](const std::vector<Eigen::Vector3d>& pts, const Eigen::Isometry3d& T,
                             const std::string& sfx) {
        const ips::eval::SurfaceErrors e = ips::eval::surfaceErrors(pts, *world, T, kMapWithinM);
        js << "  \"map_median_surface_error_m" << sfx << "\": " << jsonNumber(e.median_m) << ",\n";
        js << "  \"map_p90_surface_error_m" << sfx << "\": " << jsonNumber(e.p90_m) << ",\n";
        js << "  \"map_within_5cm_pct" << sfx << "\": " << jsonNumber(e.within_pct) << ",\n";
      };
      if (world) surfaceKeys(map, T_truth_map, "");
      if (args.has("--map-gt-poses")) {
        const std::vector<Eigen::Vector3d> map_gt = ips::mapper::VoxelMap::load(args.get("--map-gt-poses"));
        js << "  \"map_points_gt_poses\": " << map_gt.size() << ",\n";
        if (world) surfaceKeys(map_gt, Eigen::Isometry3d::Identity(), "_gt_poses");
      }
      // The earlier and the later half of the run (by image time); with the true poses the gap is what the voxels
      // and the stereo error leave, the rest of the filter's gap is navigation drift.
      auto consistencyKeys = [&](const std::vector<MapPoints>& maps, const std::string& sfx) {
        if (maps.size() < 2) return;
        std::vector<Eigen::Vector3d> early, late;
        const int64_t middle = (maps.front().utime + maps.back().utime) / 2;
        for (const auto& mp : maps) {
          auto& half = mp.utime < middle ? early : late;
          half.insert(half.end(), mp.points.begin(), mp.points.end());
        }
        const ips::eval::SelfConsistency c = ips::eval::selfConsistency(early, late, kMapOverlapM);
        js << "  \"map_consistency_median_m" << sfx << "\": " << jsonNumber(c.median_m) << ",\n";
        js << "  \"map_consistency_p90_m" << sfx << "\": " << jsonNumber(c.p90_m) << ",\n";
        js << "  \"map_consistency_overlap_pct" << sfx
           << "\": " << jsonNumber(c.late_points ? 100.0 * c.overlapping / c.late_points : NAN) << ",\n";
      };
      consistencyKeys(map_points, "");
      consistencyKeys(map_points_gt_poses, "_gt_poses");
      // Depth from one camera (MONO_POINTS) beside the stereo maps' points (POINTS), both as published, placed with
      // the filter's poses and put on the truth by the same alignment: each point's distance to the true surfaces.
      js << "  \"mono_maps\": " << mono_points.size() << ",\n";
      if (world && !mono_points.empty()) {
        auto pointKeys = [&](const std::vector<MapPoints>& maps, const std::string& prefix) {
          std::vector<Eigen::Vector3d> all;
          for (const auto& mp : maps) all.insert(all.end(), mp.points.begin(), mp.points.end());
          // An even sample keeps the distance queries to seconds; the figures are medians and shares.
          const size_t stride = std::max<size_t>(1, all.size() / kSurfaceSamplePoints);
          std::vector<Eigen::Vector3d> sample;
          for (size_t i = 0; i < all.size(); i += stride) sample.push_back(all[i]);
          const ips::eval::SurfaceErrors e = ips::eval::surfaceErrors(sample, *world, T_truth_map, kMapWithinM);
          js << "  \"" << prefix << "points\": " << all.size() << ",\n";
          js << "  \"" << prefix << "median_surface_error_m\": " << jsonNumber(e.median_m) << ",\n";
          js << "  \"" << prefix << "p90_surface_error_m\": " << jsonNumber(e.p90_m) << ",\n";
          js << "  \"" << prefix << "within_5cm_pct\": " << jsonNumber(e.within_pct) << ",\n";
        };
        pointKeys(mono_points, "mono_");
        pointKeys(map_points, "stereo_");
      }
      std::vector<double> up;
      if (args.get("--map-up") == "truth") {
        if (gt.empty() || delta_msgs.empty())
          throw ips::ArgError("--map-up truth needs the ground truth and the tracker's increments in the recording");
        // The tracker's chain starts at its first increment's image: the body there is the map's world.
        const Eigen::Vector3d u =
            truthAttitudeAt(gt, delta_msgs.front().utime * 1e-6).conjugate() * Eigen::Vector3d::UnitZ();
        up = {u.x(), u.y(), u.z()};
      } else {
        std::stringstream ss(args.get("--map-up"));
        std::string item;
        while (std::getline(ss, item, ',')) up.push_back(std::stod(item));
      }
      if (up.size() != 3 || !(std::hypot(up[0], up[1], up[2]) > 0))
        throw ips::ArgError("--map-up takes three numbers, not all zero: '" + args.get("--map-up") + "'");
      page_map = ips::report::mapJson(
          map, grey, kMaxMapPagePoints, Eigen::Vector3d(up[0], up[1], up[2]).normalized(),
          args.get("--map-poses") == "tracker" ? "the tracker\u2019s increments" : "the filter\u2019s states");
    }

    // Examples for the page: a few maps beside their rectified left images, the ground truth and the error map,
    // colour-mapped here (the page places them with colour bars drawn from the same colour tables); the middle
    // one triangulated into the 3D view's point cloud.
    std::vector<std::string> page_examples;
    std::string page_cloud = "null";
    if (args.has("--images") && truth_calib && !est_disp.empty()) {
      const ips::StereoRectification rect = ips::computeRectification(*truth_calib);
      const int want = static_cast<int>(args.getInt("--pictures"));
      // Spread over the run: among the maps with ground truth, or all maps when there is none (a recording).
      std::vector<int64_t> candidates;
      for (const auto& sc : scores) candidates.push_back(sc.seq);
      if (candidates.empty())
        for (const auto& kv : est_disp) candidates.push_back(kv.second.seq);
      std::set<int64_t> pick;
      for (int i = 0; i < want && i < static_cast<int>(candidates.size()); ++i)
        pick.insert(candidates[candidates.size() * (2 * i + 1) / (2 * want)]);
      const int64_t cloud_seq = pick.empty() ? -1 : *std::next(pick.begin(), static_cast<long>(pick.size() / 2));
      std::map<int64_t, const DisparityScore*> score_of;
      for (const auto& sc : scores) score_of[sc.seq] = &sc;
      std::map<int64_t, std::string> examples;  // by seq, in order
      forEachMessage(args.get("--images"), failures, [&](const ips::fw::LogMessage& im) {
        if (im.channel != "STEREO") return;
        ips::stereo_pair_t p;
        if (!decode(im, &p) || !pick.count(p.seq) || !est_disp.count(p.utime) || examples.count(p.seq)) return;
        if (!ips::fw::validate(p).ok() || p.width != truth_calib->cam0.width || p.height != truth_calib->cam0.height) {
          ++bad_messages;
          return;
        }
        cv::Mat r0, r1;
        ips::rectifyPair(rect, ips::fw::leftImage(p), ips::fw::rightImage(p), r0, r1);
        const ips::disparity_map_t& dm = est_disp[p.utime];
        // The page draws values below zero as "none".
        cv::Mat d = ips::fw::disparityImage(dm);
        cv::patchNaNs(d, -1.0);
        cv::resize(r0, r0, d.size(), 0, 0, cv::INTER_AREA);
        cv::Mat truth;
        if (gt_disp.count(p.utime)) {  // at the map's scale, as scored
          truth = ips::eval::truthAtSize(ips::fw::disparityImage(gt_disp[p.utime]), d.size());
          cv::patchNaNs(truth, -1.0);
        }
        std::ostringstream fields;
        fields << ", \"seq\": " << p.seq << ", \"t\": " << jsonNumber(p.utime * 1e-6 - t0);
        if (score_of.count(p.seq)) {
          const DisparityScore& sc = *score_of[p.seq];
          fields << ", \"bad2_pct\": " << jsonNumber(sc.bad2_pct) << ", \"density_pct\": " << jsonNumber(sc.density_pct)
                 << ", \"evaluated\": " << sc.evaluated;
        }
        examples[p.seq] = ips::report::disparityExampleJson(
            r0, d, truth, dm.min_disparity, dm.min_disparity + dm.num_disparities, 2 * kBadDisparityPx, fields.str());
        if (p.seq == cloud_seq && dm.focal_px > 0 && dm.baseline_m > 0)
          page_cloud = ips::report::pointCloudJson(d, r0, dm.focal_px, dm.cx, dm.cy, dm.baseline_m, kMaxCloudPoints,
                                                   kMinCloudDisparityPx, p.seq);
      });
      for (const auto& kv : examples) page_examples.push_back(kv.second);
      js << "  \"disparity_pictures\": " << examples.size() << ",\n";
    }

    js << "  \"processes\": {";
    bool first_proc = true;
    for (const auto& kv : procs) {
      const ProcessFigures& f = kv.second;
      js << (first_proc ? "\n" : ",\n") << "    " << ips::report::jsonString(kv.first)
         << ": {\"rate_hz\": " << jsonNumber(f.rate_n ? f.rate_sum / f.rate_n : 0)
         << ", \"latency_ms\": " << jsonNumber(f.latency_n ? f.latency_sum / f.latency_n : 0)
         << ", \"received\": " << f.last.received << ", \"published\": " << f.last.published
         << ", \"dropped\": " << f.last.dropped << ", \"bad\": " << f.last.bad << ", \"counters\": {";
      // Its detailed counters at the end (seq_gap: messages lost on the way; the filter's imu_gaps, tracker_too_late).
      for (int i = 0; i < f.last.num_counters; ++i)
        js << (i ? ", " : "") << ips::report::jsonString(f.last.counter_names[i]) << ": " << f.last.counter_values[i];
      js << "}}";
      first_proc = false;
    }
    js << "\n  },\n";
    js << "  \"bad_messages\": " << bad_messages << ",\n";
    js << "  \"calibration_source\": " << ips::report::jsonString(calibration_source) << ",\n";
    // On the simulator: what made its scenario harder than the built-in walk (ips::sim::simEffects).
    if (world_scenario) {
      std::string list;
      for (const std::string& name : ips::sim::simEffects(*world_scenario))
        list += (list.empty() ? "" : ", ") + ips::report::jsonString(name);
      js << "  \"sim_effects\": [" << list << "],\n";
    }
    js << "  \"calibration_figures\": "
       << calibrationFiguresJson(args.has("--process-calib") ? args.get("--process-calib") : args.get("--calib"))
       << ",\n";
    js << "  \"status\": \""
       << (!failures.empty()   ? "failed"
           : !warnings.empty() ? "disturbed"
                               : "ok")
       << "\",\n  \"warnings\": [";
    for (size_t i = 0; i < warnings.size(); ++i) js << (i ? ", " : "") << ips::report::jsonString(warnings[i]);
    js << "],\n  \"failures\": [";
    for (size_t i = 0; i < failures.size(); ++i) js << (i ? ", " : "") << ips::report::jsonString(failures[i]);
    js << "]\n}\n";
    std::ofstream report(out + "/report.json");
    report << js.str();
    report.close();
    if (!report) throw std::runtime_error(out + "/report.json: cannot write (disk full?)");

    // The page: report.json's figures and the series it draws, filled into the template with the libraries.
    {
      std::vector<double> t, inliers, matches, valid;
      for (size_t i : ips::report::subsample(delta_msgs.size(), kMaxPageErrorSamples)) {
        const ips::tracker_delta_t& d = delta_msgs[i];
        t.push_back(d.utime * 1e-6 - t0);
        inliers.push_back(d.num_inliers);
        matches.push_back(d.num_inter_matches);
        valid.push_back(d.valid ? 1 : 0);
      }
      std::string latency = "[";
      for (const auto& [process, f] : procs) {
        if (f.t.empty()) continue;  // a process that reports no processing time (the filters)
        std::vector<double> ft, fl, fr;
        for (size_t i : ips::report::subsample(f.t.size(), kMaxPageErrorSamples)) {
          ft.push_back(f.t[i] - t0);
          fl.push_back(f.latency_ms[i]);
          fr.push_back(f.rate_hz[i]);
        }
        latency += (latency.size() > 1 ? ", " : "") + std::string("{\"process\": ") + ips::report::jsonString(process) +
                   ", \"t\": " + ips::report::jsonArray(ft, 7) + ", \"latency_ms\": " + ips::report::jsonArray(fl, 4) +
                   ", \"rate_hz\": " + ips::report::jsonArray(fr, 4) + "}";
      }
      auto list = [](const std::vector<std::string>& items) {
        std::string o = "[";
        for (size_t i = 0; i < items.size(); ++i) o += (i ? ",\n" : "\n") + items[i];
        return o + "]";
      };
      std::ostringstream data;
      data << "{\"report\": " << js.str() << ", \"run\": " << ips::report::jsonString(out)
           << ", \"t0\": " << jsonNumber(t0) << ", \"trajectories\": " << list(page_trajectories)
           << ", \"errors\": " << list(page_errors) << ", \"nees_band\": [" << jsonNumber(kChi2Dof3Lo) << ", "
           << jsonNumber(kChi2Dof3Hi) << "], \"tracker\": {\"t\": " << ips::report::jsonArray(t, 7)
           << ", \"inliers\": " << ips::report::jsonArray(inliers)
           << ", \"inter_matches\": " << ips::report::jsonArray(matches)
           << ", \"valid\": " << ips::report::jsonArray(valid) << "}, \"latency\": " << latency << "]"
           << ", \"disparity\": " << list(page_examples) << ", \"colour_maps\": " << ips::report::colourMapsJson()
           << ", \"cloud\": " << page_cloud << ", \"map\": " << page_map << "}";
      const std::string js_dir = args.get("--js-dir");
      ips::report::writePage(args.get("--page-template"),
                             {{"/*@CHART_JS@*/", js_dir + "/chart.js/chart.min.js"},
                              {"/*@THREE_JS@*/", js_dir + "/three/three.min.js"},
                              {"/*@ORBIT_CONTROLS_JS@*/", js_dir + "/three/examples/js/controls/OrbitControls.js"}},
                             data.str(), out + "/report.html");
    }
    std::fputs(js.str().c_str(), stdout);
    for (const auto& w : warnings) std::fprintf(stderr, "ips_report: disturbed: %s\n", w.c_str());
    for (const auto& f : failures) std::fprintf(stderr, "ips_report: FAILED: %s\n", f.c_str());
    return failures.empty() ? 0 : 4;
  });
}
