#pragma once
// The stereo head: two GigE cameras, each camera's clock mapped onto the common clock, frames paired by time.
// Output pairs map one to one onto ips::stereo_pair_t.
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "ips/drivers/clock_mapper.hpp"
#include "ips/drivers/frame_pairer.hpp"
#include "ips/drivers/gige_camera.hpp"

namespace ips {
class Config;
}

namespace ips::drivers {

struct StereoCameraSettings {
  GigeCameraSettings left, right;  // shared keys under camera/, per-camera keys under camera/left, camera/right
  FramePairerConfig pairing;       // tolerance: camera/pair_tolerance_us
  ClockMapperConfig clock;
  // The camera stamps the start of exposure (GenICam convention for the frame-start time stamp); the message
  // carries the mid-exposure time, so half the exposure is added.
  bool stamp_is_exposure_start = true;
  // Calibrated constant delay [us] between the mapped stamp and the true exposure instant (transport latency
  // floor of the clock mapping, trigger latency): subtracted.
  int64_t delay_us = 0;
  static StereoCameraSettings fromConfig(const Config& config);  // reads section camera/
};

struct StereoFrame {
  int64_t utime = 0;  // mid-exposure, common clock
  int64_t seq = 0;
  CameraFrame left, right;
  std::string serial_left, serial_right;
  int64_t left_utime = 0, right_utime = 0;  // each camera's own mapped stamp (their difference shows sync)
};

class StereoCamera {
 public:
  explicit StereoCamera(StereoCameraSettings settings);
  // Connects what is missing, waits up to timeout_ms for frames of both cameras, returns completed pairs.
  std::vector<StereoFrame> poll(int timeout_ms);
  // Camera counters (prefixed left_/right_) and pairing counters (unpaired_left, unpaired_right, pairs).
  std::map<std::string, int64_t> counters() const;
  bool connected() const { return cameras_[0]->connected() && cameras_[1]->connected(); }
  GigeCamera& camera(int side) { return *cameras_[side]; }

 private:
  void handle(int side, CameraFrame frame, std::vector<StereoFrame>* out);
  StereoCameraSettings settings_;
  std::unique_ptr<GigeCamera> cameras_[2];
  ClockMapper mappers_[2];
  FramePairer<CameraFrame> pairer_;
  int64_t seen_connection_[2] = {0, 0};
  int64_t seq_ = -1;
  uint64_t last_left_id_ = 0;
  int64_t clock_resets_ = 0;
  int64_t size_mismatches_ = 0;
};

}  // namespace ips::drivers
