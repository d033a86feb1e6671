// The serial drivers through real pseudo-terminals (openpty): a device emulator thread writes the byte stream
// a sensor would send, including corruption, a silent line and a line that hangs up; the reader must deliver
// every good sample with a sensible stamp, count the rest, and keep going.
#include <gtest/gtest.h>
#include <pty.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "ips/drivers/common_clock.hpp"
#include "ips/drivers/mmq50.hpp"
#include "ips/drivers/pei_z260.hpp"
#include "ips/drivers/serial_reader.hpp"

using namespace ips::drivers;
using namespace std::chrono_literals;

namespace {

// A pseudo-terminal pair: the emulator writes to the master, the driver opens the slave by its path.
struct Pty {
  int master = -1, slave = -1;
  std::string path;
  Pty() {
    char name[256];
    if (openpty(&master, &slave, name, nullptr, nullptr) != 0) throw std::runtime_error("openpty failed");
    path = name;
    SerialSettings raw;
    raw.device = path;
    SerialPort::configure(master, raw);  // no echo, no line discipline on the emulator side
  }
  ~Pty() {
    if (master >= 0) close(master);
    if (slave >= 0) close(slave);
  }
  void write(const std::vector<uint8_t>& bytes) const {
    size_t done = 0;
    while (done < bytes.size()) {
      const ssize_t n = ::write(master, bytes.data() + done, bytes.size() - done);
      if (n <= 0) throw std::runtime_error("pty write failed");
      done += static_cast<size_t>(n);
    }
  }
};

template <class Reader, class Pred>
auto readUntil(Reader& reader, std::chrono::milliseconds limit, Pred done) {
  std::vector<typename Reader::Sample> all;
  const auto end = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < end && !done(all)) {
    auto s = reader.poll(20);
    all.insert(all.end(), s.begin(), s.end());
  }
  return all;
}

}  // namespace

TEST(SerialPty, ImuStreamWithCorruptionAndSilence) {
  Pty pty;
  Mmq50Format format;
  SerialReaderConfig rc;
  rc.port.device = pty.path;
  rc.port.baud = 460800;
  rc.delay_us = 1500;
  rc.silence_s = 0.25;
  SerialReader<Mmq50Parser> reader(rc, Mmq50Parser(format));
  reader.poll(1);  // opens the port
  ASSERT_TRUE(reader.open());

  std::atomic<int64_t> last_write_us{0};
  std::thread emulator([&] {
    const double w[3] = {0.01, 0.02, 0.03}, a[3] = {0, 0, 9.81};
    for (uint32_t k = 0; k < 200; ++k) {
      auto p = Mmq50Parser::encode(format, k, w, a);
      if (k == 50) p[7] ^= 0xFF;                                     // checksum error
      if (k == 80) pty.write({0x13, 0x37, 0x55, 0x00, 0xAA, 0x42});  // garbage incl. a false sync start
      if (k == 120) {                                                // half a frame, then silence
        p.resize(p.size() / 2);
        pty.write(p);
        std::this_thread::sleep_for(700ms);
        continue;
      }
      pty.write(p);
      last_write_us = commonClockNowUs();
      std::this_thread::sleep_for(5ms);  // 200 Hz
    }
  });
  const auto s = readUntil(reader, 6000ms, [](const auto& all) { return all.size() >= 197; });
  emulator.join();
  const auto c = reader.counters();
  EXPECT_EQ(s.size(), 197u);  // 200 sent, one corrupt, one cut short by the silence
  EXPECT_EQ(c.at("checksum_errors"), 1 + 0);
  EXPECT_GE(c.at("garbage_bytes"), 6);
  EXPECT_GE(c.at("silences"), 1);  // more only if this machine stalled the emulator for 0.25 s
  EXPECT_EQ(c.at("partial_frames"), 1);
  EXPECT_EQ(c.at("counter_gaps"), 2);
  for (size_t i = 1; i < s.size(); ++i) EXPECT_GT(s[i].utime, s[i - 1].utime);
  // Stamps are arrival minus the configured delay: the last one lies just before "arrival" of the last write.
  const int64_t expected = last_write_us.load() - rc.delay_us;
  EXPECT_LT(std::llabs(s.back().utime - expected), 50000) << "stamp vs write time";
}

TEST(SerialPty, TiltLinesAndAHungUpLine) {
  auto pty = std::make_unique<Pty>();
  Z260Format format;
  SerialReaderConfig rc;
  rc.port.device = pty->path;
  rc.port.baud = 9600;
  rc.port.parity = 'E';
  rc.silence_s = 0.3;
  rc.reopen_interval_s = 0.1;
  SerialReader<Z260Parser> reader(rc, Z260Parser(format));
  reader.poll(1);
  ASSERT_TRUE(reader.open());
  std::thread emulator([&] {
    for (int k = 0; k < 20; ++k) {
      std::string line = Z260Parser::format(format, 0.001 * k, -0.002 * k);
      if (k == 10) line = "X=+0#.000 Y=+01.000\r\n";  // a corrupt digit
      pty->write(std::vector<uint8_t>(line.begin(), line.end()));
      std::this_thread::sleep_for(10ms);
    }
  });
  const auto s = readUntil(reader, 3000ms, [](const auto& all) { return all.size() >= 19; });
  emulator.join();
  ASSERT_EQ(s.size(), 19u);
  EXPECT_NEAR(s.back().angle_x, 0.019, 1e-4);
  EXPECT_EQ(reader.counters().at("bad_frames"), 1);

  // The device goes away (USB adapter unplugged): the driver notices, keeps trying, and does not crash.
  const std::string path = pty->path;
  pty.reset();
  readUntil(reader, 2000ms, [&](const auto&) { return reader.counters().at("open_failures") > 0; });
  const auto c = reader.counters();
  EXPECT_EQ(c.at("read_errors"), 1);    // the hang-up, seen once
  EXPECT_GE(c.at("open_failures"), 1);  // and the device is retried, not given up
  EXPECT_FALSE(reader.open());
}
