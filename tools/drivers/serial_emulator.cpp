// serial_emulator: a software MMQ-50 IMU or PEI-Z260 inclinometer on a pseudo-terminal, for running the imu and
// tilt processes without hardware (tests, demos). Writes the real byte stream at the sensor's rate, with
// optional corruption (flipped bytes, garbage between frames, a line that goes silent mid-frame).
#include <pty.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <thread>

#include "ips/args.hpp"
#include "ips/config.hpp"
#include "ips/drivers/mmq50.hpp"
#include "ips/drivers/pei_z260.hpp"
#include "ips/drivers/serial_port.hpp"

using namespace ips::drivers;

namespace {

void writeAll(int fd, const std::vector<uint8_t>& bytes) {
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EAGAIN || errno == EINTR) {
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
        continue;
      }
      throw std::runtime_error("serial_emulator: write failed");
    }
    done += static_cast<size_t>(n);
  }
}

}  // namespace

int main(int argc, char** argv) {
  try {
    ips::Args args(argc, argv, "Emulates an MMQ-50 IMU or a PEI-Z260 inclinometer on a pseudo-terminal");
    args.required("--sensor", "NAME", "mmq50 or z260")
        .option("--config", "FILE", "config with imu/packet or tilt/format (default: built-in defaults)")
        .option("--link", "PATH", "also make PATH a symbolic link to the terminal (a fixed name for the driver)")
        .option("--rate", "HZ", "output rate (default: the format's rate_hz)", "0")
        .option("--count", "N", "frames to send", "1000")
        .option("--corrupt-every", "N", "flip one byte in every N-th frame (0: never)", "0")
        .option("--garbage-every", "N", "write 1..16 random bytes before every N-th frame (0: never)", "0")
        .option("--silence-at", "N", "after N frames write half a frame and go silent (0: never)", "0")
        .option("--silence-s", "S", "length of that silence", "1.0")
        .option("--wait-s", "S", "wait this long after 'ready' before the first frame (driver opening)", "0")
        .option("--linger-s", "S", "keep the terminal open this long after the last frame", "1.0")
        .option("--seed", "N", "random seed", "1");
    if (!args.parse()) return 0;
    const std::string sensor = args.get("--sensor");
    if (sensor != "mmq50" && sensor != "z260") throw ips::ArgError("--sensor must be mmq50 or z260");

    Mmq50Format imu;
    Z260Format tilt;
    if (args.has("--config")) {
      const ips::Config cfg(args.get("--config"));
      if (sensor == "mmq50")
        imu = Mmq50Format::fromConfig(cfg.section("imu/packet"));
      else
        tilt = Z260Format::fromConfig(cfg.section("tilt/format"));
    }
    double rate = args.getDouble("--rate");
    if (rate <= 0) rate = sensor == "mmq50" ? imu.rate_hz : tilt.rate_hz;
    const long long count = args.getInt("--count");
    const long long corrupt_every = args.getInt("--corrupt-every");
    const long long garbage_every = args.getInt("--garbage-every");
    const long long silence_at = args.getInt("--silence-at");

    int master = -1, slave = -1;
    char name[256];
    if (openpty(&master, &slave, name, nullptr, nullptr) != 0) throw std::runtime_error("openpty failed");
    SerialSettings raw;
    raw.device = name;
    SerialPort::configure(master, raw);
    if (args.has("--link")) {
      ::unlink(args.get("--link").c_str());
      if (::symlink(name, args.get("--link").c_str()) != 0) throw std::runtime_error("cannot create --link");
    }
    std::printf("ready %s\n", name);
    std::fflush(stdout);

    std::this_thread::sleep_for(std::chrono::duration<double>(args.getDouble("--wait-s")));
    std::mt19937 rng(static_cast<unsigned>(args.getInt("--seed")));
    std::uniform_int_distribution<int> byte(0, 255), len(1, 16);
    auto start = std::chrono::steady_clock::now();
    long long corrupted = 0, garbage = 0;
    for (long long k = 0; k < count; ++k) {
      std::this_thread::sleep_until(start + std::chrono::duration<double>(k / rate));
      const double t = k / rate;
      std::vector<uint8_t> frame;
      if (sensor == "mmq50") {
        const double w[3] = {0.1 * std::sin(t), 0.2 * std::cos(t), 0.05};
        const double f[3] = {0.0, 0.0, 9.81};
        frame = Mmq50Parser::encode(imu, static_cast<uint32_t>(k), w, f);
      } else {
        const std::string line = Z260Parser::format(tilt, 0.05 * std::sin(0.5 * t), 0.03);
        frame.assign(line.begin(), line.end());
      }
      if (garbage_every > 0 && k % garbage_every == garbage_every - 1) {
        std::vector<uint8_t> junk(static_cast<size_t>(len(rng)));
        for (auto& b : junk) b = static_cast<uint8_t>(byte(rng));
        writeAll(master, junk);
        ++garbage;
      }
      if (corrupt_every > 0 && k % corrupt_every == corrupt_every - 1) {
        frame[frame.size() / 2] ^= 0x5A;
        ++corrupted;
      }
      if (silence_at > 0 && k == silence_at) {
        frame.resize(frame.size() / 2);
        writeAll(master, frame);
        std::this_thread::sleep_for(std::chrono::duration<double>(args.getDouble("--silence-s")));
        // A sensor that was silent does not send the missed frames in a burst afterwards: the schedule restarts.
        start = std::chrono::steady_clock::now() - std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                                       std::chrono::duration<double>(k / rate));
        continue;
      }
      writeAll(master, frame);
    }
    std::printf("sent frames=%lld corrupted=%lld garbage_runs=%lld\n", count, corrupted, garbage);
    std::fflush(stdout);
    std::this_thread::sleep_for(std::chrono::duration<double>(args.getDouble("--linger-s")));
    if (args.has("--link")) ::unlink(args.get("--link").c_str());
    ::close(master);
    ::close(slave);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "serial_emulator: error: %s\n", e.what());
    return 1;
  }
}
