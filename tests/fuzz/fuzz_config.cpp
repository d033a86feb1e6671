// libFuzzer target: the configuration and calibration readers on arbitrary file contents. Every process and
// tool reads its YAML through them; a malformed file must give a ConfigError, never a hang, a crash or
// another exception. (libFuzzer's -timeout turns a hang into a finding.)
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

#include "ips/calibration.hpp"
#include "ips/config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = "/tmp/ips_fuzz_config_" + std::to_string(getpid()) + ".yaml";
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) return 0;
  std::fwrite(data, 1, size, f);
  std::fclose(f);
  try {
    ips::Config c(path);
    (void)c.getDouble("gravity", 9.81);
    (void)c.getInt("max_clones", 2);
    if (c.has("v")) (void)c.getMat("v");
  } catch (const ips::ConfigError&) {
  }
  try {
    (void)ips::loadCalibration(path);
  } catch (const ips::ConfigError&) {
  }
  return 0;
}
