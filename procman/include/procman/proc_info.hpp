#pragma once
// CPU time and memory of the machine and of single processes, read from Linux /proc.
#include <sys/types.h>

#include <cstdint>
#include <string>

namespace ips::procman {

struct SystemTimes {
  uint64_t user = 0, nice = 0, system = 0, idle = 0;  // jiffies since boot, all CPUs
  int64_t mem_total_bytes = 0, mem_free_bytes = 0;    // "free" = MemAvailable (what a new process can get)
  int64_t swap_total_bytes = 0, swap_free_bytes = 0;
};

struct ProcessTimes {
  uint64_t user = 0, system = 0;  // jiffies of this process
  int64_t vsize_bytes = 0, rss_bytes = 0;
};

// Both return false (and leave the output untouched) when the files cannot be read or parsed.
bool readSystemTimes(SystemTimes& out, const std::string& proc_root = "/proc");
bool readProcessTimes(pid_t pid, ProcessTimes& out, const std::string& proc_root = "/proc");

// Share of elapsed machine time spent busy between two samples, in [0, 1]; 0 when nothing elapsed.
float cpuLoad(const SystemTimes& before, const SystemTimes& after);
// Share of elapsed machine time used by a process between two samples, in [0, 1].
float processCpuUsage(const ProcessTimes& before, const ProcessTimes& after, const SystemTimes& sys_before,
                      const SystemTimes& sys_after);

}  // namespace ips::procman
