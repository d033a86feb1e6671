#include "ips/drivers/common_clock.hpp"

#include <time.h>

namespace ips::drivers {

int64_t commonClockNowUs() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1'000'000 + ts.tv_nsec / 1000;
}

}  // namespace ips::drivers
