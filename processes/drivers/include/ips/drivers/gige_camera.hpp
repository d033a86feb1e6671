#pragma once
// One GigE Vision camera through Aravis 0.8: chosen by serial number, device id or IP address; GenICam settings
// from the config; a fixed pool of buffers that are always given back to the stream (it never runs dry); the
// buffer status checked before the image is touched; and reconnection when the camera disappears (control
// lost, or no frame for a while), without restarting the process. No LCM here: frames are plain structs.
#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace ips {
class Config;
}

namespace ips::drivers {

struct GigeCameraSettings {
  std::string id;                      // serial number, Aravis device id, or IP address
  std::string pixel_format = "Mono8";  // Mono8, Mono10, Mono12, Mono16 (wider than 8 bits: sent as mono16)
  int width = 0, height = 0;           // region of interest from (offset_x, offset_y); 0 keeps the camera's
  int offset_x = 0, offset_y = 0;
  double exposure_us = 0;          // 0 keeps the camera's
  double gain_db = -1;             // < 0 keeps the camera's
  double frame_rate_hz = 0;        // free-running rate; 0 keeps the camera's
  std::string trigger_source;      // "" free running; "Line1" (hardware, both cameras on one line), "Software"
  int packet_size = 0;             // GigE packet size [bytes]; 0 negotiates the largest that passes
  int64_t packet_delay_ns = 0;     // inter-packet delay (GevSCPD) to share a link between two cameras
  bool packet_resend = true;       // ask the camera to resend lost packets
  int packet_timeout_ms = 20;      // wait before asking for a resend
  int frame_retention_ms = 200;    // give up on an incomplete frame after this
  int buffers = 8;                 // buffer pool size
  bool packet_socket = false;      // Aravis packet sockets: faster, but as root they miss loopback traffic
  double reconnect_after_s = 2.0;  // no complete frame for this long while acquiring: reconnect
  double retry_interval_s = 1.0;   // between connection attempts
  static GigeCameraSettings fromConfig(const Config& section);
};

struct CameraFrame {
  int64_t device_time_ns = 0;  // the camera's time stamp (its own clock)
  int64_t arrival_us = 0;      // host arrival on the common clock
  uint64_t frame_id = 0;       // the camera's frame (block) id
  int width = 0, height = 0, stride = 0;
  int bytes_per_pixel = 1;
  float exposure_us = 0, gain_db = 0;
  std::vector<uint8_t> data;
};

class GigeCamera {
 public:
  explicit GigeCamera(GigeCameraSettings settings);
  ~GigeCamera();
  GigeCamera(const GigeCamera&) = delete;
  GigeCamera& operator=(const GigeCamera&) = delete;

  // Starts connecting (discovery, configuration, start of acquisition) in a background thread if not connected
  // and the retry interval has passed, so that a missing camera never blocks the other one. Returns whether
  // the camera is acquiring. Never throws: failures (missing camera, settings it rejects) are logged, counted
  // and retried.
  bool ensureConnected();
  // Waits up to timeout_ms for one buffer. Returns a frame only for a complete image buffer; every other
  // status is counted. Detects a lost camera and disconnects (ensureConnected() then reconnects).
  std::optional<CameraFrame> grab(int timeout_ms);
  void disconnect();

  bool connected() const;
  const std::string& serial() const { return serial_; }
  const GigeCameraSettings& settings() const { return settings_; }
  // Counters since start: frames, incomplete_<status> (buffer status, e.g. missing_packets, timeout), lost, reconnects,
  // connect_failures, resent_packets, missing_packets, underruns.
  std::map<std::string, int64_t> counters() const;
  // Increments at each successful (re)connection: frames and time stamps restart.
  int64_t connectionCount() const { return connections_; }

 private:
  struct Impl;
  void connect();
  void closeCamera();
  void count(const std::string& name, int64_t n = 1) { counters_[name] += n; }
  void harvestStatistics();
  GigeCameraSettings settings_;
  std::unique_ptr<Impl> impl_;
  std::string serial_;
  std::map<std::string, int64_t> counters_;
  int64_t connections_ = 0;
  int64_t last_attempt_us_ = INT64_MIN / 2;
  int64_t last_frame_us_ = 0;
  int64_t last_grab_us_ = 0;
  bool configured_once_ = false;
  bool connected_ = false;      // read and written by the caller's thread only
  bool pending_close_ = false;  // a lost camera still to be closed
  std::thread connector_;
  std::atomic<bool> connect_done_{false};
  std::string connect_error_;  // written by the connector before connect_done_, read after the join
  std::string last_error_;
};

}  // namespace ips::drivers
