// sim: the simulated sensor head. Batch mode writes an LCM log as fast as it can; live mode publishes in real
// time (or scaled by --rate). Channels: STEREO, IMU, TILT (as the real drivers), GT_POSE, GT_DISPARITY.
// The head's calibration goes to FILE.calib.yaml beside the log (batch) or to --calib-out (live): the truth, or
// with the scenario's calibration_errors a perturbed one (the truth then beside it as FILE.true.calib.yaml).
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <future>
#include <iostream>
#include <ips/disparity_map_t.hpp>
#include <ips/ground_truth_t.hpp>
#include <ips/imu_sample_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <ips/tilt_sample_t.hpp>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <thread>

#include "ips/args.hpp"
#include "ips/framework/channels.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/log_writer.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/process.hpp"
#include "ips/log.hpp"
#include "ips/sim/simulation.hpp"

namespace {

using ips::sim::SimEvent;

using ips::fw::encodeMessage;

void copy3(const Eigen::Vector3d& v, double* out) {
  for (int i = 0; i < 3; ++i) out[i] = v[i];
}

// One event as (channel, encoded message).
struct Encoded {
  int64_t log_utime;
  std::string channel;
  std::vector<uint8_t> data;
};

Encoded encodeEvent(const SimEvent& e, const ips::sim::Simulation& sim) {
  namespace ch = ips::channels;
  const ips::sim::Scenario& sc = sim.scenario();
  switch (e.kind) {
    case SimEvent::kStereo: {
      const ips::sim::StereoFrame& f = *e.frame;
      ips::stereo_pair_t m =
          ips::fw::makeStereoPair(f.utime_stamp, f.seq, f.left, f.right, sim.head().calibration.cam0.serial,
                                  sim.head().calibration.cam1.serial);
      m.exposure_us[0] = m.exposure_us[1] = static_cast<float>(sc.camera.exposure_us);
      m.gain_db[0] = static_cast<float>(sc.camera.gain_left_db);
      m.gain_db[1] = static_cast<float>(sc.camera.gain_right_db);
      return {e.log_utime, ch::kStereo, encodeMessage(m)};
    }
    case SimEvent::kGtDisparity: {
      const ips::sim::StereoFrame& f = *e.frame;
      const ips::StereoRectification& r = sim.renderer().rectification();
      ips::disparity_map_t m;
      m.utime = f.utime_stamp;
      m.seq = f.seq;
      m.width = f.gt_disparity.cols;
      m.height = f.gt_disparity.rows;
      m.subpixel_scale = 16;
      m.invalid_value = -1;
      m.focal_px = r.f;
      m.cx = r.cx;
      m.cy = r.cy;
      m.baseline_m = r.baseline;
      double max_d = 0;
      cv::minMaxLoc(f.gt_disparity, nullptr, &max_d);
      m.min_disparity = 0;
      m.num_disparities = static_cast<int16_t>(std::min(2047.0, std::ceil(max_d) + 1));
      m.data.assign(m.height, std::vector<int16_t>(m.width));
      for (int y = 0; y < m.height; ++y)
        for (int x = 0; x < m.width; ++x) {
          const float d = f.gt_disparity.at<float>(y, x);
          m.data[y][x] = d > 0 && d * 16 < 32767 ? static_cast<int16_t>(std::lround(d * 16)) : m.invalid_value;
        }
      m.confidence_size = 0;
      return {e.log_utime, ch::kGtDisparity, encodeMessage(m)};
    }
    case SimEvent::kImu: {
      ips::imu_sample_t m;
      m.utime = e.imu.utime_stamp;
      m.seq = e.imu.seq;
      copy3(e.imu.angular_rate, m.angular_rate);
      copy3(e.imu.specific_force, m.specific_force);
      return {e.log_utime, ch::kImu, encodeMessage(m)};
    }
    case SimEvent::kTilt: {
      ips::tilt_sample_t m;
      m.utime = e.tilt.utime_stamp;
      m.seq = e.tilt.seq;
      m.angle_x = e.tilt.angle_x;
      m.angle_y = e.tilt.angle_y;
      return {e.log_utime, ch::kTilt, encodeMessage(m)};
    }
    case SimEvent::kGtPose:
    default: {
      const ips::sim::GroundTruth& g = e.truth;
      ips::ground_truth_t m;
      m.utime = g.utime;
      copy3(g.position, m.position);
      m.orientation[0] = g.orientation.w();
      m.orientation[1] = g.orientation.x();
      m.orientation[2] = g.orientation.y();
      m.orientation[3] = g.orientation.z();
      copy3(g.velocity, m.velocity);
      copy3(g.acceleration, m.acceleration);
      copy3(g.angular_rate, m.angular_rate);
      copy3(g.gyro_bias, m.gyro_bias);
      copy3(g.accel_bias, m.accel_bias);
      return {e.log_utime, ch::kGtPose, encodeMessage(m)};
    }
  }
}

int runBatch(ips::sim::Simulation& sim, const std::string& out) {
  ips::fw::LogWriter log(out);
  const auto t0 = std::chrono::steady_clock::now();
  int64_t pairs = 0;
  ips::LogThrottle progress(10'000'000);
  // This thread renders (OpenCV's parallel_for_ on both cores works from the main thread); a writer thread
  // encodes and writes the previous batch of events meanwhile.
  std::vector<SimEvent> events;
  std::future<void> writing;
  auto write = [&](std::vector<SimEvent> batch) {
    for (const SimEvent& e : batch) {
      const Encoded enc = encodeEvent(e, sim);
      log.write(enc.channel, enc.log_utime, enc.data);
      if (e.kind == SimEvent::kStereo) {
        ++pairs;
        if (progress.allow(e.log_utime))
          IPS_INFO("pair " << pairs << "/" << sim.frameCount()
                           << " (t = " << (e.frame->utime_true - sim.scenario().start_utime) * 1e-6 << " s)");
      }
    }
  };
  while (sim.next(events)) {
    if (writing.valid()) writing.get();  // rethrows a write error
    writing = std::async(std::launch::async, write, std::move(events));
    events = std::vector<SimEvent>();
  }
  if (writing.valid()) writing.get();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  IPS_INFO("wrote " << log.events() << " events (" << pairs << " stereo pairs) to " << out << " in " << wall << " s");
  return 0;
}

int runLive(ips::sim::Simulation& sim, const std::string& url, double rate) {
  ips::fw::installSignalHandlers();
  ips::fw::Node node("sim", ips::fw::resolveLcmUrl(url));
  // This thread renders ahead into a short queue (OpenCV's parallel_for_ uses both cores from the main thread);
  // a publisher thread sends each event at its arrival time, the clock starting 0.5 s after the first event.
  std::mutex mutex;
  std::condition_variable cv;
  std::deque<Encoded> queue;
  bool done = false;
  int64_t late = 0;
  constexpr size_t kMaxQueued = 2000;  // several frames of events
  std::thread publisher([&] {
    const int64_t sim0 = sim.scenario().start_utime;
    std::chrono::steady_clock::time_point wall0;
    bool started = false;
    auto last_health = std::chrono::steady_clock::now();
    while (!ips::fw::stopRequested()) {
      Encoded enc;
      {
        std::unique_lock<std::mutex> lock(mutex);
        cv.wait_for(lock, std::chrono::milliseconds(100), [&] { return !queue.empty() || done; });
        if (queue.empty()) {
          if (done) break;
          continue;
        }
        enc = std::move(queue.front());
        queue.pop_front();
        cv.notify_all();
      }
      if (!started) {
        // Half a second of buffer: the samples between two frames are generated with the later frame.
        wall0 = std::chrono::steady_clock::now() + std::chrono::milliseconds(500) -
                std::chrono::microseconds(static_cast<int64_t>((enc.log_utime - sim0) / rate));
        started = true;
      }
      const auto due = wall0 + std::chrono::microseconds(static_cast<int64_t>((enc.log_utime - sim0) / rate));
      const auto now = std::chrono::steady_clock::now();
      if (due > now)
        std::this_thread::sleep_until(due);
      else if (now - due > std::chrono::milliseconds(50))
        ++late;
      node.lcm().publish(enc.channel, enc.data.data(), static_cast<unsigned>(enc.data.size()));
      node.health().published();
      node.health().received(enc.log_utime);
      if (std::chrono::steady_clock::now() - last_health > std::chrono::seconds(1)) {
        node.health().set("late_events", late);
        node.publishHealth(std::chrono::duration<double>(std::chrono::steady_clock::now() - last_health).count());
        last_health = std::chrono::steady_clock::now();
      }
    }
  });
  std::vector<SimEvent> events;
  try {
    while (!ips::fw::stopRequested() && sim.next(events)) {
      for (const SimEvent& e : events) {
        Encoded enc = encodeEvent(e, sim);
        std::unique_lock<std::mutex> lock(mutex);
        cv.wait(lock, [&] { return queue.size() < kMaxQueued || ips::fw::stopRequested(); });
        queue.push_back(std::move(enc));
        cv.notify_all();
      }
      events.clear();
    }
  } catch (...) {
    ips::fw::requestStop();
    publisher.join();
    throw;
  }
  {
    std::lock_guard<std::mutex> lock(mutex);
    done = true;
    cv.notify_all();
  }
  publisher.join();
  if (late > 0) IPS_WARN(late << " events were published more than 50 ms late (rendering slower than --rate)");
  return 0;
}

// FILE.calib.yaml is what the processes are given. When it is perturbed, the truth goes beside it as
// FILE.true.calib.yaml, for evaluation only.
void writeCalibrations(const ips::sim::Scenario& scenario, const ips::sim::SensorHead& head,
                       const std::string& calib_path) {
  const ips::StereoCalibration told = head.calibrationForProcesses(scenario);
  ips::saveCalibration(calib_path, told);
  if (told.source != "perturbed") return;
  ips::StereoCalibration truth = head.calibration;
  truth.source = "true";
  const std::string suffix = ".calib.yaml";
  const bool has_suffix = calib_path.size() > suffix.size() &&
                          calib_path.compare(calib_path.size() - suffix.size(), suffix.size(), suffix) == 0;
  const std::string truth_path =
      (has_suffix ? calib_path.substr(0, calib_path.size() - suffix.size()) : calib_path) + ".true.calib.yaml";
  ips::saveCalibration(truth_path, truth);
  IPS_INFO("the processes get a perturbed calibration (" << calib_path << "); the truth is in " << truth_path);
}

}  // namespace

int main(int argc, char** argv) {
  return ips::fw::guardedMain("sim", [&]() -> int {
    ips::Args args(argc, argv,
                   "The simulated sensor head (stereo camera, IMU, tilt sensor) with ground truth.\n"
                   "Batch: sim --duration S --out FILE.lcmlog (writes FILE.calib.yaml beside it). "
                   "Live: sim [--rate F] [--lcm-url URL] [--calib-out FILE].");
    args.option("--duration", "SECONDS",
                "simulated time; default: until the trajectory ends; 0: only write the calibration")
        .option("--out", "FILE.lcmlog", "batch mode: write an LCM log as fast as possible")
        .option("--scenario", "FILE.yaml", "scenario (config/sim_*.yaml); default: the built-in walk")
        .option("--seed", "N", "random seed (overrides the scenario's)")
        .option("--gt-disparity-every", "N", "ground-truth disparity (GT_DISPARITY) for every N-th pair", "0")
        .option("--rate", "FACTOR", "live mode: speed relative to real time", "1")
        .option("--lcm-url", "URL", "live mode: LCM URL (default $LCM_DEFAULT_URL)")
        .option("--calib-out", "FILE", "live mode: where to write the calibration", "sim.calib.yaml")
        .option("--log-level", "LEVEL", "debug, info, warn, error", "info");
    if (!args.parse()) return 0;
    ips::setLogName("sim");
    ips::setLogLevel(ips::parseLogLevel(args.get("--log-level")));
    ips::sim::Scenario scenario =
        args.has("--scenario") ? ips::sim::Scenario::load(args.get("--scenario")) : ips::sim::Scenario::defaults();
    if (args.has("--seed")) {
      const long long seed = args.getInt("--seed");
      if (seed < 0) throw ips::ArgError("--seed must not be negative");
      scenario.seed = static_cast<uint64_t>(seed);
    }
    ips::sim::SimulationOptions options;
    options.gt_disparity_every = static_cast<int>(args.getInt("--gt-disparity-every"));
    if (options.gt_disparity_every < 0) throw ips::ArgError("--gt-disparity-every must not be negative");
    const ips::sim::Trajectory probe(scenario.trajectory, scenario.gravity);
    options.duration_s = args.has("--duration") ? args.getDouble("--duration") : probe.duration();
    if (!(options.duration_s >= 0)) throw ips::ArgError("--duration must not be negative");
    const double rate = args.getDouble("--rate");
    if (!(rate > 0)) throw ips::ArgError("--rate must be positive");

    const std::string calib_path = args.has("--out") ? args.get("--out") + ".calib.yaml" : args.get("--calib-out");
    if (options.duration_s == 0) {  // only the calibration (for processes started before the head)
      writeCalibrations(scenario, ips::sim::SensorHead::make(scenario), calib_path);
      IPS_INFO("--duration 0: wrote the calibration " << calib_path << " and nothing else");
      return 0;
    }
    ips::sim::Simulation sim(scenario, options);
    writeCalibrations(scenario, sim.head(), calib_path);
    IPS_INFO("scenario '" << scenario.name << "' (" << scenario.source << "), seed " << scenario.seed << ", "
                          << options.duration_s << " s of a " << sim.trajectory().duration() << " s, "
                          << sim.trajectory().pathLength() << " m trajectory; " << sim.world().quads.size()
                          << " quads, " << sim.world().photo_count << " photographs; calibration: " << calib_path);
    if (args.has("--out")) return runBatch(sim, args.get("--out"));
    return runLive(sim, args.get("--lcm-url"), rate);
  });
}
