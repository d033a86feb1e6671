// libFuzzer target: the IMU (MMQ-50 binary frames) and tilt sensor (PEI Z260 text lines) parsers on arbitrary
// bytes, fed in chunks whose sizes come from the input, as a serial line delivers them.
#include <cstddef>
#include <cstdint>

#include "ips/drivers/mmq50.hpp"
#include "ips/drivers/pei_z260.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  ips::drivers::Mmq50Format imu_format;
  imu_format.checksum = (data[0] & 1) ? ips::drivers::Checksum::Sum16 : ips::drivers::Checksum::None;
  ips::drivers::Mmq50Parser imu(imu_format);
  ips::drivers::Z260Format tilt_format;
  tilt_format.xor_checksum = data[0] & 2;
  ips::drivers::Z260Parser tilt(tilt_format);
  int64_t t = 1'000'000;
  for (size_t pos = 1; pos < size;) {
    const size_t chunk = 1 + data[pos] % 64;
    const size_t n = chunk < size - pos ? chunk : size - pos;
    (void)imu.feed(data + pos, n, t, 86.8);
    (void)tilt.feed(data + pos, n, t, 86.8);
    pos += n;
    t += 10'000;
  }
  imu.dropPartial();
  tilt.dropPartial();
  return 0;
}
