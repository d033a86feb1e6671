// The framework's handling of bad input: undecodable bytes, impossible sizes, NaN, time going backwards and
// sequence gaps are counted by kind, and the good messages around them still get through.
#include <gtest/gtest.h>

#include <cmath>
#include <ips/imu_sample_t.hpp>
#include <ips/stereo_pair_t.hpp>

#include "ips/framework/image.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/validate.hpp"

namespace {

ips::imu_sample_t imu(int64_t utime, int64_t seq) {
  ips::imu_sample_t m{};
  m.utime = utime;
  m.seq = seq;
  m.specific_force[2] = 9.81;
  return m;
}

TEST(Framework, UndecodableMessagesAreCountedAndSkipped) {
  ips::fw::Node node("t", "memq://");
  int good = 0;
  node.subscribe<ips::imu_sample_t>("IMU", [&](const ips::imu_sample_t&) { ++good; });
  const char junk[] = "garbage bytes";
  node.lcm().publish("IMU", junk, sizeof(junk));
  node.publish("IMU", imu(1, 1));
  // A message of another type on the channel: its fingerprint differs, so it must not decode either.
  ips::stereo_pair_t other =
      ips::fw::makeStereoPair(1, 1, cv::Mat(2, 2, CV_8UC1, cv::Scalar(1)), cv::Mat(2, 2, CV_8UC1, cv::Scalar(2)));
  node.publish("IMU", other);
  node.publish("IMU", imu(2, 2));
  for (int i = 0; i < 4; ++i) node.handleOnce(10);
  EXPECT_EQ(good, 2);
  EXPECT_EQ(node.health().counter("decode_error"), 2);
  EXPECT_EQ(node.health().badCount(), 2);
}

TEST(Framework, HandlerExceptionsAreCountedNotFatal) {
  ips::fw::Node node("t", "memq://");
  int calls = 0;
  node.subscribe<ips::imu_sample_t>("IMU", [&](const ips::imu_sample_t& m) {
    ++calls;
    if (m.seq == 1) throw std::runtime_error("boom");
  });
  node.publish("IMU", imu(1, 1));
  node.publish("IMU", imu(2, 2));
  node.handleOnce(10);
  node.handleOnce(10);
  EXPECT_EQ(calls, 2);
  EXPECT_EQ(node.health().counter("handler_error"), 1);
}

TEST(Framework, ValidateStereoSizes) {
  cv::Mat a(4, 6, CV_8UC1, cv::Scalar(3));
  ips::stereo_pair_t m = ips::fw::makeStereoPair(10, 1, a, a);
  EXPECT_TRUE(ips::fw::validate(m).ok());
  ips::stereo_pair_t short_data = m;
  short_data.right.pop_back();
  EXPECT_EQ(ips::fw::validate(short_data).reason, "bad_size");
  ips::stereo_pair_t huge = m;
  huge.width = 100000;
  EXPECT_EQ(ips::fw::validate(huge).reason, "bad_size");
  ips::stereo_pair_t negative = m;
  negative.height = -4;
  EXPECT_EQ(ips::fw::validate(negative).reason, "bad_size");
  ips::stereo_pair_t stride = m;
  stride.stride = 3;
  EXPECT_EQ(ips::fw::validate(stride).reason, "bad_size");
  ips::stereo_pair_t format = m;
  format.pixel_format = 9;
  EXPECT_EQ(ips::fw::validate(format).reason, "bad_format");
}

TEST(Framework, ValidateNanAndRanges) {
  ips::imu_sample_t m = imu(1, 1);
  EXPECT_TRUE(ips::fw::validate(m).ok());
  m.angular_rate[1] = std::nan("");
  EXPECT_EQ(ips::fw::validate(m).reason, "nan");
  m = imu(1, 1);
  m.specific_force[0] = INFINITY;
  EXPECT_EQ(ips::fw::validate(m).reason, "nan");
  m = imu(1, 1);
  m.angular_rate[0] = 1e6;
  EXPECT_EQ(ips::fw::validate(m).reason, "bad_value");

  ips::tracker_delta_t d{};
  d.utime = 2;
  d.utime_prev = 1;
  d.valid = true;
  d.rotation[0] = 1;
  for (int i = 0; i < 6; ++i) d.covariance[i * 7] = 1;
  EXPECT_TRUE(ips::fw::validate(d).ok());
  d.rotation[0] = 0.5;
  EXPECT_EQ(ips::fw::validate(d).reason, "bad_value");
  d.rotation[0] = 1;
  d.translation[2] = std::nan("");
  EXPECT_EQ(ips::fw::validate(d).reason, "nan");
  d.utime_prev = 3;
  EXPECT_EQ(ips::fw::validate(d).reason, "bad_time");
}

TEST(Framework, ValidateIntegrity) {
  ips::integrity_t m{};
  m.utime = 2000;
  m.state = ips::integrity_t::STATE_OK;
  m.applied[0] = 0.2 * M_PI / 180;  // a knock's correction
  m.applied_utime = 1000;
  EXPECT_TRUE(ips::fw::validate(m).ok());
  m.state = 7;
  EXPECT_EQ(ips::fw::validate(m).reason, "bad_value");
  m.state = ips::integrity_t::STATE_ALARM;
  m.correction_covariance[5] = std::nan("");
  EXPECT_EQ(ips::fw::validate(m).reason, "nan");
  m.correction_covariance[5] = 0;
  m.applied[2] = 10 * M_PI / 180;  // no head is corrected by 10 deg: corrupt
  EXPECT_EQ(ips::fw::validate(m).reason, "bad_value");
  m.applied[2] = 0;
  m.applied[3] = 0.5;
  EXPECT_EQ(ips::fw::validate(m).reason, "bad_value");
  m.applied[3] = 0;
  m.applied_utime = 3000;  // decided after its own pair
  EXPECT_EQ(ips::fw::validate(m).reason, "bad_time");
  m.applied_utime = 1000;
  m.disparity_offset_px = -0.4f;  // a principal point a few tenths of a pixel off
  m.disparity_offset_utime = 1500;
  EXPECT_TRUE(ips::fw::validate(m).ok());
  m.disparity_offset_px = 35.0f;
  EXPECT_EQ(ips::fw::validate(m).reason, "bad_value");
  m.disparity_offset_px = std::nanf("");
  EXPECT_EQ(ips::fw::validate(m).reason, "bad_value");
  m.disparity_offset_px = 0.3f;
  m.disparity_offset_utime = 2500;
  EXPECT_EQ(ips::fw::validate(m).reason, "bad_time");
}

TEST(Framework, StreamOrderCountsGapsAndRejectsBackwards) {
  ips::fw::StreamOrder order;
  EXPECT_TRUE(order.check(100, 1).accept);
  auto r = order.check(200, 4);  // 2 and 3 lost
  EXPECT_TRUE(r.accept);
  EXPECT_EQ(r.gap, 2);
  EXPECT_FALSE(order.check(150, 5).accept);  // earlier than 200
  EXPECT_FALSE(order.check(200, 5).accept);  // repeated stamp
  EXPECT_TRUE(order.check(300, 5).accept);   // the stream goes on after the rejected ones
  EXPECT_EQ(order.lastUtime(), 300);
}

TEST(Framework, StreamOrderLeavesAForgedFirstStampBehind) {
  // No check can judge a stream's first stamp alone: forged an hour ahead, it is accepted, but the real stream that
  // follows far behind it starts its line again at once instead of being refused as going backwards.
  ips::fw::StreamOrder order;
  EXPECT_TRUE(order.check(3'600'000'000 + 1'000'000, 7).accept);
  const auto r = order.check(1'000'000, 1);
  EXPECT_TRUE(r.accept);
  EXPECT_TRUE(r.rebased);
  for (int i = 2; i < 10; ++i) EXPECT_TRUE(order.check(1'000'000 + i * 5'000, i).accept) << i;
  // A confirmed line is not left for one stamp far off, ahead or behind.
  EXPECT_FALSE(order.check(3'700'000'000, 100).accept);
  EXPECT_FALSE(order.check(100, 101).accept);
  EXPECT_TRUE(order.check(1'050'000, 10).accept);
}

// The health stamp is the newest accepted input's: a refused stamp far ahead leaves it; a stream started again at its
// real stamps brings it down from a forged first one.
TEST(Framework, HealthStampFollowsAcceptedInputsOnly) {
  ips::fw::Health h("filter");
  h.received(1000);
  h.accepted();
  h.received(9'000'000'000'000'000);
  h.bad("time_ahead_of_host", "forged");
  EXPECT_EQ(h.report(1.0).utime, 1000);
  h.received(2000);
  h.accepted();
  EXPECT_EQ(h.report(1.0).utime, 2000);

  ips::fw::Health fresh("tracker");
  ips::fw::StreamOrder order;
  fresh.received(9'000'000'000'000'000);
  ASSERT_TRUE(ips::fw::admitInOrder(order, 9'000'000'000'000'000, 0, fresh, "stereo"));
  fresh.accepted();
  EXPECT_EQ(fresh.report(1.0).utime, 9'000'000'000'000'000);
  // Real pairs until the stream leaves the forged first stamp behind.
  int64_t t = 1'000'000;
  for (int i = 1; i < 40 && fresh.counter("stereo_time_rebased") == 0; ++i, t += 50'000) {
    fresh.received(t);
    if (ips::fw::admitInOrder(order, t, i, fresh, "stereo")) fresh.accepted();
  }
  ASSERT_EQ(fresh.counter("stereo_time_rebased"), 1);
  EXPECT_LT(fresh.report(1.0).utime, t);
  EXPECT_GE(fresh.report(1.0).utime, 1'000'000);
}

TEST(Framework, HealthReportsRatesAndCounters) {
  ips::fw::Health h("tracker");
  for (int i = 0; i < 10; ++i) {
    h.received(1000 + i);
    h.accepted();
    h.latency(2.0 + i % 2);
  }
  for (int i = 0; i < 4; ++i) h.published();
  h.dropped("superseded", 3);
  h.bad("nan", "test");
  h.queueLength(2);
  ips::health_t m = h.report(2.0);
  EXPECT_EQ(m.process, "tracker");
  EXPECT_EQ(m.utime, 1009);
  EXPECT_DOUBLE_EQ(m.input_rate_hz, 5.0);
  EXPECT_DOUBLE_EQ(m.output_rate_hz, 2.0);
  EXPECT_DOUBLE_EQ(m.latency_ms, 2.5);
  EXPECT_EQ(m.dropped, 3);
  EXPECT_EQ(m.bad, 1);
  EXPECT_EQ(m.queue_length, 2);
  ASSERT_EQ(m.num_counters, 2);
  EXPECT_EQ(m.counter_names[0], "nan");
  EXPECT_EQ(m.counter_values[1], 3);
  // Rates are per interval; totals are not reset.
  ips::health_t next = h.report(1.0);
  EXPECT_DOUBLE_EQ(next.input_rate_hz, 0.0);
  EXPECT_EQ(next.received, 10);
}

TEST(Framework, HealthCounterNamesAlwaysPassTheValidator) {
  // A stream named with a space ("cloud delta") once made counters such as "cloud delta_clock_step": from the
  // first such event on every health message of the filter was refused by its consumers, and the report said
  // the filter had stopped.
  ips::fw::Health h("filter");
  h.count("cloud delta_clock_step");
  h.dropped("seq gap/stereo", 2);
  h.bad("", "a reason nobody named");
  h.set(std::string(80, 'x'), 7);
  h.count("cloud delta_clock_step");
  const ips::health_t m = h.report(1.0);
  EXPECT_TRUE(ips::fw::validate(m, "HEALTH_FILTER").ok()) << ips::fw::validate(m, "HEALTH_FILTER").detail;
  EXPECT_EQ(h.counter("cloud_delta_clock_step"), 2);
  EXPECT_EQ(h.counter("cloud delta_clock_step"), 2);  // the caller's name finds the same counter
  EXPECT_EQ(h.counter("seq_gap_stereo"), 2);
  EXPECT_EQ(h.counter("unnamed"), 1);
  EXPECT_EQ(h.counter(std::string(64, 'x')), 7);
  EXPECT_EQ(m.num_counters, 4);
}

TEST(Framework, HealthMessageIsPublishedOnItsChannel) {
  ips::fw::Node node("my_proc", "memq://");
  int seen = 0;
  node.subscribe<ips::health_t>("HEALTH_MY_PROC", [&](const ips::health_t& h) {
    EXPECT_EQ(h.process, "my_proc");
    ++seen;
  });
  node.publishHealth(1.0);
  node.handleOnce(10);
  EXPECT_EQ(seen, 1);
}

}  // namespace
