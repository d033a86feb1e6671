#include "ips/eval/run_report.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <iomanip>
#include <ips/ground_truth_t.hpp>
#include <ips/imu_sample_t.hpp>
#include <ips/point_cloud_t.hpp>
#include <opencv2/core.hpp>
#include <sstream>

#include "app/filter_messages.hpp"
#include "ips/eval/disparity.hpp"
#include "ips/eval/map_errors.hpp"
#include "ips/eval/span_noise.hpp"
#include "ips/framework/channels.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/log_reader.hpp"
#include "ips/framework/message_arrays.hpp"
#include "ips/framework/validate.hpp"
#include "ips/tracker/delta_chain.hpp"

namespace ips::eval {
namespace {

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
// A map point "on" the surface: within the map's voxel size.
constexpr double kMapWithinM = 0.05;
// The later part of a run "sees the same surface" as the earlier one where their points are this close: a few
// voxels, more than the drift of a good run, less than the distance between walls.
constexpr double kMapOverlapM = 0.25;
// Points drawn evenly from all published clouds of one kind for their distances to the true surfaces.
constexpr size_t kSurfaceSamplePoints = 200000;
// Where filter_state_t's error-state covariance holds the position and the attitude error (see its .lcm).
constexpr int kCovPosition = 0;
constexpr int kCovAttitude = 18;

template <class Msg>
bool decode(const ips::fw::LogMessage& e, Msg* m) {
  return m->decode(e.data.data(), 0, static_cast<int>(e.data.size())) >= 0;
}

TrajPoint toPoint(int64_t utime, const double* p, const double* q) {
  TrajPoint t;
  t.t = utime * 1e-6;
  t.p = Eigen::Vector3d(p[0], p[1], p[2]);
  t.q = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized();
  return t;
}

// The truth's position and attitude at time t (interpolate: linear, slerp; the end poses outside).
Eigen::Vector3d truthAt(const Trajectory& gt, double t) { return interpolate(gt, t).p; }
Eigen::Quaterniond truthAttitudeAt(const Trajectory& gt, double t) { return interpolate(gt, t).q; }

bool inStartFrame(const FilterRun& run) {
  return !run.states.empty() && run.states.back().frame == ips::filter_state_t::FRAME_START;
}

std::string filterName(const FilterRun& run) { return run.type == ips::filter_state_t::FILTER_UKF ? "ukf" : "ekf"; }

Trajectory alignStart(const Trajectory& est, const Trajectory& gt, bool whole_pose) {
  const Eigen::Isometry3d T = startAlignment(est, gt, whole_pose);
  Trajectory out = est;
  for (auto& p : out) {
    p.p = T * p.p;
    p.q = Eigen::Quaterniond(T.linear()) * p.q;
  }
  return out;
}

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
  const std::vector<size_t> shown = subsample(n, max_samples);
  size_t next_shown = 0;
  double nees_sum = 0, heading_max = 0;
  int64_t nees_n = 0, nees_in = 0, heading_n = 0, heading_in = 0;
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
    if (has_att) Pa = R * block(s, kCovAttitude) * R.transpose();
    // q_true = exp(dtheta) * q_est: the attitude error as a rotation vector in world, as the covariance has it.
    // (Eigen's angle-axis of a quaternion has its angle in [0, pi]: the shortest rotation.)
    const Eigen::AngleAxisd d(truthAttitudeAt(gt, p.t) * p.q.inverse());
    const Eigen::Vector3d dtheta_w = d.angle() * d.axis();
    if (has_att && std::isfinite(Pa(2, 2))) {
      const double heading = std::abs(dtheta_w.z());
      heading_max = std::max(heading_max, heading);
      heading_in += heading <= 3 * std::sqrt(std::max(0.0, Pa(2, 2))) ? 1 : 0;
      ++heading_n;
    }
    if (next_shown >= shown.size() || shown[next_shown] != i) continue;
    ++next_shown;
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
  if (heading_n)
    out.heading_error_max_deg = heading_max * 180 / M_PI,
    out.heading_within_3sigma_pct = 100.0 * heading_in / heading_n;
  return out;
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

std::string fixed(double v, int decimals) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(decimals) << v;
  return os.str();
}

// Messages of every part of one recorder in order; more than one part means the recorder restarted and what was
// published in between is missing.
void noteRestart(const std::vector<std::string>& parts, const std::string& what, std::vector<std::string>& failures) {
  if (parts.size() > 1)
    failures.push_back(what + " restarted (" + std::to_string(parts.size()) +
                       " parts): messages published between the parts are missing");
}

}  // namespace

std::vector<size_t> subsample(size_t n, size_t max_samples) {
  std::vector<size_t> idx;
  if (n == 0 || max_samples == 0) return idx;
  const size_t step = std::max<size_t>(1, (n + max_samples - 1) / max_samples);
  for (size_t i = 0; i < n; i += step) idx.push_back(i);
  if (idx.back() != n - 1) {
    if (idx.size() >= max_samples)
      idx.back() = n - 1;
    else
      idx.push_back(n - 1);
  }
  return idx;
}

Json figure(double v) {
  if (!std::isfinite(v)) return nullptr;
  std::ostringstream os;
  os << std::setprecision(6) << v;
  const double rounded = std::stod(os.str());
  // Whole numbers as integers, as they were always written (2, not 2.0).
  if (rounded == std::floor(rounded) && std::abs(rounded) < 1e15) return static_cast<int64_t>(rounded);
  return rounded;
}

RunLog readRunLog(const RunLogFiles& files, const std::vector<std::string>& filter_channels) {
  RunLog log;
  for (const auto& ch : filter_channels) log.runs.push_back(FilterRun{ch, 0, {}});
  noteRestart(files.results, "the recorder", log.failures);
  noteRestart(files.states, "the states' recorder", log.failures);
  noteRestart(files.bulk, "the bulk bus's recorder", log.failures);
  // The other recorders are read after the main one: each holds its own channels, so every channel's messages stay
  // in order.
  std::vector<std::string> parts = files.results;
  parts.insert(parts.end(), files.states.begin(), files.states.end());
  parts.insert(parts.end(), files.bulk.begin(), files.bulk.end());
  // The recording holds whatever was on the bus, damaged, repeated or forged messages included: each channel's
  // stamps pass the same checks as in the processes, so a repeat or a stamp off the time line is not counted.
  std::map<std::string, ips::fw::StreamOrder> order;
  auto inOrder = [&](const std::string& ch, int64_t utime) {
    if (order[ch].check(utime, 0).accept) return true;
    ++log.bad_messages;
    return false;
  };
  for (const auto& part : parts)
    log.events += forEachMessage(part, log.failures, [&](const ips::fw::LogMessage& m) {
      log.last_log_us = std::max(log.last_log_us, m.timestamp);
      const std::string& ch = m.channel;
      if (ch == "GT_POSE") {
        log.last_input_log_us = std::max(log.last_input_log_us, m.timestamp);
        ips::ground_truth_t g{};
        if (decode(m, &g) && inOrder(ch, g.utime)) log.gt.push_back(toPoint(g.utime, g.position, g.orientation));
      } else if (ch == "GT_DISPARITY" || ch == "DISPARITY") {
        ips::disparity_map_t d;
        if (!decode(m, &d) || !ips::fw::validate(d).ok()) {
          ++log.bad_messages;
          return;
        }
        if (inOrder(ch, d.utime)) (ch == "DISPARITY" ? log.est_disp : log.gt_disp)[d.utime] = std::move(d);
      } else if (ch == "POINTS" || ch == "POINTS_GT_POSES" || ch == "MONO_POINTS") {
        ips::point_cloud_t pc;
        if (!decode(m, &pc) || pc.num_points < 0) {
          ++log.bad_messages;
          return;
        }
        if (!inOrder(ch, pc.utime)) return;
        MapPoints mp;
        mp.utime = pc.utime;
        for (const auto& q : pc.points)
          if (std::isfinite(q[0]) && std::isfinite(q[1]) && std::isfinite(q[2]))
            mp.points.emplace_back(q[0], q[1], q[2]);
        (ch == "POINTS"        ? log.map_points
         : ch == "MONO_POINTS" ? log.mono_points
                               : log.map_points_gt_poses)
            .push_back(std::move(mp));
      } else if (ch == "TRACKER_DELTA") {
        ips::tracker_delta_t d;
        if (!decode(m, &d) || !ips::fw::validate(d).ok()) {
          ++log.bad_messages;
          return;
        }
        if (inOrder(ch, d.utime)) {
          log.delta_msgs.push_back(d);
          ++log.deltas;
          log.deltas_valid += d.valid ? 1 : 0;
        }
      } else if (ch.rfind("HEALTH_", 0) == 0) {
        ips::health_t h;
        if (!decode(m, &h) || !ips::fw::validate(h, ch).ok()) {
          ++log.bad_messages;
          return;
        }
        log.last_health_log_us[h.process] = m.timestamp;
        ProcessFigures& f = log.procs[h.process];
        if (h.input_rate_hz > 0) f.rate_sum += h.input_rate_hz, ++f.rate_n;
        if (h.latency_ms > 0) f.latency_sum += h.latency_ms, ++f.latency_n;
        f.last = h;
        if (h.utime > 0 && h.latency_ms > 0) {  // intervals without an input processed have no latency
          f.t.push_back(h.utime * 1e-6);
          f.latency_ms.push_back(h.latency_ms);
          f.rate_hz.push_back(h.input_rate_hz);
        }
      } else {
        for (auto& run : log.runs)
          if (ch == run.channel) {
            ips::filter_state_t s;
            if (!decode(m, &s) || !ips::fw::validate(s).ok()) {
              ++log.bad_messages;
            } else if (!s.a_priori && inOrder(ch, s.utime)) {
              run.type = s.filter_type;
              run.states.push_back(std::move(s));
            }
          }
      }
    });
  std::sort(log.gt.begin(), log.gt.end(), [](const TrajPoint& a, const TrajPoint& b) { return a.t < b.t; });
  log.gt.erase(
      std::unique(log.gt.begin(), log.gt.end(), [](const TrajPoint& a, const TrajPoint& b) { return a.t == b.t; }),
      log.gt.end());
  std::stable_sort(log.delta_msgs.begin(), log.delta_msgs.end(),
                   [](const ips::tracker_delta_t& a, const ips::tracker_delta_t& b) { return a.utime < b.utime; });
  return log;
}

InputLog readInputLog(const std::string& input_log, std::vector<std::string>& failures) {
  InputLog in;
  forEachMessage(input_log, failures, [&](const ips::fw::LogMessage& m) {
    if (m.channel == "GT_POSE") {
      ips::ground_truth_t g{};
      if (decode(m, &g)) in.truth_end_us = std::max(in.truth_end_us, g.utime);
    } else if (m.channel == ips::channels::kImu) {
      ips::imu_sample_t s{};
      if (!decode(m, &s) || !ips::fw::validate(s).ok() || (!in.imu.empty() && s.utime <= in.imu.back().utime)) return;
      in.imu.push_back(ips::filter_app::toImuSample(s));
    }
  });
  return in;
}

Json spanNoiseSection(const RunLog& log, const std::vector<filter::ImuSample>& imu, const Trajectory& tracker_cam0,
                      const std::optional<ips::StereoCalibration>& truth_calib) {
  Json out = Json::object();
  out["span_noise"] = nullptr;
  if (imu.size() < 3 || log.gt.size() < 3 || tracker_cam0.size() < 3 || !truth_calib) return out;
  SpanNoiseInput in;
  in.truth = log.gt;
  in.estimate = tracker_cam0;
  in.imu = imu;
  in.T_imu_cam0 = truth_calib->T_imu_cam0;
  const double density = truth_calib->imu ? truth_calib->imu->accel_noise_density : 0.0;
  std::vector<SpanNoise> result;
  try {
    result = spanNoise(in, {1, 2, 4, 8});
  } catch (const std::invalid_argument&) {
    return out;  // the tracker's poses and the truth overlap in fewer than three samples
  }
  Json spans = Json::array();
  for (const SpanNoise& s : result) {
    spans.push_back({{"frames", s.span_frames},
                     {"span_s", figure(s.span_s)},
                     {"centres", s.centres},
                     {"tracker_mm", figure(s.estimate * 1e3)},
                     {"imu_mm", figure(s.imu * 1e3)},
                     {"truth_mm", figure(s.truth * 1e3)},
                     {"tracker_vs_imu_mm", figure(s.estimate_vs_imu * 1e3)},
                     {"truth_vs_tracker_mm", figure(s.truth_vs_estimate * 1e3)},
                     {"truth_vs_imu_mm", figure(s.truth_vs_imu * 1e3)},
                     {"imu_white_noise_mm",
                      density > 0 ? figure(imuWhiteNoiseSecondDifference(density, s.span_s) * 1e3) : Json(nullptr)}});
  }
  out["span_noise"] = spans;
  return out;
}

std::vector<std::string> completenessFailures(const RunLog& log, const std::string& label,
                                              std::optional<int64_t> input_truth_end_us) {
  std::vector<std::string> failures;
  if (log.events == 0 ||
      (log.gt.empty() && log.deltas == 0 && log.est_disp.empty() &&
       std::all_of(log.runs.begin(), log.runs.end(), [](const FilterRun& r) { return r.states.empty(); })))
    failures.push_back(label + ": holds none of a run's results (no ground truth, deltas, maps or states)");
  // Who cut a recording short: nothing recorded after the input stopped means the recorder stopped with it.
  const bool recording_cut = (log.last_log_us - log.last_input_log_us) * 1e-6 < kRecordingCutS;
  if (!log.gt.empty()) {
    const double input_end = log.gt.back().t;
    for (const auto& run : log.runs) {
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
    for (const auto& [process, last_us] : log.last_health_log_us)
      if ((log.last_input_log_us - last_us) * 1e-6 > kMaxHealthSilenceS)
        failures.push_back("process " + process + " stopped reporting " +
                           std::to_string((log.last_input_log_us - last_us) * 1e-6) + " s before the end of the input");
    // The input itself played to its end: a player stopped early (its deputy killed, the disk full) leaves a
    // recording that is complete in itself but covers part of the walk.
    if (input_truth_end_us && *input_truth_end_us * 1e-6 - input_end > kMaxStateGapS)
      failures.push_back(recording_cut
                             ? "the recording ends at t=" + std::to_string(input_end) + " s of the input's " +
                                   std::to_string(*input_truth_end_us * 1e-6) +
                                   " s, every channel at once: the recorder stopped (disk full, or "
                                   "killed), not the player"
                             : "the input was played to t=" + std::to_string(input_end) + " s of its " +
                                   std::to_string(*input_truth_end_us * 1e-6) + " s (the player stopped early)");
  }
  // The player's own account (log_player's health): a recording cut short, or a player stopped early, is incomplete
  // whether or not the input log is at hand.
  if (const auto player = log.procs.find("log_player");
      player != log.procs.end() && counterOf(player->second.last, "played_to_end") != 1) {
    const std::string played = std::to_string(counterOf(player->second.last, "events_played"));
    failures.push_back(recording_cut ? "the recording ends, every channel at once, before the player's account of the "
                                       "end of its log (its last: events_played " +
                                           played + "): the recorder stopped (disk full, or killed), not the player"
                                     : "the player's last account (events_played " + played +
                                           ") says it did not play its log to the end: the recording covers part of "
                                           "the input");
  }
  return failures;
}

std::vector<std::string> disturbances(const RunLog& log) {
  std::vector<std::string> out;
  for (const auto& [name, f] : log.procs) {
    const ips::health_t& h = f.last;
    // Inputs lost on the way to a process, bridged gaps in its IMU, deltas that came too late or were not fused.
    if (const int64_t lost = counterOf(h, "imu_seq_gap"))
      out.push_back(name + ": " + std::to_string(lost) + " IMU samples lost on the way (imu_seq_gap)");
    if (const int64_t gaps = counterOf(h, "imu_gaps"))
      out.push_back(name + ": " + std::to_string(gaps) + " gaps in the IMU bridged (imu_gaps)");
    const int64_t fused = counterOf(h, "tracker_accepted"), late = counterOf(h, "tracker_too_late");
    if (log.deltas_valid > 20 && h.num_counters > 0 && counterOf(h, "image_accepted") > 0 &&
        fused < 0.9 * log.deltas_valid)
      out.push_back(name + ": fused " + std::to_string(fused) + " of " + std::to_string(log.deltas_valid) +
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
  for (const auto& run : log.runs)
    for (const auto& [name, f] : log.procs)
      if (const int64_t sent = counterOf(f.last, "published_" + run.channel);
          sent > static_cast<int64_t>(run.states.size()))
        out.push_back(run.channel + ": the recording holds " + std::to_string(run.states.size()) + " of the " +
                      std::to_string(sent) + " states " + name + " published");
  for (const auto& run : log.runs) {
    if (run.states.empty()) continue;
    const double t0 = run.states.front().utime * 1e-6;
    const CovarianceJump p = firstJump(run, kCovPosition, 2.0, 0.01);
    if (std::isfinite(p.t))
      out.push_back(run.channel + ": position sigma rose from " + fixed(p.from, 3) + " to " + fixed(p.to, 3) +
                    " m within a second, at t=" + fixed(p.t - t0, 1) + " s of its states");
    const CovarianceJump a = firstJump(run, kCovAttitude, 2.0, 0.5 * M_PI / 180);
    if (std::isfinite(a.t))
      out.push_back(run.channel + ": attitude sigma rose from " + fixed(a.from * 180 / M_PI, 2) + " to " +
                    fixed(a.to * 180 / M_PI, 2) + " deg within a second, at t=" + fixed(a.t - t0, 1) +
                    " s of its states");
  }
  return out;
}

double pageStartTime(const RunLog& log) {
  double t0 = log.gt.empty() ? NAN : log.gt.front().t;
  for (const auto& run : log.runs)
    if (!run.states.empty() && !(t0 <= run.states.front().utime * 1e-6)) t0 = run.states.front().utime * 1e-6;
  if (!std::isfinite(t0)) t0 = log.delta_msgs.empty() ? 0.0 : log.delta_msgs.front().utime * 1e-6;
  return t0;
}

Json overviewSection(const RunLog& log) {
  Json j;
  j["distance_m"] = figure(distanceTravelled(log.gt));
  j["duration_s"] = figure(log.gt.empty() ? 0 : log.gt.back().t - log.gt.front().t);
  j["tracker_deltas"] = log.deltas;
  j["tracker_deltas_valid"] = log.deltas_valid;
  return j;
}

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

Trajectory statesTrajectory(const FilterRun& run) {
  Trajectory est;
  for (const auto& s : run.states) est.push_back(toPoint(s.utime, s.position, s.orientation));
  return est;
}

FiltersSection filtersSection(const RunLog& log, const std::optional<ips::StereoCalibration>& truth,
                              const std::optional<ips::StereoCalibration>& ran_on, double t0,
                              size_t max_error_samples) {
  FiltersSection section;
  const Trajectory& gt = log.gt;
  const double distance = distanceTravelled(gt);
  Json filters = Json::array();
  double first_end_err = NAN, first_end_pct = NAN, first_ate = NAN;
  for (const auto& run : log.runs) {
    const Trajectory est = statesTrajectory(run);
    FilterResult result{run.channel, filterName(run), alignStart(est, gt, inStartFrame(run)), {}};
    double ate = NAN, end_err = NAN, end_pct = NAN;
    if (est.size() >= 3 && gt.size() >= 3) {
      Trajectory ea, ra;
      associate(result.aligned, gt, 0.05, &ea, &ra);
      if (ea.size() >= 3) {
        ate = ateRmse(ea, ra);
        end_err = (ea.back().p - ra.back().p).norm();
        end_pct = distance > 0 ? 100.0 * end_err / distance : NAN;
      }
    }
    if (filters.empty()) first_end_err = end_err, first_end_pct = end_pct, first_ate = ate;
    result.errors = errorSeries(run, est, result.aligned, gt, t0, max_error_samples);
    Json f;
    f["channel"] = run.channel;
    f["filter"] = result.name;
    f["states"] = run.states.size();
    f["end_error_m"] = figure(end_err);
    f["end_error_pct"] = figure(end_pct);
    f["ate_rmse_m"] = figure(ate);
    f["nees_position_mean"] = figure(result.errors.nees_mean);
    f["nees_position_in_95_band_pct"] = figure(result.errors.nees_in_band_pct);
    f["heading_error_max_deg"] = figure(result.errors.heading_error_max_deg);
    f["heading_within_3sigma_pct"] = figure(result.errors.heading_within_3sigma_pct);
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
      f["tilt_error_start_mrad"] = figure(tiltError(run.states.front()));
      f["tilt_error_end_mrad"] = figure(tiltError(run.states.back()));
    }
    // The head's calibration as the filter estimated it online (its optional states), at the end: each estimate as
    // "name_unit": value(s) and "name_sigma_unit": sigma(s) (one dimension: a number, else an array), beside the
    // truth where the head is simulated.
    if (!run.states.empty()) {
      const ips::filter_state_t& last = run.states.back();
      for (const ips::calibration_estimate_t& c : last.calibration) {
        const std::string unit = c.unit.empty() ? "" : "_" + c.unit;
        Json v = Json::array(), s = Json::array();
        for (double x : c.value) v.push_back(figure(x));
        for (double x : c.sigma) s.push_back(figure(x));
        f[c.name + unit] = c.dim == 1 ? v[0] : v;
        f[c.name + "_sigma" + unit] = c.dim == 1 ? s[0] : s;
        if (c.name == "lever_arm" && c.dim == 3 && truth) {
          Json error = Json::array();
          for (int k = 0; k < 3; ++k) error.push_back(figure(c.value[k] - truth->T_imu_cam0.translation()(k)));
          f["lever_arm_error_m"] = error;
        }
        // The camera-to-IMU rotation's own error in the file the processes ran on (the principal points' part of
        // the alignment is not in it).
        if (c.name == "camera_alignment" && truth && ran_on) {
          const Eigen::AngleAxisd err(ran_on->T_imu_cam0.linear().transpose() * truth->T_imu_cam0.linear());
          const Eigen::Vector3d e = err.angle() * err.axis();
          f["camera_alignment_calibration_error_rad"] = Json::array({figure(e.x()), figure(e.y()), figure(e.z())});
        }
      }
    }
    filters.push_back(std::move(f));
    section.results.push_back(std::move(result));
  }
  section.json["filters"] = filters;
  section.json["end_error_m"] = figure(first_end_err);
  section.json["end_error_pct"] = figure(first_end_pct);
  section.json["ate_rmse_m"] = figure(first_ate);
  return section;
}

std::vector<double> defaultRpeLengths(double distance_m) {
  return distance_m > 40 ? std::vector<double>{10, 20, 40} : std::vector<double>{1, 2};
}

EstimatorsSection estimatorsSection(const RunLog& log, const Eigen::Isometry3d& T_imu_cam0,
                                    const std::vector<double>& lengths) {
  EstimatorsSection section;
  struct Estimate {
    std::string name;
    Trajectory est, ref;
    int64_t lost = 0;
  };
  DeltaConsistency delta_consistency;
  std::vector<Estimate> estimates;
  const std::vector<ips::tracker_delta_t>& deltas = log.delta_msgs;
  if (!deltas.empty()) {
    ips::tracker::DeltaChain chain;
    // The origin is the first pair; when the recording starts with a valid increment, its reference pair.
    if (deltas.front().valid)
      chain.add(deltas.front().utime_prev, 0, false, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero());
    for (const auto& d : deltas)
      chain.add(d.utime, d.utime_prev, d.valid, ips::fw::quaternionFromArray(d.rotation),
                ips::fw::vectorFromArray(d.translation));
    // Each delta starts at a pair the ones before reached (a dropped pair is bridged by the next delta, a pair too
    // poor to be a reference is skipped): one whose reference is unknown follows a delta missing from the recording,
    // which the recorder lost (its queue full while the machine was loaded).
    if (chain.unreferenced() > 0)
      section.warnings.push_back("the recording misses tracker deltas: the chain breaks " +
                                 std::to_string(chain.unreferenced()) + " times in " + std::to_string(deltas.size()) +
                                 " (the recorder fell behind)");
    Estimate t{"tracker", {}, {}, chain.invalid()};
    for (const auto& p : chain.poses()) {
      TrajPoint q;
      q.t = p.utime * 1e-6;
      q.p = p.T_world_cam0.translation();
      q.q = Eigen::Quaterniond(p.T_world_cam0.linear());
      t.est.push_back(q);
    }
    t.ref = rigidlyAttached(log.gt, T_imu_cam0);
    std::vector<RelativePoseMeasurement> steps;
    for (const auto& d : deltas) {
      if (!d.valid) continue;
      RelativePoseMeasurement m;
      m.t0 = d.utime_prev * 1e-6;
      m.t1 = d.utime * 1e-6;
      m.T.linear() = ips::fw::quaternionFromArray(d.rotation).toRotationMatrix();
      m.T.translation() = ips::fw::vectorFromArray(d.translation);
      m.covariance = Eigen::Map<const Eigen::Matrix<double, 6, 6, Eigen::RowMajor>>(d.covariance);
      steps.push_back(m);
    }
    delta_consistency = deltaConsistency(steps, t.ref);
    // On the page beside the truth: the chain placed at the truth's camera-0 pose at its first pair, as its end
    // error is judged (the camera is a lever arm away from the body the filters and the truth give).
    Trajectory ea, ra;
    if (t.ref.size() >= 3) associate(t.est, t.ref, 0.05, &ea, &ra);
    section.tracker = t.est;
    section.truth_cam0 = t.ref;
    section.tracker_on_truth = ea.empty() ? t.est : alignFirstPose(ea, ra);
    estimates.push_back(std::move(t));
  }
  for (const auto& run : log.runs)
    if (!run.states.empty()) estimates.push_back(Estimate{filterName(run), statesTrajectory(run), log.gt, 0});
  Json list = Json::array();
  for (const auto& est : estimates) {
    Trajectory ea, ra;
    if (est.ref.size() >= 3) associate(est.est, est.ref, 0.05, &ea, &ra);
    double ate = NAN, end_m = NAN, end_pct = NAN, dist = 0;
    RelativeErrors rel;
    if (ea.size() >= 3) {
      const TrajectoryErrors err = evaluate(ea, ra, lengths.front());
      ate = err.ate_rmse_m;
      dist = err.distance_m;
      rel = relativeErrors(ea, ra, lengths);
      end_m = endErrorFirstPoseAligned(ea, ra);
      end_pct = dist > 0 ? 100.0 * end_m / dist : NAN;
    }
    Json e;
    e["name"] = est.name;
    e["poses"] = est.est.size();
    e["matched"] = ea.size();
    e["lost"] = est.lost;
    e["distance_m"] = figure(dist);
    e["ate_rmse_m"] = figure(ate);
    e["rpe_trans_pct"] = figure(rel.trans_pct);
    e["rpe_rot_deg_per_m"] = figure(rel.rot_deg_per_m);
    e["rpe_subsequences"] = rel.subsequences;
    e["end_error_m"] = figure(end_m);
    e["end_error_pct"] = figure(end_pct);
    if (est.name == "tracker" && delta_consistency.deltas > 0) {
      e["delta_nees_translation"] = figure(delta_consistency.nees_translation);
      e["delta_nees_rotation"] = figure(delta_consistency.nees_rotation);
      e["delta_error_lag1_correlation"] = figure(delta_consistency.lag1_correlation);
    }
    list.push_back(std::move(e));
  }
  section.json["estimators"] = list;
  Json l = Json::array();
  for (double x : lengths) l.push_back(figure(x));
  section.json["rpe_lengths_m"] = l;
  return section;
}

std::vector<DisparityScore> disparityScores(const RunLog& log) {
  std::vector<DisparityScore> scores;
  for (const auto& [utime, est] : log.est_disp) {
    const auto g = log.gt_disp.find(utime);
    if (g == log.gt_disp.end()) continue;
    // E3D's map against the true one, at E3D's scale (output_scale) and in its pixels, as stereo benchmarks at a
    // reduced resolution count.
    const cv::Mat e = ips::fw::disparityImage(est);
    const cv::Mat truth = truthAtSize(ips::fw::disparityImage(g->second), e.size());
    const DisparityErrors err = disparityErrors(e, truth, {kBadDisparityPx});
    scores.push_back({est.seq, err.badPct(0), err.densityPct(), err.evaluated});
  }
  return scores;
}

Json disparitySection(const RunLog& log, const std::vector<DisparityScore>& scores) {
  double bad2 = 0, density = 0;
  int64_t evaluated = 0;
  for (const auto& s : scores) bad2 += s.bad2_pct * s.evaluated, density += s.density_pct, evaluated += s.evaluated;
  Json j;
  j["disparity_maps"] = log.est_disp.size();
  j["disparity_maps_with_ground_truth"] = scores.size();
  j["disparity_bad2_pct"] = figure(evaluated ? bad2 / evaluated : NAN);
  j["disparity_density_pct"] = figure(scores.empty() ? NAN : density / scores.size());
  return j;
}

Json mapSection(const RunLog& log, const std::vector<Eigen::Vector3d>& map,
                const std::optional<std::vector<Eigen::Vector3d>>& map_gt_poses, const ips::sim::World* world) {
  Json j;
  j["map_points"] = map.size();
  Eigen::Isometry3d T_truth_map = Eigen::Isometry3d::Identity();
  if (!log.runs.empty() && !log.runs.front().states.empty())
    T_truth_map = startAlignment(statesTrajectory(log.runs.front()), log.gt, inStartFrame(log.runs.front()));
  auto surfaceKeys = [&](const std::vector<Eigen::Vector3d>& pts, const Eigen::Isometry3d& T, const std::string& sfx) {
    const SurfaceErrors e = surfaceErrors(pts, *world, T, kMapWithinM);
    j["map_median_surface_error_m" + sfx] = figure(e.median_m);
    j["map_p90_surface_error_m" + sfx] = figure(e.p90_m);
    j["map_within_5cm_pct" + sfx] = figure(e.within_pct);
  };
  if (world) surfaceKeys(map, T_truth_map, "");
  if (map_gt_poses) {
    j["map_points_gt_poses"] = map_gt_poses->size();
    if (world) surfaceKeys(*map_gt_poses, Eigen::Isometry3d::Identity(), "_gt_poses");
  }
  // The earlier and the later half of the run (by image time); with the true poses the gap is what the voxels and
  // the stereo error leave, the rest of the filter's gap is navigation drift.
  auto consistencyKeys = [&](const std::vector<MapPoints>& maps, const std::string& sfx) {
    if (maps.size() < 2) return;
    std::vector<Eigen::Vector3d> early, late;
    const int64_t middle = (maps.front().utime + maps.back().utime) / 2;
    for (const auto& mp : maps) {
      auto& half = mp.utime < middle ? early : late;
      half.insert(half.end(), mp.points.begin(), mp.points.end());
    }
    const SelfConsistency c = selfConsistency(early, late, kMapOverlapM);
    j["map_consistency_median_m" + sfx] = figure(c.median_m);
    j["map_consistency_p90_m" + sfx] = figure(c.p90_m);
    j["map_consistency_overlap_pct" + sfx] = figure(c.late_points ? 100.0 * c.overlapping / c.late_points : NAN);
  };
  consistencyKeys(log.map_points, "");
  consistencyKeys(log.map_points_gt_poses, "_gt_poses");
  // Depth from one camera (MONO_POINTS) beside the stereo maps' points (POINTS), both as published, placed with the
  // filter's poses and put on the truth by the same alignment: each point's distance to the true surfaces.
  j["mono_maps"] = log.mono_points.size();
  if (world && !log.mono_points.empty()) {
    auto pointKeys = [&](const std::vector<MapPoints>& maps, const std::string& prefix) {
      std::vector<Eigen::Vector3d> all;
      for (const auto& mp : maps) all.insert(all.end(), mp.points.begin(), mp.points.end());
      // An even sample keeps the distance queries to seconds; the figures are medians and shares.
      const size_t stride = std::max<size_t>(1, all.size() / kSurfaceSamplePoints);
      std::vector<Eigen::Vector3d> sample;
      for (size_t i = 0; i < all.size(); i += stride) sample.push_back(all[i]);
      const SurfaceErrors e = surfaceErrors(sample, *world, T_truth_map, kMapWithinM);
      j[prefix + "points"] = all.size();
      j[prefix + "median_surface_error_m"] = figure(e.median_m);
      j[prefix + "p90_surface_error_m"] = figure(e.p90_m);
      j[prefix + "within_5cm_pct"] = figure(e.within_pct);
    };
    pointKeys(log.mono_points, "mono_");
    pointKeys(log.map_points, "stereo_");
  }
  return j;
}

Eigen::Vector3d mapUpFromTruth(const RunLog& log) {
  if (log.gt.empty() || log.delta_msgs.empty())
    throw std::invalid_argument("the map's up from the truth needs the ground truth and the tracker's increments");
  // The tracker's chain starts at its first increment's image: the body there is the map's world.
  return truthAttitudeAt(log.gt, log.delta_msgs.front().utime * 1e-6).conjugate() * Eigen::Vector3d::UnitZ();
}

Json processesSection(const RunLog& log) {
  Json procs = Json::object();
  for (const auto& [name, f] : log.procs) {
    Json p;
    p["rate_hz"] = figure(f.rate_n ? f.rate_sum / f.rate_n : 0);
    p["latency_ms"] = figure(f.latency_n ? f.latency_sum / f.latency_n : 0);
    p["received"] = f.last.received;
    p["published"] = f.last.published;
    p["dropped"] = f.last.dropped;
    p["bad"] = f.last.bad;
    // Its detailed counters at the end (seq_gap: messages lost on the way; the filter's imu_gaps, tracker_too_late).
    Json counters = Json::object();
    for (int i = 0; i < f.last.num_counters; ++i) counters[f.last.counter_names[i]] = f.last.counter_values[i];
    p["counters"] = counters;
    procs[name] = p;
  }
  Json j;
  j["processes"] = procs;
  return j;
}

Json calibrationFigures(const std::string& path) {
  Json figures = Json::object();
  cv::FileStorage fs;
  try {
    if (path.empty() || !fs.open(path, cv::FileStorage::READ)) return figures;
  } catch (const cv::Exception&) {
    return figures;
  }
  for (const cv::FileNode& block : fs.root()) {
    const std::string name = block.name();
    if (!block.isMap() || name.size() < 8 || name.compare(name.size() - 8, 8, "_figures") != 0) continue;
    Json b = Json::object();
    for (const cv::FileNode& item : block) {
      if (item.isString())
        b[item.name()] = static_cast<std::string>(item);
      else if (item.isInt() || item.isReal())
        b[item.name()] = figure(static_cast<double>(item));
    }
    figures[name] = b;
  }
  return figures;
}

std::string runStatus(const std::vector<std::string>& failures, const std::vector<std::string>& warnings) {
  return !failures.empty() ? "failed" : !warnings.empty() ? "disturbed" : "ok";
}

}  // namespace ips::eval
