#pragma once
// Parser of the Systron Donner MMQ-50 binary data packets, separate from any I/O.
//
// The layout below is configurable because the MMQ-50 interface control document is not public: sync bytes,
// a sample counter, three angular rates, three accelerations, a status word and a checksum over the bytes
// between sync and checksum. Word sizes, byte order, scale factors and checksum type are config options
// (config/imu.yaml, keys under imu/packet); the defaults are an assumption to be checked against the ICD of
// the unit at hand (processes/drivers/README.md). Axes are mapped to the IMU frame by `axis_map`/`axis_sign`.
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace ips {
class Config;
}

namespace ips::drivers {

enum class Checksum { None, Sum8, Xor8, Sum16, Crc16Ccitt };
Checksum parseChecksum(const std::string& name);  // "none", "sum8", "xor8", "sum16", "crc16_ccitt"
// The checksum of `data` as the packet stores it (1 or 2 bytes).
uint32_t computeChecksum(Checksum type, const uint8_t* data, size_t size);
size_t checksumBytes(Checksum type);

struct Mmq50Format {
  static constexpr uint8_t kDefaultSync[2] = {0x55, 0xAA};
  std::vector<uint8_t> sync = std::vector<uint8_t>(kDefaultSync, kDefaultSync + 2);
  int counter_bytes = 2;  // 1 or 2 (unsigned, wraps)
  int rate_bytes = 4;     // 2 or 4 (signed two's complement)
  int accel_bytes = 4;    // 2 or 4
  int status_bytes = 2;   // 0, 1 or 2
  bool big_endian = true;
  double rate_lsb = 1.0e-6;   // [rad/s] per count
  double accel_lsb = 1.0e-5;  // [m/s^2] per count
  Checksum checksum = Checksum::Sum16;
  uint32_t status_ok_mask = 0;              // status bits that must be clear (0: status not checked)
  std::array<int, 3> axis_map = {0, 1, 2};  // IMU frame axis i = packet axis axis_map[i]
  std::array<int, 3> axis_sign = {1, 1, 1};
  double rate_hz = 200.0;  // nominal output rate (for counter time stamps and silence detection)

  size_t packetSize() const;
  void validate() const;  // throws std::invalid_argument naming the bad field
  // Reads keys of a config section (all optional; defaults above).
  static Mmq50Format fromConfig(const Config& section);
};

struct ImuSample {
  int64_t utime = 0;                     // common clock [us]; set by the caller from the arrival time
  int64_t counter = 0;                   // unwrapped sample counter
  double angular_rate[3] = {0, 0, 0};    // [rad/s], IMU frame
  double specific_force[3] = {0, 0, 0};  // [m/s^2], IMU frame
  uint32_t status = 0;
};

// Counts of what the byte stream held besides good packets.
struct StreamCounters {
  int64_t frames = 0;           // good frames
  int64_t checksum_errors = 0;  // frames whose checksum did not match (resynchronised after them)
  int64_t garbage_bytes = 0;    // bytes skipped while searching for a frame start
  int64_t bad_frames = 0;       // frames with a valid checksum but unusable content (status, format)
  int64_t counter_gaps = 0;     // samples missing according to the counter
};

class Mmq50Parser {
 public:
  explicit Mmq50Parser(Mmq50Format format);

  // Feeds bytes read at `arrival_us`; each completed frame gets utime = arrival of its last byte, estimated
  // as arrival_us - (bytes after it in this chunk) * byte_time_us. Returns the samples completed.
  std::vector<ImuSample> feed(const uint8_t* data, size_t size, int64_t arrival_us, double byte_time_us);
  // Bytes of an incomplete frame held at the end of the stream: a line that goes silent mid-frame leaves
  // them; call dropPartial() to count them as a partial frame and resynchronise.
  size_t pending() const { return buffer_.size(); }
  void dropPartial();
  int64_t partialFrames() const { return partial_frames_; }
  const StreamCounters& counters() const { return counters_; }
  const Mmq50Format& format() const { return format_; }

  // Builds a packet (for device emulators and tests): rates in rad/s and forces in m/s^2 of the IMU frame.
  static std::vector<uint8_t> encode(const Mmq50Format& format, uint32_t counter, const double angular_rate[3],
                                     const double specific_force[3], uint32_t status = 0);

 private:
  bool decode(const uint8_t* packet, ImuSample* out);
  Mmq50Format format_;
  std::vector<uint8_t> buffer_;
  StreamCounters counters_;
  int64_t partial_frames_ = 0;
  bool have_counter_ = false;
  uint32_t last_raw_counter_ = 0;
  int64_t unwrapped_counter_ = 0;
};

}  // namespace ips::drivers
