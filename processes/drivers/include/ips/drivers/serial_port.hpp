#pragma once
// A serial line through termios: raw mode, baud rate and framing from the config, non-blocking reads with a
// poll() timeout. Errors throw std::runtime_error naming the device and the failing call.
#include <cstddef>
#include <cstdint>
#include <string>

namespace ips {
class Config;
}

namespace ips::drivers {

struct SerialSettings {
  std::string device;    // e.g. /dev/ttyS0, /dev/ttyUSB0, or a pseudo-terminal in tests
  int baud = 115200;     // one of the standard rates 1200 ... 4000000
  int data_bits = 8;     // 5..8
  char parity = 'N';     // 'N', 'E', 'O'
  int stop_bits = 1;     // 1 or 2
  bool rts_cts = false;  // hardware flow control

  // Time one byte takes on the line [us] (start + data + parity + stop bits): used to date each frame of a
  // chunk that arrived in one read.
  double byteTimeUs() const;
  // Keys device, baud, data_bits, parity, stop_bits, rts_cts of a config section (device required).
  static SerialSettings fromConfig(const Config& section);
};

class SerialPort {
 public:
  explicit SerialPort(const SerialSettings& settings);
  ~SerialPort();
  SerialPort(const SerialPort&) = delete;
  SerialPort& operator=(const SerialPort&) = delete;

  // Waits up to timeout_ms for bytes and reads what is there (at most `capacity`). Returns 0 on timeout.
  // Throws if the device failed or was closed (hang-up), so the caller can reopen it.
  size_t read(uint8_t* buffer, size_t capacity, int timeout_ms);
  // Writes all bytes (blocking up to timeout_ms in total); throws on error or timeout.
  void write(const uint8_t* data, size_t size, int timeout_ms = 1000);
  void write(const std::string& text, int timeout_ms = 1000) {
    write(reinterpret_cast<const uint8_t*>(text.data()), text.size(), timeout_ms);
  }
  const SerialSettings& settings() const { return settings_; }

  // Puts an already open terminal descriptor in raw mode with these settings (used for both ends of a pty).
  static void configure(int fd, const SerialSettings& settings);

 private:
  SerialSettings settings_;
  int fd_ = -1;
};

}  // namespace ips::drivers
