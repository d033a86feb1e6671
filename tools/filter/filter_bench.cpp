// filter_bench: speed of both filters, in IMU samples per second on one core, with the real message mix of
// the sensor head (IMU 200 Hz, tilt 14 Hz, images 8 Hz with a tracker delta each, pose clones in the state).
// All sensor data are generated first; only the estimator is timed (the wall clock is read here only).
//
//   filter_bench [--seconds 60] [--config filter.yaml] [--repeat 3]
// Last line: ekf_imu_per_s=<n> ukf_imu_per_s=<n>   (target >= 20000 each)
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "ips/args.hpp"
#include "ips/config.hpp"
#include "ips/eval/filter_testbed.hpp"
#include "ips/log.hpp"

using namespace ips::filter;
using namespace ips::eval;

namespace {

struct Message {
  int kind;  // 0 imu, 1 tilt, 2 image + delta
  ImuSample imu;
  TiltSample tilt;
  int64_t image_time;
  TrackerDelta delta;
  bool has_delta;
};

std::vector<Message> generate(double seconds, const ips::StereoCalibration& calib, const AnalyticWalk& walk) {
  SensorSimParams sp;
  SensorSim sim(walk, sp, calib, 7);
  std::vector<Message> msgs;
  const int64_t imu_dt = 5000, tilt_dt = 71429, img_dt = 125000;
  int64_t ti = imu_dt, tt = tilt_dt / 2, tc = img_dt / 3, last = -1;
  const int64_t end = static_cast<int64_t>(seconds * 1e6);
  while (true) {
    const int64_t t = std::min({ti, tt, tc});
    if (t > end) break;
    Message m{};
    if (t == ti) {
      m.kind = 0, m.imu = sim.imu(t), ti += imu_dt;
    } else if (t == tt) {
      m.kind = 1, m.tilt = sim.tilt(t), tt += tilt_dt;
    } else {
      m.kind = 2, m.image_time = t, m.has_delta = last >= 0;
      if (m.has_delta) m.delta = sim.delta(last, t);
      last = t, tc += img_dt;
    }
    msgs.push_back(m);
  }
  return msgs;
}

}  // namespace

int main(int argc, char** argv) {
  ips::setLogLevel(ips::LogLevel::Warn);
  try {
    ips::Args args(argc, argv,
                   "speed of both filters in IMU samples per second on one core, with the real message mix");
    args.option("--seconds", "S", "generated sensor data", "60")
        .option("--repeat", "N", "runs per filter; the best counts", "3")
        .option("--config", "FILE", "filter configuration (section filter; default: built-in)");
    if (!args.parse()) return 0;
    const double seconds = args.getDouble("--seconds");
    const int repeat = static_cast<int>(args.getInt("--repeat"));
    const std::string config = args.get("--config");
    FilterParams base;
    if (!config.empty()) {
      const ips::Config cfg(config);
      base = loadFilterParams(cfg.section("filter"));
      cfg.refuseUnreadKeys();
    }
    const ips::StereoCalibration calib = testbedCalibration();
    const AnalyticWalk walk;
    const std::vector<Message> msgs = generate(seconds, calib, walk);
    const size_t n_imu = std::count_if(msgs.begin(), msgs.end(), [](const Message& m) { return m.kind == 0; });
    double rate[2] = {0, 0};
    for (FilterType type : {FilterType::Ekf, FilterType::Ukf}) {
      FilterParams p = base;
      p.type = type;
      double best = 1e300;
      size_t outputs = 0;
      int clones = 0;
      for (int r = 0; r < repeat; ++r) {
        SensorSim sim(walk, SensorSimParams{}, calib, 1);
        Estimator est(p, calib);
        est.initialize(sim.truth(0), initialCovariance(p.init));
        const auto t0 = std::chrono::steady_clock::now();
        for (const Message& m : msgs) {
          if (m.kind == 0) {
            est.addImu(m.imu);
          } else if (m.kind == 1) {
            est.addTilt(m.tilt);
          } else {
            est.addImageTime(m.image_time);
            if (m.has_delta) est.addTrackerDelta(m.delta);
            outputs += est.takeOutputs().size();  // the process drains its queue per image, as the main would
          }
        }
        est.flush();
        outputs += est.takeOutputs().size();
        const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        best = std::min(best, s);
        clones = static_cast<int>(est.filter().state().clones.size());
      }
      const int idx = type == FilterType::Ekf ? 0 : 1;
      rate[idx] = n_imu / best;
      std::printf(
          "%s: %zu IMU samples (+ tilt, images, deltas) in %.3f s (best of %d): %.0f IMU/s, %.2f us each; "
          "clones in state %d (error dim %d), outputs %zu\n",
          toString(type).c_str(), n_imu, best, repeat, rate[idx], 1e6 * best / n_imu, clones,
          kCoreErrorDim + kCloneErrorDim * clones, outputs / repeat);
    }
    std::printf("ekf_imu_per_s=%.0f ukf_imu_per_s=%.0f\n", rate[0], rate[1]);
  } catch (const ips::ArgError& e) {
    std::fprintf(stderr, "%s\n", e.what());  // names the program and the option
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "filter_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
