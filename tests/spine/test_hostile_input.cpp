// Messages crafted to break the receiver: every 4-byte field of a valid encoding of each type replaced by a
// hostile length (negative, zero, INT32_MIN, INT32_MAX, larger than the datagram). The generated decoders
// (bounded by cmake/lcm_bound_lengths.cmake) must reject them without throwing and without allocating from a
// length the bytes cannot hold; the framework's stream checks must not adopt a forged stamp.
#include <gtest/gtest.h>

#include <climits>
#include <cmath>
#include <cstring>
#include <fstream>
#include <ips/disparity_map_t.hpp>
#include <ips/filter_state_t.hpp>
#include <ips/ground_truth_t.hpp>
#include <ips/health_t.hpp>
#include <ips/imu_sample_t.hpp>
#include <ips/integrity_t.hpp>
#include <ips/point_cloud_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <ips/tilt_sample_t.hpp>
#include <ips/tracker_delta_t.hpp>
#include <lcm/lcm-cpp.hpp>
#include <limits>
#include <vector>

#include "ips/framework/image.hpp"
#include "ips/framework/log_reader.hpp"
#include "ips/framework/log_writer.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/validate.hpp"
#include "ips/test_support/sample_messages.hpp"

namespace {

using ips::test_support::encodeMessage;
using ips::test_support::forEachHostileLength;
using ips::test_support::putBigEndian32;

// Decodes every variant of `valid` with one 4-byte window replaced by a hostile length; `check` then looks at
// the message the decoder filled (or partly filled before it gave up).
template <class Msg, class Check>
void decodeEveryHostileLength(const Msg& valid, Check check) {
  forEachHostileLength(encodeMessage(valid), [&](const std::vector<uint8_t>& bad, size_t at, int32_t v) {
    const auto size = static_cast<int>(bad.size());
    Msg m;
    int rc = 0;
    ASSERT_NO_THROW(rc = m.decode(bad.data(), 0, size)) << Msg::getTypeName() << " at byte " << at << " = " << v;
    check(m, rc, size);
  });
}

// Every vector the decoder allocated holds at most as many elements as the datagram has bytes.
template <class T>
void expectBounded(const std::vector<T>& v, int32_t datagram) {
  EXPECT_LE(v.capacity(), static_cast<size_t>(datagram));
}

TEST(HostileInput, StereoPairLengthsAreBoundedByTheDatagram) {
  ips::stereo_pair_t m = ips::fw::makeStereoPair(1000, 1, cv::Mat(3, 4, CV_8UC1, cv::Scalar(7)),
                                                 cv::Mat(3, 4, CV_8UC1, cv::Scalar(9)), "L123", "R456");
  decodeEveryHostileLength(m, [](const ips::stereo_pair_t& d, int, int32_t size) {
    expectBounded(d.left, size);
    expectBounded(d.right, size);
    EXPECT_LE(d.serial_left.size(), static_cast<size_t>(size));
  });
}

TEST(HostileInput, DataSizeOfTwoGigabytesInASmallMessageIsRejectedAtOnce) {
  ips::stereo_pair_t m =
      ips::fw::makeStereoPair(1000, 1, cv::Mat(2, 2, CV_8UC1, cv::Scalar(1)), cv::Mat(2, 2, CV_8UC1, cv::Scalar(2)));
  std::vector<uint8_t> buf = encodeMessage(m);
  // data_size sits right before the 4 + 4 image bytes at the end of the message.
  putBigEndian32(buf, buf.size() - 8 - 4, INT32_MAX);
  ips::stereo_pair_t d;
  EXPECT_LT(d.decode(buf.data(), 0, static_cast<int>(buf.size())), 0);
  EXPECT_LE(d.left.capacity(), buf.size());
}

TEST(HostileInput, DisparityMapLengthsAreBoundedByTheDatagram) {
  const auto m = ips::test_support::sampleDisparityMap();
  decodeEveryHostileLength(m, [](const ips::disparity_map_t& d, int, int32_t size) {
    expectBounded(d.data, size);
    for (const auto& row : d.data) expectBounded(row, size);
    expectBounded(d.confidence, size);
  });
}

TEST(HostileInput, FilterStateLengthsAreBoundedByTheDatagram) {
  const auto m = ips::test_support::sampleFilterState();
  decodeEveryHostileLength(m, [](const ips::filter_state_t& d, int, int32_t size) {
    expectBounded(d.covariance, size);
    for (const auto& row : d.covariance) expectBounded(row, size);
    expectBounded(d.sensor_names, size);
    expectBounded(d.accepted, size);
  });
}

TEST(HostileInput, HealthPointCloudAndFixedSizeTypesNeverThrow) {
  const auto h = ips::test_support::sampleHealth();
  decodeEveryHostileLength(h, [](const ips::health_t& d, int, int32_t size) {
    expectBounded(d.counter_names, size);
    expectBounded(d.counter_values, size);
  });
  const auto pc = ips::test_support::samplePointCloud();
  decodeEveryHostileLength(pc, [](const ips::point_cloud_t& d, int, int32_t size) {
    expectBounded(d.points, size);
    expectBounded(d.intensity, size);
  });
  auto none = [](const auto&, int, int32_t) {};
  decodeEveryHostileLength(ips::imu_sample_t{}, none);
  decodeEveryHostileLength(ips::tilt_sample_t{}, none);
  decodeEveryHostileLength(ips::tracker_delta_t{}, none);
  decodeEveryHostileLength(ips::integrity_t{}, none);
  ips::ground_truth_t gt{};
  decodeEveryHostileLength(gt, none);
}

TEST(HostileInput, NodeCountsAMessageWhoseStringLengthIsZero) {
  ips::fw::Node node("t", "memq://");
  int delivered = 0;
  node.subscribe<ips::health_t>("HEALTH_X", [&](const ips::health_t&) { ++delivered; });
  ips::health_t h{};
  h.process = "x";
  h.host = "y";
  std::vector<uint8_t> buf = encodeMessage(h);
  putBigEndian32(buf, 8 + 8, 0);  // the length of `process` (which counts its NUL) set to 0
  node.lcm().publish("HEALTH_X", buf.data(), static_cast<unsigned>(buf.size()));
  node.publish("HEALTH_X", h);
  node.handleOnce(10);
  node.handleOnce(10);
  EXPECT_EQ(delivered, 1);
  EXPECT_EQ(node.health().counter("decode_error"), 1);
}

TEST(HostileInput, NodeDropsExactRepeats) {
  ips::fw::Node node("t", "memq://");
  int delivered = 0;
  node.subscribe<ips::imu_sample_t>("IMU", [&](const ips::imu_sample_t&) { ++delivered; });
  ips::imu_sample_t a{};
  a.utime = 100;
  a.seq = 1;
  ips::imu_sample_t b = a;
  b.utime = 105;
  b.seq = 2;
  for (const auto* m : {&a, &a, &b, &a, &b}) node.publish("IMU", *m);
  for (int i = 0; i < 5; ++i) node.handleOnce(10);
  EXPECT_EQ(delivered, 2);
  EXPECT_EQ(node.health().counter("duplicate"), 3);
  EXPECT_EQ(node.health().droppedCount(), 3);
}

TEST(HostileInput, AnotherProcessOfTheSameNameIsCounted) {
  ips::fw::Node node("tracker", "memq://");
  node.publishHealth(1.0);  // its own health message: not counted
  ips::health_t other{};
  other.process = "tracker";
  other.host = node.health().host();
  other.pid = static_cast<int32_t>(::getpid()) + 1;  // a second tracker started by mistake
  node.publish("HEALTH_TRACKER", other);
  other.utime = 1;  // its next report (not a repeat)
  node.publish("HEALTH_TRACKER", other);
  for (int i = 0; i < 3; ++i) node.handleOnce(10);
  EXPECT_EQ(node.health().counter("other_process_same_name"), 2);
}

TEST(HostileInput, ForgedStampFarAheadIsNeverAdopted) {
  ips::fw::StreamOrder order;
  int64_t t = 1'000'000;
  for (int i = 1; i <= 10; ++i) ASSERT_TRUE(order.check(t += 5'000, i).accept);
  // An IMU sample stamped an hour ahead: rejected as a jump, and the real stream goes on.
  auto forged = order.check(t + 3'600'000'000LL, 11);
  EXPECT_FALSE(forged.accept);
  EXPECT_EQ(forged.outcome, ips::fw::StreamOrder::Outcome::jump);
  for (int i = 11; i <= 20; ++i) EXPECT_TRUE(order.check(t += 5'000, i).accept) << i;
  EXPECT_EQ(order.lastUtime(), t);
}

TEST(HostileInput, StampAFewSecondsAheadOfAKnownRhythmIsRefused) {
  ips::fw::StreamOrder::Limits limits;
  ips::fw::StreamOrder order(limits);
  int64_t t = 1'000'000;
  for (int i = 1; i <= 20; ++i) ASSERT_TRUE(order.check(t += 5'000, i).accept);
  // 200 Hz: more than gap_intervals (20) periods ahead is off the time line, even though it is far below the
  // 10 s a stream of unknown rhythm may step.
  EXPECT_FALSE(order.check(t + 3'000'000, 21).accept);
  EXPECT_FALSE(order.check(t + 200'000, 21).accept);
  // A genuine gap within the limit (ten samples lost) stays on the time line, counted as lost.
  auto gap = order.check(t += 55'000, 31);
  EXPECT_TRUE(gap.accept);
  EXPECT_EQ(gap.gap, 10);
  EXPECT_FALSE(gap.clock_step);
  // A longer outage of a real source (0.5 s) is followed after `confirm` samples, as a clock step.
  t += 500'000;
  for (int i = 1; i < limits.confirm; ++i) EXPECT_FALSE(order.check(t += 5'000, 130 + i).accept) << i;
  EXPECT_TRUE(order.check(t += 5'000, 130 + limits.confirm).clock_step);
}

TEST(HostileInput, LiveStampAheadOfTheHostClockIsRefused) {
  // 8 Hz pairs arriving 30-60 ms after their stamps. A stamp 1.5 s ahead passes the rhythm test (20 intervals
  // are 2.5 s) but not the host's clock: it arrived now, so it cannot be 1.5 s newer than the last pair.
  ips::fw::StreamOrder::Limits limits;
  ips::fw::StreamOrder order(limits);
  const int64_t host_minus_head = 7'000'000'000;  // the host's clock and the head's differ: only the offset counts
  int64_t t = 1'000'000;
  for (int i = 1; i <= 20; ++i, t += 125'000)
    ASSERT_TRUE(order.check(t, i, t + host_minus_head + 30'000 + (i % 3) * 15'000).accept) << i;
  const int64_t now = t - 125'000 + host_minus_head + 40'000;
  auto forged = order.check(t + 1'500'000, 21, now);
  EXPECT_FALSE(forged.accept);
  EXPECT_EQ(forged.outcome, ips::fw::StreamOrder::Outcome::ahead_of_host);
  EXPECT_EQ(ips::fw::StreamOrder::reason(forged.outcome), std::string("time_ahead_of_host"));
  // Without the arrival time (a log read offline) the same stamp is within the rhythm and accepted.
  ips::fw::StreamOrder offline(limits);
  int64_t u = 1'000'000;
  for (int i = 1; i <= 20; ++i, u += 125'000) ASSERT_TRUE(offline.check(u, i).accept);
  EXPECT_TRUE(offline.check(u - 125'000 + 1'500'000, 21).accept);
  // The real stream goes on.
  EXPECT_TRUE(order.check(t, 21, t + host_minus_head + 35'000).accept);
}

TEST(HostileInput, LiveSourcePausingForASecondIsFollowedAtOnce) {
  // A 30 Hz tilt sensor silent for 1.2 s (far more than 20 intervals): its next sample arrives 1.2 s later on
  // the host's clock too, so it is the same time line, not a jump to confirm. The same stamp arriving in the
  // stream's rhythm is refused.
  ips::fw::StreamOrder live, burst;
  int64_t t = 1'000'000, arrival = 90'000'000;
  for (int i = 1; i <= 20; ++i, t += 33'000, arrival += 33'000) {
    ASSERT_TRUE(live.check(t, i, arrival + 2'000).accept);
    ASSERT_TRUE(burst.check(t, i, arrival + 2'000).accept);
  }
  auto resumed = live.check(t + 1'200'000, 21, arrival + 1'200'000 + 2'500);
  EXPECT_TRUE(resumed.accept);
  EXPECT_FALSE(resumed.clock_step);
  EXPECT_FALSE(burst.check(t + 1'200'000, 21, arrival + 2'500).accept);
}

TEST(HostileInput, ReplayFasterThanRealTimeIsNotAheadOfTheHost) {
  // lcm-logplayer at 4x: every pair arrives 94 ms "earlier" than the one before, over and over.
  ips::fw::StreamOrder order;
  int64_t t = 1'000'000, arrival = 50'000'000;
  for (int i = 1; i <= 400; ++i, t += 125'000, arrival += 125'000 / 4)
    ASSERT_TRUE(order.check(t, i, arrival).accept) << i;
}

TEST(HostileInput, HealthMessagesNamingNoPossibleProcessAreRefused) {
  ips::health_t h = ips::test_support::sampleHealth();
  EXPECT_TRUE(ips::fw::validate(h, "HEALTH_TRACKER").ok());
  EXPECT_EQ(ips::fw::healthChannel("filter_ukf"), "HEALTH_FILTER_UKF");
  EXPECT_EQ(ips::fw::validate(h, "HEALTH_FILTER").reason, "bad_value");  // misdirected
  ips::health_t bad = h;
  bad.process = std::string("trac\xff\x01r");
  EXPECT_FALSE(ips::fw::validate(bad, "HEALTH_TRAC\xff\x01R").ok());
  bad = h;
  bad.process = "";
  EXPECT_FALSE(ips::fw::validate(bad, "HEALTH_").ok());
  bad = h;
  bad.dropped = -4;
  EXPECT_FALSE(ips::fw::validate(bad, "HEALTH_TRACKER").ok());
  bad = h;
  bad.latency_ms = std::nan("");
  EXPECT_EQ(ips::fw::validate(bad, "HEALTH_TRACKER").reason, "nan");
  bad = h;
  bad.counter_names[1] = "x y";
  EXPECT_FALSE(ips::fw::validate(bad, "HEALTH_TRACKER").ok());
}

TEST(HostileInput, GenuineClockStepIsFollowedAfterConfirmation) {
  ips::fw::StreamOrder::Limits limits;
  ips::fw::StreamOrder order(limits);
  int64_t t = 50'000'000;
  for (int i = 1; i <= 5; ++i) ASSERT_TRUE(order.check(t += 5'000, i).accept);
  // The source restarts at a much earlier time (a replay started again): the first confirm-1 messages are
  // rejected, then the new time line is adopted.
  int64_t t2 = 1'000'000;
  for (int i = 1; i < limits.confirm; ++i) EXPECT_FALSE(order.check(t2 += 5'000, i).accept) << i;
  auto step = order.check(t2 += 5'000, limits.confirm);
  EXPECT_TRUE(step.accept);
  EXPECT_TRUE(step.clock_step);
  EXPECT_EQ(step.gap, 0);
  EXPECT_TRUE(order.check(t2 += 5'000, limits.confirm + 1).accept);
}

TEST(HostileInput, SequenceJumpBeyondTheElapsedTimeIsAResetNotLostMessages) {
  ips::fw::Health health("t");
  ips::fw::StreamOrder order;
  EXPECT_TRUE(ips::fw::admitInOrder(order, 1'000'000, 1, health, "imu"));
  EXPECT_TRUE(ips::fw::admitInOrder(order, 1'005'000, std::numeric_limits<int64_t>::max() - 1, health, "imu"));
  EXPECT_TRUE(ips::fw::admitInOrder(order, 1'010'000, std::numeric_limits<int64_t>::min(), health, "imu"));
  EXPECT_EQ(health.droppedCount(), 0);
  EXPECT_EQ(health.counter("imu_seq_reset"), 2);
  // A plausible gap is still counted as lost messages.
  EXPECT_TRUE(ips::fw::admitInOrder(order, 1'030'000, std::numeric_limits<int64_t>::min() + 4, health, "imu"));
  EXPECT_EQ(health.droppedCount(), 3);
}

TEST(HostileInput, HealthCountersSaturate) {
  ips::fw::Health health("t");
  health.dropped("x", std::numeric_limits<int64_t>::max());
  health.dropped("x", 5);
  EXPECT_EQ(health.counter("x"), std::numeric_limits<int64_t>::max());
  EXPECT_EQ(health.droppedCount(), std::numeric_limits<int64_t>::max());
}

TEST(HostileInput, FilterStateWithNonFiniteCovarianceOrBiasIsRejected) {
  ips::filter_state_t m{};
  m.utime = 5;
  m.orientation[0] = 1;
  m.up[2] = 1;
  m.cov_dim = 2;
  m.covariance.assign(2, std::vector<double>(2, 0.0));
  EXPECT_TRUE(ips::fw::validate(m).ok());
  ips::filter_state_t nan_cov = m;
  nan_cov.covariance[1][0] = std::nan("");
  EXPECT_EQ(ips::fw::validate(nan_cov).reason, "nan");
  ips::filter_state_t inf_bias = m;
  inf_bias.gyro_bias[2] = INFINITY;
  EXPECT_EQ(ips::fw::validate(inf_bias).reason, "nan");
  ips::filter_state_t ragged = m;
  ragged.covariance[1].resize(1);
  EXPECT_EQ(ips::fw::validate(ragged).reason, "bad_size");
  // The frame is one of the two, its local vertical a unit vector.
  ips::filter_state_t start = m;
  start.frame = ips::filter_state_t::FRAME_START;
  start.up[0] = 0.6, start.up[2] = 0.8;
  EXPECT_TRUE(ips::fw::validate(start).ok());
  ips::filter_state_t no_frame = m;
  no_frame.frame = 7;
  EXPECT_EQ(ips::fw::validate(no_frame).reason, "bad_value");
  ips::filter_state_t no_up = m;
  no_up.up[2] = 0;
  EXPECT_EQ(ips::fw::validate(no_up).reason, "bad_value");
  // Finite values no navigation state can have.
  ips::filter_state_t zero_q = m;
  zero_q.orientation[0] = 0;
  EXPECT_EQ(ips::fw::validate(zero_q).reason, "bad_value");
  ips::filter_state_t far = m;
  far.position[0] = 1e308;
  EXPECT_EQ(ips::fw::validate(far).reason, "bad_value");
  ips::filter_state_t nan_up = m;
  nan_up.up[1] = std::nan("");
  EXPECT_EQ(ips::fw::validate(nan_up).reason, "bad_value");
  // The calibration estimates: named, as many values and sigmas as dimensions, finite.
  ips::filter_state_t with_estimate = m;
  with_estimate.calibration.push_back({"tilt_offset", "rad", 2, {0.001, -0.002}, {1e-4, 1e-4}});
  with_estimate.num_calibration = 1;
  EXPECT_TRUE(ips::fw::validate(with_estimate).ok());
  ips::filter_state_t short_sigma = with_estimate;
  short_sigma.calibration[0].sigma.resize(1);
  EXPECT_EQ(ips::fw::validate(short_sigma).reason, "bad_size");
  ips::filter_state_t unnamed = with_estimate;
  unnamed.calibration[0].name.clear();
  EXPECT_EQ(ips::fw::validate(unnamed).reason, "bad_size");
  ips::filter_state_t miscounted = with_estimate;
  miscounted.num_calibration = 2;
  EXPECT_EQ(ips::fw::validate(miscounted).reason, "bad_size");
  ips::filter_state_t nan_estimate = with_estimate;
  nan_estimate.calibration[0].sigma[1] = std::nan("");
  EXPECT_EQ(ips::fw::validate(nan_estimate).reason, "nan");
}

// A log of three IMU samples (LogWriter is LCM's own writer); returns its bytes.
std::vector<char> writeLog(const std::string& path) {
  {
    ips::fw::LogWriter log(path);
    for (int i = 0; i < 3; ++i) {
      ips::imu_sample_t m{};
      m.utime = 1000 + i;
      m.seq = i;
      log.write("IMU", m.utime, m);
    }
  }
  std::ifstream in(path, std::ios::binary);
  return std::vector<char>((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

int64_t readAll(const std::string& path) {
  ips::fw::LogReader reader(path);
  ips::fw::LogMessage m;
  while (reader.next(&m)) EXPECT_EQ(m.channel, "IMU");
  return reader.events();
}

TEST(HostileInput, DamagedLogsAreErrorsNotShortLogs) {
  const std::string path = testing::TempDir() + "/log_reader_" + std::to_string(::getpid()) + ".lcmlog";
  const std::vector<char> good = writeLog(path);
  EXPECT_EQ(readAll(path), 3);

  // Truncated in the middle of the last event (a full disk, a killed logger).
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(good.data(), static_cast<std::streamsize>(good.size() - 5));
  try {
    readAll(path);
    FAIL() << "a truncated log read as a whole one";
  } catch (const ips::fw::LogError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("after event 2"), std::string::npos) << e.what();
  }

  // Garbage between two events: LCM's reader resynchronises silently, LogReader does not.
  std::vector<char> corrupt(good.begin(), good.begin() + static_cast<long>(good.size() / 3));
  corrupt.insert(corrupt.end(), {'x', 'y', 'z'});
  corrupt.insert(corrupt.end(), good.begin() + static_cast<long>(good.size() / 3), good.end());
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(corrupt.data(), static_cast<std::streamsize>(corrupt.size()));
  EXPECT_THROW(readAll(path), ips::fw::LogError);

  EXPECT_THROW(ips::fw::LogReader("/nonexistent/run.lcmlog"), ips::fw::LogError);
  std::remove(path.c_str());
}

}  // namespace
