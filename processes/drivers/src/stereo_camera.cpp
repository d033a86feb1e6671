#include "ips/drivers/stereo_camera.hpp"

#include <cmath>
#include <stdexcept>

#include "ips/config.hpp"
#include "ips/log.hpp"

namespace ips::drivers {

StereoCameraSettings StereoCameraSettings::fromConfig(const Config& config) {
  StereoCameraSettings s;
  const Config c = config.section("camera");
  // Keys directly under camera/ apply to both; camera/left and camera/right override them.
  const GigeCameraSettings shared = GigeCameraSettings::fromConfig(c);
  auto side = [&](const std::string& name) {
    if (!c.has(name))
      throw ConfigError(config.path() + ": key 'camera/" + name + "' (the " + name + " camera) is missing");
    const Config sc = c.section(name);
    GigeCameraSettings g = shared;
    // Re-read with the shared values as defaults.
    g.id = sc.getString("id");
    g.pixel_format = sc.getString("pixel_format", g.pixel_format);
    g.width = sc.getInt("width", g.width);
    g.height = sc.getInt("height", g.height);
    g.offset_x = sc.getInt("offset_x", g.offset_x);
    g.offset_y = sc.getInt("offset_y", g.offset_y);
    g.exposure_us = sc.getDouble("exposure_us", g.exposure_us);
    g.gain_db = sc.getDouble("gain_db", g.gain_db);
    g.frame_rate_hz = sc.getDouble("frame_rate_hz", g.frame_rate_hz);
    g.trigger_source = sc.getString("trigger_source", g.trigger_source);
    g.packet_size = sc.getInt("packet_size", g.packet_size);
    g.packet_delay_ns = sc.getInt("packet_delay_ns", static_cast<int>(g.packet_delay_ns));
    return g;
  };
  s.left = side("left");
  s.right = side("right");
  s.pairing.tolerance_us = c.getInt("pair_tolerance_us", static_cast<int>(s.pairing.tolerance_us));
  s.pairing.max_waiting = static_cast<size_t>(c.getInt("pair_max_waiting", static_cast<int>(s.pairing.max_waiting)));
  s.clock.window = static_cast<size_t>(c.getInt("clock_window", static_cast<int>(s.clock.window)));
  s.clock.max_drift_ppm = c.getDouble("clock_max_drift_ppm", s.clock.max_drift_ppm);
  s.stamp_is_exposure_start = c.getBool("stamp_is_exposure_start", s.stamp_is_exposure_start);
  s.delay_us = c.getInt("delay_us", static_cast<int>(s.delay_us));
  if (s.pairing.tolerance_us <= 0 || s.pairing.max_waiting < 1)
    throw ConfigError(config.path() + ": camera/pair_tolerance_us must be > 0 and camera/pair_max_waiting >= 1");
  if (s.left.pixel_format != s.right.pixel_format)
    throw ConfigError(config.path() + ": left and right pixel_format must be the same");
  return s;
}

StereoCamera::StereoCamera(StereoCameraSettings settings)
    : settings_(std::move(settings)),
      mappers_{ClockMapper(settings_.clock), ClockMapper(settings_.clock)},
      pairer_(settings_.pairing) {
  cameras_[0] = std::make_unique<GigeCamera>(settings_.left);
  cameras_[1] = std::make_unique<GigeCamera>(settings_.right);
}

void StereoCamera::handle(int side, CameraFrame frame, std::vector<StereoFrame>* out) {
  GigeCamera& cam = *cameras_[side];
  if (cam.connectionCount() != seen_connection_[side]) {
    // A new connection: the camera's clock and frame ids may have restarted.
    seen_connection_[side] = cam.connectionCount();
    mappers_[side].reset();
    pairer_.clear(side);
    if (side == 0) last_left_id_ = 0;
  }
  const size_t resets_before = mappers_[side].resets();
  const int64_t mapped = mappers_[side].update(frame.device_time_ns / 1000, frame.arrival_us);
  if (mappers_[side].resets() != resets_before) {
    ++clock_resets_;
    pairer_.clear(side);
  }
  int64_t utime = mapped - settings_.delay_us;
  if (settings_.stamp_is_exposure_start) utime += static_cast<int64_t>(std::llround(frame.exposure_us / 2));
  auto pair = pairer_.push(side, utime, std::move(frame));
  if (!pair) return;
  if (pair->left.width != pair->right.width || pair->left.height != pair->right.height ||
      pair->left.bytes_per_pixel != pair->right.bytes_per_pixel) {
    // Differently configured cameras cannot form a stereo_pair_t.
    ++size_mismatches_;
    return;
  }
  // Sequence: advances by the left camera's frame id step, so frames lost on the way show up as gaps.
  const uint64_t id = pair->left.frame_id;
  int64_t step = 1;
  if (last_left_id_ != 0 && id > last_left_id_ && id - last_left_id_ < 10000)
    step = static_cast<int64_t>(id - last_left_id_);
  last_left_id_ = id;
  seq_ += step;
  StereoFrame f;
  f.left_utime = pair->left_us;
  f.right_utime = pair->right_us;
  f.utime = (pair->left_us + pair->right_us) / 2;
  f.seq = seq_;
  f.serial_left = cameras_[0]->serial();
  f.serial_right = cameras_[1]->serial();
  f.left = std::move(pair->left);
  f.right = std::move(pair->right);
  out->push_back(std::move(f));
}

std::vector<StereoFrame> StereoCamera::poll(int timeout_ms) {
  std::vector<StereoFrame> out;
  const bool up[2] = {cameras_[0]->ensureConnected(), cameras_[1]->ensureConnected()};
  if (!up[0] && !up[1]) {
    // Nothing to wait on: sleep the timeout away so the caller's loop does not spin.
    struct timespec ts {
      timeout_ms / 1000, (timeout_ms % 1000) * 1000000L
    };
    nanosleep(&ts, nullptr);
    return out;
  }
  // Each camera's stream fills its buffers in its own thread; alternate short waits so neither waits long.
  const int slice = std::max(1, timeout_ms / 4);
  for (int round = 0; round < 2; ++round) {
    for (int side = 0; side < 2; ++side) {
      if (!up[side]) continue;
      while (auto frame = cameras_[side]->grab(out.empty() ? slice : 0)) handle(side, std::move(*frame), &out);
    }
    if (!out.empty()) break;
  }
  return out;
}

std::map<std::string, int64_t> StereoCamera::counters() const {
  std::map<std::string, int64_t> all;
  const char* prefix[2] = {"left_", "right_"};
  for (int side = 0; side < 2; ++side)
    for (const auto& [name, value] : cameras_[side]->counters()) all[prefix[side] + name] = value;
  all["pairs"] = pairer_.pairs();
  all["unpaired_left"] = pairer_.unpaired(0);
  all["unpaired_right"] = pairer_.unpaired(1);
  all["out_of_order"] = pairer_.outOfOrder(0) + pairer_.outOfOrder(1);
  all["clock_resets"] = clock_resets_;
  all["size_mismatches"] = size_mismatches_;
  return all;
}

}  // namespace ips::drivers
