#include "ips/drivers/serial_reader.hpp"

#include "ips/config.hpp"

namespace ips::drivers {

SerialReaderConfig SerialReaderConfig::fromConfig(const Config& cfg, const std::string& sensor,
                                                  double default_silence_s) {
  SerialReaderConfig rc;
  rc.port = SerialSettings::fromConfig(cfg.section(sensor + "/port"));
  rc.delay_us = cfg.getInt(sensor + "/delay_us", 0);
  rc.silence_s = cfg.getDouble(sensor + "/silence_s", default_silence_s);
  rc.reopen_interval_s = cfg.getDouble(sensor + "/reopen_interval_s", rc.reopen_interval_s);
  return rc;
}

}  // namespace ips::drivers
