#pragma once
// Parser of the PEI-Z260 (Measurement Specialties) inclinometer's RS-232 ASCII output, separate from any I/O.
//
// The sensor sends its two axis angles as text lines. The exact line layout is not in the documents available
// to this project, so it is configurable (config/tilt.yaml, keys under tilt/format): a prefix before each
// axis value (default "X=" and "Y="), the unit (degrees), the line terminator, and an optional NMEA-style
// "*HH" XOR checksum. Both axes on one line ("X=+01.234 Y=-00.456") and one axis per line ("X=+01.234\r\n"
// then "Y=-00.456\r\n") are accepted: a sample is complete when Y follows X.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "ips/drivers/mmq50.hpp"  // StreamCounters

namespace ips {
class Config;
}

namespace ips::drivers {

struct Z260Format {
  std::string x_prefix = "X=";
  std::string y_prefix = "Y=";
  bool degrees = true;            // values in degrees (else radians)
  bool xor_checksum = false;      // line ends with "*HH" (XOR of the characters before '*')
  size_t max_line = 64;           // longer lines are garbage
  double max_abs_angle_deg = 65;  // larger values are corrupt (the Z260 measures +-60 deg)
  int x_sign = 1, y_sign = 1;     // to align the sensor axes with the tilt frame of the calibration
  double rate_hz = 14.0;          // nominal output rate (silence detection)
  static Z260Format fromConfig(const Config& section);
};

struct TiltSample {
  int64_t utime = 0;
  int64_t seq = 0;
  double angle_x = 0;  // [rad]
  double angle_y = 0;  // [rad]
};

class Z260Parser {
 public:
  explicit Z260Parser(Z260Format format);
  // As Mmq50Parser::feed: each sample is dated by the arrival of the end of its Y line.
  std::vector<TiltSample> feed(const uint8_t* data, size_t size, int64_t arrival_us, double byte_time_us);
  size_t pending() const { return line_.size(); }
  void dropPartial();
  int64_t partialFrames() const { return partial_frames_; }
  const StreamCounters& counters() const { return counters_; }

  // A line as the sensor writes it (for emulators and tests), both axes on one line, angles in radians.
  static std::string format(const Z260Format& f, double angle_x_rad, double angle_y_rad);

 private:
  void handleLine(int64_t utime, std::vector<TiltSample>* out);
  bool parseValue(const std::string& text, size_t* pos, const std::string& prefix, double* value_rad);
  Z260Format format_;
  std::string line_;
  bool have_x_ = false;
  bool discarding_ = false;  // skipping the rest of a line spoilt by noise
  double pending_x_ = 0;
  int64_t seq_ = 0;
  StreamCounters counters_;
  int64_t partial_frames_ = 0;
};

}  // namespace ips::drivers
