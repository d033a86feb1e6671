// The serial parsers on byte streams built in memory: round trips for every supported layout, streams split at
// every byte, and corrupted streams (checksum errors, partial frames, garbage) that are counted and survived.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "ips/drivers/mmq50.hpp"
#include "ips/drivers/pei_z260.hpp"

using namespace ips::drivers;

namespace {

std::vector<uint8_t> packet(const Mmq50Format& f, uint32_t counter) {
  const double w[3] = {0.1 * counter, -0.2, 0.3 + 1e-3 * counter};
  const double a[3] = {0.5, -9.81, 1.0 + 0.01 * counter};
  return Mmq50Parser::encode(f, counter, w, a);
}

std::vector<ImuSample> feedAll(Mmq50Parser& p, const std::vector<uint8_t>& bytes, size_t chunk) {
  std::vector<ImuSample> out;
  for (size_t i = 0; i < bytes.size(); i += chunk) {
    const size_t n = std::min(chunk, bytes.size() - i);
    auto s = p.feed(bytes.data() + i, n, 1'000'000 + static_cast<int64_t>(i), 1.0);
    out.insert(out.end(), s.begin(), s.end());
  }
  return out;
}

}  // namespace

TEST(Mmq50, RoundTripEveryLayout) {
  for (Checksum c : {Checksum::None, Checksum::Sum8, Checksum::Xor8, Checksum::Sum16, Checksum::Crc16Ccitt}) {
    for (int word : {2, 4}) {
      for (bool big : {true, false}) {
        Mmq50Format f;
        f.checksum = c;
        f.rate_bytes = f.accel_bytes = word;
        f.big_endian = big;
        f.rate_lsb = word == 2 ? 1e-4 : 1e-7;
        f.accel_lsb = word == 2 ? 1e-3 : 1e-6;
        f.axis_map = {2, 0, 1};
        f.axis_sign = {1, -1, 1};
        Mmq50Parser p(f);
        const double w[3] = {0.5, -1.25, 2.0};
        const double a[3] = {-9.80665, 0.25, 3.0};
        const auto bytes = Mmq50Parser::encode(f, 77, w, a, 0);
        ASSERT_EQ(bytes.size(), f.packetSize());
        auto s = p.feed(bytes.data(), bytes.size(), 5000, 10.0);
        ASSERT_EQ(s.size(), 1u);
        for (int i = 0; i < 3; ++i) {
          EXPECT_NEAR(s[0].angular_rate[i], w[i], f.rate_lsb);
          EXPECT_NEAR(s[0].specific_force[i], a[i], f.accel_lsb);
        }
        EXPECT_EQ(s[0].utime, 5000);  // the last byte arrived with the read
      }
    }
  }
}

TEST(Mmq50, KnownChecksums) {
  const uint8_t text[] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
  EXPECT_EQ(computeChecksum(Checksum::Crc16Ccitt, text, 9), 0x29B1u);  // CRC-16/CCITT-FALSE check value
  EXPECT_EQ(computeChecksum(Checksum::Sum8, text, 9),
            (0x31u + 0x32 + 0x33 + 0x34 + 0x35 + 0x36 + 0x37 + 0x38 + 0x39) & 0xFF);
  EXPECT_EQ(computeChecksum(Checksum::Xor8, text, 9), 0x31u);
}

TEST(Mmq50, SameSamplesWhateverTheReadSizes) {
  Mmq50Format f;
  std::vector<uint8_t> stream;
  for (uint32_t k = 0; k < 50; ++k) {
    const auto p = packet(f, k);
    stream.insert(stream.end(), p.begin(), p.end());
  }
  for (size_t chunk : {size_t(1), size_t(3), size_t(7), f.packetSize(), size_t(1000)}) {
    Mmq50Parser p(f);
    const auto s = feedAll(p, stream, chunk);
    ASSERT_EQ(s.size(), 50u) << "chunk " << chunk;
    for (size_t k = 0; k < s.size(); ++k) {
      EXPECT_EQ(s[k].counter, static_cast<int64_t>(k));
      EXPECT_NEAR(s[k].angular_rate[0], 0.1 * k, 1e-6);
    }
    EXPECT_EQ(p.counters().garbage_bytes, 0);
    EXPECT_EQ(p.counters().checksum_errors, 0);
    EXPECT_EQ(p.pending(), 0u);
  }
}

TEST(Mmq50, FramesInOneReadAreDatedByTheBytesBehindThem) {
  Mmq50Format f;
  std::vector<uint8_t> stream;
  for (uint32_t k = 0; k < 3; ++k) {
    const auto p = packet(f, k);
    stream.insert(stream.end(), p.begin(), p.end());
  }
  Mmq50Parser p(f);
  const auto s = p.feed(stream.data(), stream.size(), 100000, 10.0);  // 10 us per byte
  ASSERT_EQ(s.size(), 3u);
  const int64_t size = static_cast<int64_t>(f.packetSize());
  EXPECT_EQ(s[2].utime, 100000);
  EXPECT_EQ(s[1].utime, 100000 - 10 * size);
  EXPECT_EQ(s[0].utime, 100000 - 20 * size);
}

TEST(Mmq50, CorruptedStreamCountedAndSurvived) {
  Mmq50Format f;
  std::vector<uint8_t> stream = {0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07};  // garbage before the first frame
  auto add = [&](const std::vector<uint8_t>& p) { stream.insert(stream.end(), p.begin(), p.end()); };
  add(packet(f, 0));
  auto bad = packet(f, 1);
  bad[5] ^= 0x10;  // a flipped bit in the data
  add(bad);
  add(packet(f, 2));
  auto cut = packet(f, 3);
  cut.resize(cut.size() / 2);  // a partial frame, then the next one
  add(cut);
  add(packet(f, 4));
  add(packet(f, 5));
  Mmq50Parser p(f);
  const auto s = feedAll(p, stream, 5);
  std::vector<int64_t> counters;
  for (const auto& x : s) counters.push_back(x.counter);
  // Counters as unwrapped from the device counter 0, 2, 4, 5: the lost ones appear as gaps.
  EXPECT_EQ(counters, (std::vector<int64_t>{0, 2, 4, 5}));
  EXPECT_EQ(p.counters().frames, 4);
  EXPECT_EQ(p.counters().counter_gaps, 2);
  EXPECT_GE(p.counters().checksum_errors, 2);  // the flipped one and the cut one running into the next
  EXPECT_GE(p.counters().garbage_bytes, 7);
  EXPECT_NEAR(s[1].angular_rate[0], 0.2, 1e-6);
}

TEST(Mmq50, RandomGarbageBetweenFramesLosesNoFrame) {
  Mmq50Format f;
  std::mt19937 rng(42);
  std::uniform_int_distribution<int> byte(0, 255), len(0, 40);
  std::vector<uint8_t> stream;
  const uint32_t n = 2000;
  for (uint32_t k = 0; k < n; ++k) {
    for (int i = len(rng); i > 0; --i) stream.push_back(static_cast<uint8_t>(byte(rng)));
    const auto p = packet(f, k);
    stream.insert(stream.end(), p.begin(), p.end());
  }
  Mmq50Parser p(f);
  const auto s = feedAll(p, stream, 61);
  EXPECT_EQ(s.size(), n);  // garbage may hold false sync words, but their checksums fail
  EXPECT_EQ(p.counters().counter_gaps, 0);
  EXPECT_GT(p.counters().garbage_bytes, 20 * static_cast<int64_t>(n) / 2);
}

TEST(Mmq50, StatusBitsAndRepeatedPacketsRejected) {
  Mmq50Format f;
  f.status_ok_mask = 0x0001;
  Mmq50Parser p(f);
  const double w[3] = {0, 0, 0}, a[3] = {0, 0, 9.8};
  auto s1 = Mmq50Parser::encode(f, 1, w, a, 0x0000);
  auto s2 = Mmq50Parser::encode(f, 2, w, a, 0x0001);  // the sensor flags a failure
  auto s3 = Mmq50Parser::encode(f, 2, w, a, 0x0000);  // the same counter again
  std::vector<uint8_t> stream = s1;
  stream.insert(stream.end(), s2.begin(), s2.end());
  stream.insert(stream.end(), s3.begin(), s3.end());
  EXPECT_EQ(p.feed(stream.data(), stream.size(), 0, 1).size(), 1u);
  EXPECT_EQ(p.counters().bad_frames, 2);
}

TEST(Mmq50, BadFormatRejected) {
  Mmq50Format f;
  f.rate_bytes = 3;
  EXPECT_THROW(Mmq50Parser{f}, std::invalid_argument);
  f = Mmq50Format();
  f.axis_map = {0, 0, 1};
  EXPECT_THROW(Mmq50Parser{f}, std::invalid_argument);
  EXPECT_THROW(parseChecksum("md5"), std::invalid_argument);
}

TEST(Z260, RoundTripOneLineAndTwoLines) {
  Z260Format f;
  Z260Parser p(f);
  const std::string line = Z260Parser::format(f, 0.1, -0.2);
  auto s = p.feed(reinterpret_cast<const uint8_t*>(line.data()), line.size(), 777, 100.0);
  ASSERT_EQ(s.size(), 1u);
  EXPECT_NEAR(s[0].angle_x, 0.1, 1e-3 * M_PI / 180);
  EXPECT_NEAR(s[0].angle_y, -0.2, 1e-3 * M_PI / 180);
  EXPECT_EQ(s[0].utime, 777 - 100);  // dated by the '\r'; the '\n' came one byte later
  const std::string two = "X=+01.500\r\nY=-02.250\r\n";
  s = p.feed(reinterpret_cast<const uint8_t*>(two.data()), two.size(), 0, 1.0);
  ASSERT_EQ(s.size(), 1u);
  EXPECT_NEAR(s[0].angle_x, 1.5 * M_PI / 180, 1e-9);
  EXPECT_NEAR(s[0].angle_y, -2.25 * M_PI / 180, 1e-9);
  EXPECT_EQ(s[0].seq, 1);
}

TEST(Z260, CorruptLinesCountedAndSurvived) {
  Z260Format f;
  f.xor_checksum = true;
  Z260Parser p(f);
  std::string stream;
  stream += Z260Parser::format(f, 0.01, 0.02);
  std::string corrupt = Z260Parser::format(f, 0.03, 0.04);
  corrupt[4] = corrupt[4] == '1' ? '2' : '1';  // a changed digit: checksum error
  stream += corrupt;
  stream += "X=+01.0";  // cut off by noise
  stream += std::string(1, '\x00') + "\xff\xfe";
  stream += "\r\n";
  stream += "X=+99.000 Y=+00.000*";  // out of range, bad checksum field
  stream += "\r\n";
  stream += std::string(100, 'Z') + "\r\n";  // an overlong line
  stream += Z260Parser::format(f, -0.05, 0.06);
  const auto s = p.feed(reinterpret_cast<const uint8_t*>(stream.data()), stream.size(), 0, 1.0);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_NEAR(s[0].angle_x, 0.01, 1e-4);
  EXPECT_NEAR(s[1].angle_x, -0.05, 1e-4);
  EXPECT_NEAR(s[1].angle_y, 0.06, 1e-4);
  EXPECT_EQ(p.counters().checksum_errors, 2);
  EXPECT_GT(p.counters().garbage_bytes, 100);
}

TEST(Z260, OutOfRangeAndLostAxisAreBadFrames) {
  Z260Format f;
  Z260Parser p(f);
  const std::string stream = "X=+75.000 Y=+00.000\r\nY=+01.000\r\nX=+01.000\r\nX=+02.000\r\nY=+03.000\r\n";
  const auto s = p.feed(reinterpret_cast<const uint8_t*>(stream.data()), stream.size(), 0, 1.0);
  ASSERT_EQ(s.size(), 1u);
  EXPECT_NEAR(s[0].angle_x, 2.0 * M_PI / 180, 1e-9);  // the X that had its Y
  EXPECT_EQ(p.counters().bad_frames, 3);              // out of range, Y without X, X without Y
}
