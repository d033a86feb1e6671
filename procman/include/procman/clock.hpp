#pragma once
// The time procman's messages carry (utime: microseconds since the epoch, the host's wall clock, as upstream). The
// deputy compares the sheriff's order stamps with it and the process table's deadlines are in it, so all three use
// this one clock.
#include <chrono>
#include <cstdint>

namespace ips::procman {

inline int64_t nowUs() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace ips::procman
