#include "procman/proc_info.hpp"

#include <unistd.h>

#include <fstream>
#include <sstream>

namespace ips::procman {

bool readSystemTimes(SystemTimes& out, const std::string& proc_root) {
  SystemTimes t;
  {
    std::ifstream stat(proc_root + "/stat");
    std::string cpu;
    if (!(stat >> cpu >> t.user >> t.nice >> t.system >> t.idle) || cpu != "cpu") return false;
  }
  std::ifstream meminfo(proc_root + "/meminfo");
  if (!meminfo) return false;
  std::string key;
  int64_t kb = 0;
  std::string unit;
  bool have_available = false;
  int64_t mem_free = 0;
  std::string line;
  while (std::getline(meminfo, line)) {
    std::istringstream ls(line);
    if (!(ls >> key >> kb)) continue;
    const int64_t bytes = kb * 1024;
    if (key == "MemTotal:") t.mem_total_bytes = bytes;
    if (key == "MemFree:") mem_free = bytes;
    if (key == "MemAvailable:") {
      t.mem_free_bytes = bytes;
      have_available = true;
    }
    if (key == "SwapTotal:") t.swap_total_bytes = bytes;
    if (key == "SwapFree:") t.swap_free_bytes = bytes;
  }
  if (!have_available) t.mem_free_bytes = mem_free;
  if (t.mem_total_bytes <= 0) return false;
  out = t;
  return true;
}

bool readProcessTimes(pid_t pid, ProcessTimes& out, const std::string& proc_root) {
  std::ifstream stat(proc_root + "/" + std::to_string(pid) + "/stat");
  std::string content;
  if (!std::getline(stat, content)) return false;
  // The command name (field 2) is in parentheses and may contain spaces: parse after the last ')'.
  const size_t close = content.rfind(')');
  if (close == std::string::npos) return false;
  std::istringstream fields(content.substr(close + 1));
  // Fields from 3 on: state ppid pgrp session tty_nr tpgid flags minflt cminflt majflt cmajflt utime stime
  // cutime cstime priority nice num_threads itrealvalue starttime vsize rss
  std::string state;
  long long skip = 0;
  ProcessTimes t;
  long long rss_pages = 0;
  if (!(fields >> state)) return false;
  for (int k = 4; k <= 13; ++k)
    if (!(fields >> skip)) return false;
  if (!(fields >> t.user >> t.system)) return false;
  for (int k = 16; k <= 22; ++k)
    if (!(fields >> skip)) return false;
  long long vsize = 0;
  if (!(fields >> vsize >> rss_pages)) return false;
  t.vsize_bytes = vsize;
  t.rss_bytes = rss_pages * static_cast<long long>(sysconf(_SC_PAGESIZE));
  out = t;
  return true;
}

float cpuLoad(const SystemTimes& a, const SystemTimes& b) {
  const uint64_t busy_a = a.user + a.nice + a.system, busy_b = b.user + b.nice + b.system;
  const uint64_t total_a = busy_a + a.idle, total_b = busy_b + b.idle;
  if (total_b <= total_a || busy_b < busy_a) return 0.f;
  const double load = static_cast<double>(busy_b - busy_a) / static_cast<double>(total_b - total_a);
  return static_cast<float>(load > 1.0 ? 1.0 : load);
}

float processCpuUsage(const ProcessTimes& a, const ProcessTimes& b, const SystemTimes& sa, const SystemTimes& sb) {
  const uint64_t total_a = sa.user + sa.nice + sa.system + sa.idle;
  const uint64_t total_b = sb.user + sb.nice + sb.system + sb.idle;
  const uint64_t used_a = a.user + a.system, used_b = b.user + b.system;
  if (total_b <= total_a || used_b < used_a) return 0.f;
  const double usage = static_cast<double>(used_b - used_a) / static_cast<double>(total_b - total_a);
  return static_cast<float>(usage > 1.0 ? 1.0 : usage);
}

}  // namespace ips::procman
