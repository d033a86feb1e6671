// navigate_log: the deployed navigation (tracker, EKF feeding the tracker's predictions, UKF beside it) over a
// recording's log on one thread, in the log's order, without the bus: what the main job's navigation gives when no
// message is lost or late. Writes the results as the main job's logger would (TRACKER_DELTA, FILTER_STATE,
// FILTER_STATE_UKF, GT_POSE), so that ips_report evaluates them the same way:
//
//   navigate_log --log walk.lcmlog --tracker-config config/euroc.yaml --filter-config config/filter.yaml
//                --out nav.lcmlog [--calib C] [--no-filter-prior] [--deltas FILE.lcmlog]
//   ips_report --log nav.lcmlog --calib walk.lcmlog.calib.yaml --pictures 0 --out DIR
//
// --deltas takes the tracker's deltas from a recording (a main job's results) instead of running the tracker: the
// filters alone, for their parameters, in seconds. Messages are converted by the processes' own code
// (processes/*/app/*_messages.hpp). Last line: "pairs=N deltas=V ekf_states=S ukf_states=S".
#include <ips/ground_truth_t.hpp>
#include <ips/imu_sample_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <ips/tilt_sample_t.hpp>
#include <map>
#include <memory>
#include <opencv2/core.hpp>

#include "app/filter_messages.hpp"
#include "app/tracker_messages.hpp"
#include "ips/args.hpp"
#include "ips/calibration.hpp"
#include "ips/config.hpp"
#include "ips/filter/estimator.hpp"
#include "ips/filter/params.hpp"
#include "ips/framework/channels.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/log_reader.hpp"
#include "ips/framework/log_writer.hpp"
#include "ips/framework/message_arrays.hpp"
#include "ips/framework/process.hpp"
#include "ips/framework/validate.hpp"
#include "ips/log.hpp"
#include "ips/tracker/epipolar_integrity.hpp"
#include "ips/tracker/pair_scheduler.hpp"
#include "ips/tracker/prior_builder.hpp"
#include "ips/tracker/stereo_tracker.hpp"

namespace {

template <class Msg>
bool decode(const ips::fw::LogMessage& e, Msg* m) {
  return m->decode(e.data.data(), 0, static_cast<int>(e.data.size())) >= 0;
}

}  // namespace

int main(int argc, char** argv) {
  return ips::fw::guardedMain("navigate_log", [&]() {
    ips::Args args(argc, argv, "tracker, EKF and UKF over a recording's log on one thread, results as an LCM log");
    args.required("--log", "FILE.lcmlog", "the head's log (STEREO, IMU, TILT, GT_POSE)")
        .option("--calib", "FILE", "calibration (default: FILE.lcmlog.calib.yaml)")
        .required("--tracker-config", "FILE", "tracker parameters (config/euroc.yaml, ...)")
        .required("--filter-config", "FILE", "filter parameters (config/filter.yaml, ...)")
        .required("--out", "FILE.lcmlog", "the results")
        .option("--deltas", "FILE.lcmlog", "the tracker's deltas from this recording instead of running the tracker")
        .flag("--no-filter-prior", "the tracker without the EKF's predictions (gyro, else constant velocity)");
    if (!args.parse()) return 0;
    ips::setLogLevel(ips::LogLevel::Warn);
    cv::setNumThreads(1);
    const std::string log_path = args.get("--log");
    const ips::StereoCalibration calib =
        ips::loadCalibration(args.has("--calib") ? args.get("--calib") : log_path + ".calib.yaml");
    const ips::Config tracker_cfg(args.get("--tracker-config"));
    const ips::tracker::TrackerParams tracker_params = ips::tracker::loadTrackerParams(tracker_cfg);
    ips::tracker::StereoTracker tracker(calib, tracker_params);
    // The epipolar monitor as the tracker process runs it (config integrity/enabled).
    ips::tracker::EpipolarMonitor monitor(tracker.rectification(), ips::tracker::loadIntegrityParams(tracker_cfg));
    ips::tracker::PriorBuilder priors(calib.T_imu_cam0, ips::tracker::loadPriorBuilderParams(tracker_cfg),
                                      tracker_params.prior);
    const ips::Config filter_cfg(args.get("--filter-config"));
    ips::filter::FilterParams params =
        ips::filter::loadFilterParams(filter_cfg.has("filter") ? filter_cfg.section("filter") : filter_cfg);
    params.type = ips::filter::FilterType::Ekf;
    ips::filter::Estimator ekf(params, calib);
    params.type = ips::filter::FilterType::Ukf;
    ips::filter::Estimator ukf(params, calib);
    // A misspelled key would run the experiment on the default: refused, as the processes refuse it. The tracker's
    // disparity wait is the process's alone; read so that its keys count as known.
    ips::tracker::loadDisparityWait(tracker_cfg, false);
    tracker_cfg.refuseUnreadKeys();
    filter_cfg.refuseUnreadKeys();
    const bool filter_prior = !args.getFlag("--no-filter-prior");

    // Recorded deltas by the stamp of their newer image, fused when the pair's image time is reached.
    std::map<int64_t, ips::tracker_delta_t> recorded;
    if (args.has("--deltas")) {
      ips::fw::LogReader in(args.get("--deltas"));
      ips::fw::LogMessage e;
      while (in.next(&e)) {
        ips::tracker_delta_t d;
        if (e.channel == ips::channels::kTrackerDelta && decode(e, &d) && ips::fw::validate(d).ok())
          recorded.emplace(d.utime, d);
      }
    }

    ips::fw::LogWriter out(args.get("--out"));
    int64_t now = 0, pairs = 0, deltas = 0, ekf_states = 0, ukf_states = 0, last_pair = 0;
    auto publishStates = [&]() {
      for (const auto& o : ekf.takeOutputs()) {
        out.write(ips::channels::kFilterState, now, ips::filter_app::toMessage(o));
        ++ekf_states;
      }
      for (const auto& o : ukf.takeOutputs()) {
        out.write("FILTER_STATE_UKF", now, ips::filter_app::toMessage(o));
        ++ukf_states;
      }
    };
    auto fuse = [&](const ips::tracker_delta_t& d) {
      out.write(ips::channels::kTrackerDelta, now, d);
      ++deltas;
      if (!d.valid && !d.far_valid) return;
      ekf.addTrackerDelta(ips::filter_app::toDelta(d));
      ukf.addTrackerDelta(ips::filter_app::toDelta(d));
    };

    ips::fw::LogReader log(log_path);
    ips::fw::LogMessage e;
    while (log.next(&e)) {
      if (e.channel == ips::channels::kImu) {
        ips::imu_sample_t m;
        if (!decode(e, &m) || !ips::fw::validate(m).ok()) continue;
        now = m.utime;
        const ips::filter::ImuSample s = ips::filter_app::toImuSample(m);
        ekf.addImu(s);
        ukf.addImu(s);
        priors.addGyro(m.utime, s.angular_rate);
      } else if (e.channel == ips::channels::kTilt) {
        ips::tilt_sample_t m;
        if (!decode(e, &m) || !ips::fw::validate(m).ok()) continue;
        now = m.utime;
        ekf.addTilt({m.utime, m.angle_x, m.angle_y});
        ukf.addTilt({m.utime, m.angle_x, m.angle_y});
      } else if (e.channel == "GT_POSE") {
        ips::ground_truth_t g;
        if (decode(e, &g)) out.write("GT_POSE", e.timestamp, g);
      } else if (e.channel == ips::channels::kStereo) {
        ips::stereo_pair_t m;
        if (!decode(e, &m) || !ips::fw::validate(m).ok()) continue;
        now = m.utime;
        ++pairs;
        const auto prior_state = ekf.addImageTime(m.utime);
        ukf.addImageTime(m.utime);
        if (prior_state && filter_prior)
          priors.addFilterState(ips::tracker_app::fromMessage(ips::filter_app::toMessage(*prior_state)));
        if (args.has("--deltas")) {
          const auto it = recorded.find(m.utime);
          if (it != recorded.end()) fuse(it->second);
        } else {
          std::optional<ips::tracker::MotionPrior> prior;
          if (last_pair > 0 && !(prior = priors.fromFilter(last_pair, m.utime)))
            prior = priors.fromGyro(last_pair, m.utime);
          const ips::tracker::TrackResult r = tracker.process(m.utime, ips::fw::leftImage(m), ips::fw::rightImage(m),
                                                              prior ? &*prior : nullptr, nullptr);
          if (monitor.params().enabled) ips::tracker::monitorPair(monitor, tracker, m.utime);
          last_pair = m.utime;
          if (r.utime_prev != 0) fuse(ips::tracker_app::toMessage(r, m.seq));
        }
      } else {
        continue;
      }
      publishStates();
    }
    ekf.flush();
    ukf.flush();
    publishStates();
    for (const auto* est : {&ekf, &ukf}) {
      std::printf("%s:", ips::filter::toString(est->params().type).c_str());
      for (const auto& c : est->counters())
        std::printf(" %s %lld/%lld/%lld", c.name, static_cast<long long>(c.accepted),
                    static_cast<long long>(c.rejected), static_cast<long long>(c.too_late));
      std::printf(" (accepted/rejected/too late); imu gaps %lld; camera delay %.0f us (sigma %.0f, %s)\n",
                  static_cast<long long>(est->imuGaps()), est->cameraDelay().delay_us, est->cameraDelay().sigma_us,
                  est->cameraDelay().applied ? "applied" : "not applied");
    }
    std::printf("pairs=%lld deltas=%lld ekf_states=%lld ukf_states=%lld\n", static_cast<long long>(pairs),
                static_cast<long long>(deltas), static_cast<long long>(ekf_states), static_cast<long long>(ukf_states));
    return 0;
  });
}
