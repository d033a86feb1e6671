// real_imu_eval: both filters on a recording's real IMU over its whole flight, with the tracker's deltas made from
// the ground truth. Real data for everything the IMU side of the filters does (its frames and axes, gravity and
// biases at a moving start, the camera-to-IMU mounting, the noise the head's description gives), over windows as
// long as a flight and far longer than the few frames a shared excerpt keeps: the EuRoC V1_01 excerpt has 20 frames
// but the flight's whole IMU (145 s) and its re-estimated truth (vicon2gt: pose, velocity and biases at every camera
// time). Only the deltas are made: the relative pose of camera 0 between consecutive truth times, with an error of
// the size the tracker has on real images (--delta-sigma-t, -r: its errors on EuRoC MH_01 against the truth), white
// or correlated from one delta to the next (--delta-lag1; the tracker's translation errors there have 0.8), the
// covariance given with them that of white noise, as the tracker gives it.
//
// Each window starts the deployed estimator (config/filter_recording.yaml, the head's IMU from its description) as it
// starts on a recording: by itself, in motion, from its IMU and the first deltas. Figures per window, both filters and
// the deltas chained alone (what the tracker would give), the same way as ips_report: ATE (SE(3)-aligned), end error
// with the first pose aligned (% of the distance), the heading error inside its 3-sigma bound, the position NEES
// inside its 95 % band (share of the truth times), and the biases at the window's end against vicon2gt's.
//
//   real_imu_eval [--dataset ../shared/data/euroc/V1_01_easy] [--config config/filter_recording.yaml]
//                 [--window 30] [--every 15] [--first 5] [--delta-sigma-t 2.6e-4] [--delta-sigma-r 1.2e-4]
//                 [--delta-lag1 0] [--seed 1]
// Last line: windows=N deltas_end_pct_max=.. ekf_not_started=.. ekf_ate_ratio_max=.. ekf_end_pct_max=..
//            ekf_heading_in_3sigma_pct_min=.. ekf_nees_in_band_pct_mean=.. ekf_imu_rejected_pct_max=..
//            ekf_deltas_rejected_pct_max=.. ukf_... (ratio: the filter's ATE over the chained deltas')
#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "ips/args.hpp"
#include "ips/config.hpp"
#include "ips/data_dir.hpp"
#include "ips/dataset/dataset.hpp"
#include "ips/eval/trajectory.hpp"
#include "ips/filter/estimator.hpp"
#include "ips/filter/models.hpp"
#include "ips/filter/optional_states.hpp"
#include "ips/filter/state.hpp"
#include "ips/log.hpp"

using namespace ips::filter;
using namespace ips::eval;

namespace {

struct DeltaNoise {
  double sigma_t = 2.6e-4;  // [m] per axis
  double sigma_r = 1.2e-4;  // [rad] per axis
  double lag1 = 0;          // correlation of one delta's error with the previous one's (first-order autoregressive)
};

// Relative poses of camera 0 from the truth, with errors e_k = lag1 e_(k-1) + sqrt(1 - lag1^2) sigma n_k (stationary
// sigma), applied as T_measured = T_true * Exp(e).
class TruthDeltas {
 public:
  TruthDeltas(const ips::StereoCalibration& calib, const DeltaNoise& noise, uint32_t seed)
      : calib_(calib), noise_(noise), rng_(seed) {}

  TrackerDelta delta(const ips::InertialState& a, const ips::InertialState& b) {
    const Eigen::Isometry3d T_true =
        ips::dataset::cameraPose(a, calib_).inverse() * ips::dataset::cameraPose(b, calib_);
    const double w = std::sqrt(std::max(0.0, 1.0 - noise_.lag1 * noise_.lag1));
    for (int i = 0; i < 3; ++i) {
      e_t_[i] = noise_.lag1 * e_t_[i] + w * noise_.sigma_t * n01_(rng_);
      e_r_[i] = noise_.lag1 * e_r_[i] + w * noise_.sigma_r * n01_(rng_);
    }
    TrackerDelta d;
    d.utime_prev = a.utime;
    d.utime = b.utime;
    d.translation = T_true.translation() + e_t_;
    d.rotation = Eigen::Quaterniond(T_true.linear()) * expQuat(e_r_);
    d.rotation.normalize();
    d.covariance.setZero();
    d.covariance.diagonal() << Eigen::Vector3d::Constant(noise_.sigma_t * noise_.sigma_t),
        Eigen::Vector3d::Constant(noise_.sigma_r * noise_.sigma_r);
    return d;
  }

 private:
  const ips::StereoCalibration& calib_;
  DeltaNoise noise_;
  std::mt19937 rng_;
  std::normal_distribution<double> n01_{0.0, 1.0};
  Eigen::Vector3d e_t_ = Eigen::Vector3d::Zero(), e_r_ = Eigen::Vector3d::Zero();
};

struct WindowFigures {
  bool started = false;
  double start_s = NAN;  // the first state's time after the window's start
  double ate_m = NAN, end_pct = NAN;
  double heading_in_3sigma_pct = NAN, heading_max_deg = NAN;
  double nees_in_band_pct = NAN, nees_mean = NAN;
  double imu_rejected_pct = NAN, deltas_rejected_pct = NAN;  // by the filter's gates
  double delta_scale = NAN, delta_scale_sigma = NAN;         // the tracker's scale error, where estimated
  Eigen::Vector3d gyro_bias_error = Eigen::Vector3d::Constant(NAN), gyro_bias_sigma = Eigen::Vector3d::Constant(NAN);
  Eigen::Vector3d accel_bias_error = Eigen::Vector3d::Constant(NAN), accel_bias_sigma = Eigen::Vector3d::Constant(NAN);
};

TrajPoint pointOf(int64_t utime, const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
  return TrajPoint{static_cast<double>(utime) * 1e-6, p, q};
}

// ATE and end error of `est` against `ref` (both at the same times, the first pose aligned for the end error).
void trajectoryFigures(const Trajectory& est, const Trajectory& ref, WindowFigures* f) {
  if (est.size() < 3) return;
  f->ate_m = ateRmse(est, ref);
  const double distance = distanceTravelled(ref);
  f->end_pct = distance > 0 ? 100.0 * endErrorFirstPoseAligned(est, ref) / distance : NAN;
}

}  // namespace

int main(int argc, char** argv) {
  ips::setLogLevel(ips::LogLevel::Warn);
  try {
    ips::Args args(argc, argv,
                   "both filters on a recording's real IMU over its whole flight, the tracker's deltas made from its "
                   "ground truth with the tracker's error");
    args.option("--dataset", "DIR", "EuRoC folder with the flight's IMU and a ground truth with state (vicon2gt)",
                ips::dataDir() + "/euroc/V1_01_easy")
        .option("--config", "FILE", "filter configuration (section filter)", "config/filter_recording.yaml")
        .option("--window", "S", "length of each window", "30")
        .option("--every", "S", "a window starts every S seconds", "15")
        .option("--first", "S", "the first window starts S seconds after the truth's first time", "5")
        .option("--image-hz", "F", "deltas per second (every n-th truth time; the truth is at the camera's times)",
                "20")
        .option("--delta-sigma-t", "M", "the deltas' translation error per axis (stationary sigma)", "2.6e-4")
        .option("--delta-sigma-r", "RAD", "the deltas' rotation error per axis (stationary sigma)", "1.2e-4")
        .option("--delta-lag1", "R", "correlation of a delta's error with the previous one's", "0")
        .option("--seed", "S", "seed of the deltas' errors", "1");
    if (!args.parse()) return 0;
    const double window_s = args.getDouble("--window"), every_s = args.getDouble("--every");
    const double first_s = args.getDouble("--first"), image_hz = args.getDouble("--image-hz");
    DeltaNoise noise;
    noise.sigma_t = args.getDouble("--delta-sigma-t");
    noise.sigma_r = args.getDouble("--delta-sigma-r");
    noise.lag1 = args.getDouble("--delta-lag1");
    if (!(window_s > 1 && every_s > 0 && image_hz > 0 && noise.sigma_t > 0 && noise.sigma_r > 0 &&
          std::abs(noise.lag1) < 1))
      throw std::runtime_error("--window > 1, --every, --image-hz, the sigmas > 0 and |--delta-lag1| < 1 are needed");
    const uint32_t seed = static_cast<uint32_t>(args.getInt("--seed"));

    ips::dataset::ReadOptions ro;
    ro.whole_recording = true;
    const ips::dataset::Recording rec = ips::dataset::readEuroc(args.get("--dataset"), ro);
    if (rec.imu.empty() || !rec.calib.imu) throw std::runtime_error(args.get("--dataset") + ": no IMU");
    if (!rec.ground_truth_has_state)
      throw std::runtime_error(rec.ground_truth_source +
                               ": the ground truth has no biases (a vicon2gt or state_groundtruth_estimate0 file)");
    const ips::Config cfg(args.get("--config"));
    FilterParams base = loadFilterParams(cfg.has("filter") ? cfg.section("filter") : cfg);
    cfg.refuseUnreadKeys();

    // The truth's times are the camera's; keep every n-th for the image rate asked.
    const auto& gt_all = rec.ground_truth;
    const double truth_hz =
        (gt_all.size() - 1) / (static_cast<double>(gt_all.back().utime - gt_all.front().utime) * 1e-6);
    const int stride = std::max(1, static_cast<int>(std::lround(truth_hz / image_hz)));
    std::printf(
        "%s: IMU %zu samples (%s), truth %zu states at %.1f Hz (%s), deltas every %d: %.1f Hz, error %.3g m / "
        "%.3g rad per axis, lag-1 correlation %.2f\n",
        args.get("--dataset").c_str(), rec.imu.size(), rec.calib.imu->model.c_str(), gt_all.size(), truth_hz,
        rec.ground_truth_source.c_str(), stride, truth_hz / stride, noise.sigma_t, noise.sigma_r, noise.lag1);
    std::printf("%-8s %-6s %8s %8s %9s %8s %9s %9s %22s %22s\n", "window", "filter", "start", "ATE mm", "end %",
                "heading", "3sigma %", "NEES in %", "gyro bias err mrad/s", "accel bias err mm/s2");

    struct Summary {
      double ate_ratio_max = 0, end_pct_max = 0, heading_min = 100, nees_sum = 0, imu_rejected_max = 0,
             deltas_rejected_max = 0;
      int n = 0, not_started = 0;
    };
    Summary sum[2], deltas_sum;
    int windows = 0;
    const int64_t gt_t0 = gt_all.front().utime;
    for (double w0 = first_s;; w0 += every_s) {
      const int64_t t0 = gt_t0 + static_cast<int64_t>(std::llround(w0 * 1e6));
      const int64_t t1 = t0 + static_cast<int64_t>(std::llround(window_s * 1e6));
      if (t1 > gt_all.back().utime || t1 > rec.imu.back().utime) break;
      std::vector<ips::InertialState> gt;
      for (size_t i = 0; i < gt_all.size(); ++i)
        if (gt_all[i].utime >= t0 && gt_all[i].utime <= t1 && (gt.empty() || static_cast<int>(i) % stride == 0))
          gt.push_back(gt_all[i]);
      if (gt.size() < 10) continue;
      ++windows;
      WindowFigures fig[2], chain_fig;
      Trajectory chain_est, chain_ref;
      for (int f = 0; f < 2; ++f) {
        FilterParams params = base;
        params.type = f == 0 ? FilterType::Ekf : FilterType::Ukf;
        Estimator est(params, rec.calib);
        TruthDeltas deltas(rec.calib, noise, seed + static_cast<uint32_t>(windows));
        std::vector<FilterOutput> outputs;
        std::vector<TrackerDelta> made;
        size_t k = 0;
        auto imu = std::lower_bound(rec.imu.begin(), rec.imu.end(), gt.front().utime,
                                    [](const ips::dataset::ImuSample& s, int64_t t) { return s.utime < t; });
        for (; imu != rec.imu.end() && imu->utime <= gt.back().utime; ++imu) {
          while (k < gt.size() && gt[k].utime < imu->utime) {
            est.addImageTime(gt[k].utime);
            if (k > 0) {
              made.push_back(deltas.delta(gt[k - 1], gt[k]));
              est.addTrackerDelta(made.back());
            }
            ++k;
          }
          est.addImu({imu->utime, imu->angular_rate, imu->specific_force});
          for (FilterOutput& o : est.takeOutputs()) outputs.push_back(std::move(o));
        }
        est.flush();
        for (FilterOutput& o : est.takeOutputs()) outputs.push_back(std::move(o));
        auto rejectedPct = [](const SensorCounters& c) {
          return c.accepted + c.rejected > 0 ? 100.0 * c.rejected / static_cast<double>(c.accepted + c.rejected) : NAN;
        };
        fig[f].imu_rejected_pct = rejectedPct(est.counters()[kSensorImu]);
        fig[f].deltas_rejected_pct = rejectedPct(est.counters()[kSensorTracker]);
        if (outputs.empty()) {
          ++sum[f].not_started;
          continue;
        }
        // The filter at the truth's times from its first state on, and the truth there.
        std::vector<const FilterOutput*> at;
        Trajectory est_traj, ref;
        std::vector<const ips::InertialState*> truth_at;
        size_t o = 0;
        for (const auto& g : gt) {
          while (o < outputs.size() && outputs[o].state.utime < g.utime) ++o;
          if (o >= outputs.size()) break;
          if (outputs[o].state.utime != g.utime) continue;
          at.push_back(&outputs[o]);
          truth_at.push_back(&g);
          est_traj.push_back(pointOf(g.utime, outputs[o].state.position, outputs[o].state.orientation));
          ref.push_back(pointOf(g.utime, g.position, g.orientation));
        }
        if (est_traj.size() < 3) {
          ++sum[f].not_started;
          continue;
        }
        WindowFigures& wf = fig[f];
        wf.started = true;
        wf.start_s = est_traj.front().t - static_cast<double>(t0) * 1e-6;
        trajectoryFigures(est_traj, ref, &wf);
        // NEES and heading in the truth's frame: the first state aligned to the truth (position and attitude, as
        // the report does for a filter published in its start frame), the covariance rotated with it.
        const Eigen::Matrix3d R = (ref.front().q * est_traj.front().q.inverse()).toRotationMatrix();
        int nees_in = 0, nees_n = 0, heading_in = 0;
        double nees_sum = 0, heading_max = 0;
        for (size_t i = 0; i < at.size(); ++i) {
          const Eigen::Vector3d p = R * (est_traj[i].p - est_traj.front().p) + ref.front().p;
          const Eigen::Quaterniond q = Eigen::Quaterniond(R) * est_traj[i].q;
          const Eigen::Matrix3d Pp = R * at[i]->covariance.block<3, 3>(kErrP, kErrP) * R.transpose();
          const Eigen::Matrix3d Pa = R * at[i]->covariance.block<3, 3>(kErrTh, kErrTh) * R.transpose();
          const Eigen::Vector3d e = ref[i].p - p;
          if (i > 0) {
            const double nees = e.dot(Pp.ldlt().solve(e));
            nees_sum += nees;
            nees_in += nees >= kChi2Dof3Lo && nees <= kChi2Dof3Hi ? 1 : 0;
            ++nees_n;
          }
          const Eigen::AngleAxisd d(ref[i].q * q.inverse());
          const double heading = std::abs((d.angle() * d.axis()).z());
          heading_max = std::max(heading_max, heading);
          heading_in += heading <= 3 * std::sqrt(std::max(0.0, Pa(2, 2))) ? 1 : 0;
        }
        wf.nees_in_band_pct = nees_n ? 100.0 * nees_in / nees_n : NAN;
        wf.nees_mean = nees_n ? nees_sum / nees_n : NAN;
        wf.heading_in_3sigma_pct = 100.0 * heading_in / static_cast<double>(at.size());
        wf.heading_max_deg = heading_max * 180 / M_PI;
        const FilterOutput& last = *at.back();
        if (const auto& c = last.calibration[kDeltaScale])
          wf.delta_scale = c->value(0), wf.delta_scale_sigma = c->sigma()(0);
        const ips::InertialState& gl = *truth_at.back();
        for (int a = 0; a < 3; ++a) {
          wf.gyro_bias_error[a] = last.state.gyro_bias[a] - gl.gyro_bias[a];
          wf.gyro_bias_sigma[a] = std::sqrt(last.covariance(kErrBg + a, kErrBg + a));
          wf.accel_bias_error[a] = last.state.accel_bias[a] - gl.accel_bias[a];
          wf.accel_bias_sigma[a] = std::sqrt(last.covariance(kErrBa + a, kErrBa + a));
        }
        if (f == 0) {
          // The deltas alone, chained from the filter's first state on (the tracker's trajectory), at the same times.
          Eigen::Isometry3d T_cam = Eigen::Isometry3d::Identity();
          const Eigen::Isometry3d T_cam_imu = rec.calib.T_imu_cam0.inverse();
          size_t next = 0;
          for (size_t i = 0; i < ref.size(); ++i) {
            const int64_t t = truth_at[i]->utime;
            while (next < made.size() && made[next].utime <= t) {
              if (made[next].utime_prev >= truth_at.front()->utime) {
                Eigen::Isometry3d D = Eigen::Isometry3d::Identity();
                D.linear() = made[next].rotation.toRotationMatrix();
                D.translation() = made[next].translation;
                T_cam = T_cam * D;
              }
              ++next;
            }
            const Eigen::Isometry3d T_body = T_cam * T_cam_imu;
            chain_est.push_back(pointOf(t, T_body.translation(), Eigen::Quaterniond(T_body.linear())));
          }
          chain_ref = ref;
          chain_fig.started = true;
          chain_fig.start_s = wf.start_s;
          trajectoryFigures(chain_est, chain_ref, &chain_fig);
        }
      }
      auto row = [&](const char* name, const WindowFigures& f) {
        if (!f.started) {
          std::printf("%-8.0f %-6s %8s\n", w0, name, "no start");
          return;
        }
        std::printf("%-8.0f %-6s %7.2fs %8.2f %9.3f %7.2fd %9.1f %9.1f", w0, name, f.start_s, 1e3 * f.ate_m, f.end_pct,
                    f.heading_max_deg, f.heading_in_3sigma_pct, f.nees_in_band_pct);
        if (std::isfinite(f.gyro_bias_error.x()))
          std::printf("   %5.2f %5.2f %5.2f (%4.2f)  %6.1f %6.1f %6.1f (%4.1f)", 1e3 * f.gyro_bias_error.x(),
                      1e3 * f.gyro_bias_error.y(), 1e3 * f.gyro_bias_error.z(), 1e3 * f.gyro_bias_sigma.maxCoeff(),
                      1e3 * f.accel_bias_error.x(), 1e3 * f.accel_bias_error.y(), 1e3 * f.accel_bias_error.z(),
                      1e3 * f.accel_bias_sigma.maxCoeff());
        if (std::isfinite(f.imu_rejected_pct))
          std::printf("  rejected: IMU %.1f %%, deltas %.1f %%", f.imu_rejected_pct, f.deltas_rejected_pct);
        if (std::isfinite(f.delta_scale))
          std::printf("  scale %+.2f +- %.2f %%", 100 * f.delta_scale, 100 * f.delta_scale_sigma);
        std::printf("\n");
      };
      row("deltas", chain_fig);
      row("ekf", fig[0]);
      row("ukf", fig[1]);
      if (chain_fig.started) {
        ++deltas_sum.n;
        deltas_sum.end_pct_max = std::max(deltas_sum.end_pct_max, chain_fig.end_pct);
      }
      for (int f = 0; f < 2; ++f) {
        if (!fig[f].started) continue;
        Summary& s = sum[f];
        ++s.n;
        if (chain_fig.started) s.ate_ratio_max = std::max(s.ate_ratio_max, fig[f].ate_m / chain_fig.ate_m);
        s.end_pct_max = std::max(s.end_pct_max, fig[f].end_pct);
        s.heading_min = std::min(s.heading_min, fig[f].heading_in_3sigma_pct);
        s.nees_sum += fig[f].nees_in_band_pct;
        s.imu_rejected_max = std::max(s.imu_rejected_max, fig[f].imu_rejected_pct);
        s.deltas_rejected_max = std::max(s.deltas_rejected_max, fig[f].deltas_rejected_pct);
      }
    }
    std::printf("windows=%d deltas_end_pct_max=%.4f", windows, deltas_sum.end_pct_max);
    for (int f = 0; f < 2; ++f) {
      const char* name = f == 0 ? "ekf" : "ukf";
      const Summary& s = sum[f];
      std::printf(
          " %s_not_started=%d %s_ate_ratio_max=%.3f %s_end_pct_max=%.4f %s_heading_in_3sigma_pct_min=%.1f "
          "%s_nees_in_band_pct_mean=%.1f %s_imu_rejected_pct_max=%.2f %s_deltas_rejected_pct_max=%.2f",
          name, s.not_started, name, s.ate_ratio_max, name, s.end_pct_max, name, s.heading_min, name,
          s.n ? s.nees_sum / s.n : NAN, name, s.imu_rejected_max, name, s.deltas_rejected_max);
    }
    std::printf("\n");
    return windows > 0 ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "real_imu_eval: %s\n", e.what());
    return 1;
  }
}
