// camera: the stereo camera driver. Two GigE Vision cameras through Aravis, their clocks mapped onto the common
// clock, frames paired by time stamp; publishes ips::stereo_pair_t on STEREO (raw images, mid-exposure stamp).
#include <chrono>
#include <ips/stereo_pair_t.hpp>
#include <opencv2/core.hpp>

#include "ips/config.hpp"
#include "ips/drivers/stereo_camera.hpp"
#include "ips/framework/channels.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/process.hpp"
#include "ips/framework/validate.hpp"

namespace {

cv::Mat view(ips::drivers::CameraFrame& f) {
  return cv::Mat(f.height, f.width, f.bytes_per_pixel == 1 ? CV_8UC1 : CV_16UC1, f.data.data(),
                 static_cast<size_t>(f.stride));
}

}  // namespace

int main(int argc, char** argv) {
  return ips::fw::guardedMain("camera", [&] {
    ips::Args args(argc, argv, "Stereo GigE camera driver (Aravis): two cameras -> ips::stereo_pair_t on STEREO");
    args.option("--left", "ID", "left camera serial number or address (overrides camera/left/id)")
        .option("--right", "ID", "right camera serial number or address (overrides camera/right/id)")
        .option("--count", "N", "stop after N published pairs (0: run until stopped)", "0");
    ips::fw::addCommonOptions(args, "config/camera.yaml");
    if (!args.parse()) return 0;
    ips::fw::applyCommonOptions(args);

    const ips::Config cfg(args.get("--config"));
    auto settings = ips::drivers::StereoCameraSettings::fromConfig(cfg);
    if (ips::fw::configChecked(args, cfg)) return 0;
    if (args.has("--left")) settings.left.id = args.get("--left");
    if (args.has("--right")) settings.right.id = args.get("--right");
    const long long max_count = args.getInt("--count");

    ips::drivers::StereoCamera stereo(settings);
    ips::fw::Node node("camera", args.get("--lcm-url"));
    long long published = 0;
    int64_t reported_unpaired = 0;
    auto last_health = std::chrono::steady_clock::now();
    while (!ips::fw::stopRequested() && (max_count == 0 || published < max_count)) {
      for (auto& pair : stereo.poll(50)) {
        const auto started = std::chrono::steady_clock::now();
        node.health().received(pair.utime);
        ips::stereo_pair_t msg = ips::fw::makeStereoPair(pair.utime, pair.seq, view(pair.left), view(pair.right),
                                                         pair.serial_left, pair.serial_right);
        msg.exposure_us[0] = pair.left.exposure_us;
        msg.exposure_us[1] = pair.right.exposure_us;
        msg.gain_db[0] = pair.left.gain_db;
        msg.gain_db[1] = pair.right.gain_db;
        const auto verdict = ips::fw::validate(msg);
        if (!verdict.ok()) {
          node.health().bad(verdict.reason, verdict.detail);
          continue;
        }
        node.health().accepted();
        node.publish(ips::channels::kStereoTime, ips::fw::stereoTimeOf(msg));
        if (node.publish(ips::channels::kStereo, msg)) ++published;
        node.health().latency(
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count());
      }
      const auto now = std::chrono::steady_clock::now();
      const double since = std::chrono::duration<double>(now - last_health).count();
      if (since >= 1.0) {
        const auto counters = stereo.counters();
        for (const auto& [name, value] : counters) node.health().set(name, value);
        const int64_t unpaired = counters.at("unpaired_left") + counters.at("unpaired_right");
        if (unpaired > reported_unpaired) node.health().dropped("unpaired", unpaired - reported_unpaired);
        reported_unpaired = unpaired;
        node.health().set("connected", stereo.connected() ? 1 : 0);
        node.publishHealth(since);
        last_health = now;
      }
    }
    for (const auto& [name, value] : stereo.counters()) node.health().set(name, value);
    node.publishHealth(1.0);
    return 0;
  });
}
