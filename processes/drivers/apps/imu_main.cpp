// imu: the Systron Donner MMQ-50 driver. Reads the IMU's binary packets from a serial line, stamps each sample
// on the common clock minus the IMU's calibrated delay, and publishes ips::imu_sample_t on IMU.
#include <chrono>
#include <ips/imu_sample_t.hpp>
#include <map>
#include <string>

#include "ips/config.hpp"
#include "ips/drivers/clock_mapper.hpp"
#include "ips/drivers/mmq50.hpp"
#include "ips/drivers/serial_reader.hpp"
#include "ips/framework/channels.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/process.hpp"
#include "ips/framework/validate.hpp"
#include "serial_driver.hpp"

int main(int argc, char** argv) {
  return ips::fw::guardedMain("imu", [&] {
    ips::Args args(argc, argv, "MMQ-50 IMU driver: serial line -> ips::imu_sample_t on IMU");
    args.option("--device", "PATH", "serial device (overrides imu/port/device of the config)");
    ips::fw::addCommonOptions(args, "config/imu.yaml");
    if (!args.parse()) return 0;
    ips::fw::applyCommonOptions(args);

    const ips::Config cfg(args.get("--config"));
    const auto format = ips::drivers::Mmq50Format::fromConfig(cfg.section("imu/packet"));
    // Silent after 10 sample periods: a 200 Hz IMU that misses 50 ms has stalled.
    auto rc = ips::drivers::SerialReaderConfig::fromConfig(cfg, "imu", 10.0 / format.rate_hz);
    if (args.has("--device")) rc.port.device = args.get("--device");
    // Counter stamps: the sample counter times the nominal period, mapped onto the common clock by the lower
    // envelope of arrivals; removes the jitter of serial delivery.
    const bool stamp_from_counter = cfg.getBool("imu/stamp_from_counter", true);
    ips::drivers::ClockMapperConfig mc;
    mc.window = static_cast<size_t>(cfg.getInt("imu/clock_window", static_cast<int>(format.rate_hz * 10)));
    // Arrivals later than the counter predicts by more than this: the sensor stalled or restarted; start again.
    mc.reset_jump_us = cfg.getInt("imu/clock_reset_us", 20000);
    if (ips::fw::configChecked(args, cfg)) return 0;
    ips::drivers::ClockMapper counter_clock(mc);

    ips::drivers::SerialReader<ips::drivers::Mmq50Parser> reader(rc, ips::drivers::Mmq50Parser(format));
    ips::fw::Node node("imu", args.get("--lcm-url"));
    const double period_us = 1e6 / format.rate_hz;
    return ips::drivers::runSerialDriver(
        node, reader, rc.port.device, ips::channels::kImu,
        [&](const ips::drivers::ImuSample& s) {
          ips::imu_sample_t msg;
          msg.utime = s.utime;
          if (stamp_from_counter) {
            // s.utime is arrival minus delay; the mapping keeps the delay and removes the jitter.
            msg.utime = counter_clock.update(static_cast<int64_t>(s.counter * period_us), s.utime);
          }
          msg.seq = s.counter;
          for (int i = 0; i < 3; ++i) {
            msg.angular_rate[i] = s.angular_rate[i];
            msg.specific_force[i] = s.specific_force[i];
          }
          return msg;
        },
        [&](ips::fw::Health& h) { h.set("clock_resets", static_cast<int64_t>(counter_clock.resets())); });
  });
}
