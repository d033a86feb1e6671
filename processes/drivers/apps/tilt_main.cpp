// tilt: the PEI-Z260 inclinometer driver. Reads the sensor's ASCII lines from a serial line, stamps each sample
// on the common clock minus the sensor's calibrated delay, and publishes ips::tilt_sample_t on TILT.
#include <chrono>
#include <ips/tilt_sample_t.hpp>
#include <map>
#include <string>

#include "ips/config.hpp"
#include "ips/drivers/pei_z260.hpp"
#include "ips/drivers/serial_reader.hpp"
#include "ips/framework/channels.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/process.hpp"
#include "ips/framework/validate.hpp"
#include "serial_driver.hpp"

int main(int argc, char** argv) {
  return ips::fw::guardedMain("tilt", [&] {
    ips::Args args(argc, argv, "PEI-Z260 inclinometer driver: serial line -> ips::tilt_sample_t on TILT");
    args.option("--device", "PATH", "serial device (overrides tilt/port/device of the config)");
    ips::fw::addCommonOptions(args, "config/tilt.yaml");
    if (!args.parse()) return 0;
    ips::fw::applyCommonOptions(args);

    const ips::Config cfg(args.get("--config"));
    const auto format = ips::drivers::Z260Format::fromConfig(cfg.section("tilt/format"));
    // Silent after 5 sample periods (the inclinometer's rate is low: 5 periods are already a third of a second).
    auto rc = ips::drivers::SerialReaderConfig::fromConfig(cfg, "tilt", 5.0 / format.rate_hz);
    if (args.has("--device")) rc.port.device = args.get("--device");
    if (ips::fw::configChecked(args, cfg)) return 0;

    ips::drivers::SerialReader<ips::drivers::Z260Parser> reader(rc, ips::drivers::Z260Parser(format));
    ips::fw::Node node("tilt", args.get("--lcm-url"));
    return ips::drivers::runSerialDriver(node, reader, rc.port.device, ips::channels::kTilt,
                                         [](const ips::drivers::TiltSample& s) {
                                           ips::tilt_sample_t msg;
                                           msg.utime = s.utime;
                                           msg.seq = s.seq;
                                           msg.angle_x = s.angle_x;
                                           msg.angle_y = s.angle_y;
                                           return msg;
                                         });
  });
}
