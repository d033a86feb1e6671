#include "sim_process.hpp"

#include <chrono>
#include <condition_variable>
#include <deque>
#include <future>
#include <ips/disparity_map_t.hpp>
#include <ips/ground_truth_t.hpp>
#include <ips/imu_sample_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <ips/stereo_time_t.hpp>
#include <ips/tilt_sample_t.hpp>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <thread>

#include "ips/framework/channels.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/log_writer.hpp"
#include "ips/framework/message_arrays.hpp"
#include "ips/framework/message_poses.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/process.hpp"
#include "ips/log.hpp"
#include "ips/sim/output.hpp"

namespace ips::sim_app {

namespace {

using ips::sim::SimEvent;

using ips::fw::encodeMessage;

// One event as (channel, encoded message).
struct Encoded {
  int64_t log_utime;
  std::string channel;
  std::vector<uint8_t> data;
};

Encoded encodeEvent(const SimEvent& e, const ips::sim::Simulation& sim) {
  namespace ch = ips::channels;
  switch (e.kind) {
    case SimEvent::kStereo: {
      const ips::sim::StereoFrame& f = *e.frame;
      ips::stereo_pair_t m =
          ips::fw::makeStereoPair(f.utime_stamp, f.seq, f.left, f.right, sim.head().calibration.cam0.serial,
                                  sim.head().calibration.cam1.serial);
      for (int c = 0; c < 2; ++c) {
        m.exposure_us[c] = static_cast<float>(f.exposure_us[c]);
        m.gain_db[c] = static_cast<float>(f.gain_db[c]);
      }
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
      m.subpixel_scale = ips::sim::FixedPointDisparity::kSubpixelScale;
      m.invalid_value = ips::sim::FixedPointDisparity::kInvalid;
      m.focal_px = r.f;
      m.cx = r.cx;
      m.cy = r.cy;
      m.baseline_m = r.baseline;
      const ips::sim::FixedPointDisparity fixed = ips::sim::toFixedPoint(f.gt_disparity);
      m.min_disparity = 0;
      m.num_disparities = fixed.num_disparities;
      m.data.resize(m.height);
      for (int y = 0; y < m.height; ++y) {
        const int16_t* row = fixed.data.ptr<int16_t>(y);
        m.data[y].assign(row, row + m.width);
      }
      m.confidence_size = 0;
      return {e.log_utime, ch::kGtDisparity, encodeMessage(m)};
    }
    case SimEvent::kImu: {
      ips::imu_sample_t m;
      m.utime = e.imu.utime_stamp;
      m.seq = e.imu.seq;
      ips::fw::vectorToArray(e.imu.angular_rate, m.angular_rate);
      ips::fw::vectorToArray(e.imu.specific_force, m.specific_force);
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
      const ips::ground_truth_t m = ips::fw::groundTruthMessage(e.truth);
      return {e.log_utime, ch::kGtPose, encodeMessage(m)};
    }
  }
}

}  // namespace

// An event's messages: a pair's stamp on the control bus (STEREO_TIME) goes before the pair itself.
std::vector<Encoded> encodeEvents(const SimEvent& e, const ips::sim::Simulation& sim) {
  std::vector<Encoded> out;
  if (e.kind == SimEvent::kStereo)
    out.push_back({e.log_utime, ips::channels::kStereoTime,
                   encodeMessage(ips::stereo_time_t{e.frame->utime_stamp, e.frame->seq})});
  out.push_back(encodeEvent(e, sim));
  return out;
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
      for (const Encoded& enc : encodeEvents(e, sim)) log.write(enc.channel, enc.log_utime, enc.data);
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
    ips::sim::LiveClock clock(sim.scenario().start_utime, rate);
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
      const auto due = clock.due(enc.log_utime, std::chrono::steady_clock::now());
      const auto now = std::chrono::steady_clock::now();
      if (due > now)
        std::this_thread::sleep_until(due);
      else if (ips::sim::LiveClock::late(due, now))
        ++late;
      node.publishRaw(enc.channel, enc.data.data(), static_cast<unsigned>(enc.data.size()));
      node.health().received(enc.log_utime);
      node.health().accepted();
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
        for (Encoded& enc : encodeEvents(e, sim)) {
          std::unique_lock<std::mutex> lock(mutex);
          cv.wait(lock, [&] { return queue.size() < kMaxQueued || ips::fw::stopRequested(); });
          queue.push_back(std::move(enc));
          cv.notify_all();
        }
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

}  // namespace ips::sim_app
