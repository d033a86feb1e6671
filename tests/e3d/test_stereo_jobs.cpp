// Which STEREO pairs the E3D process matches and when: selection by sequence number, the newest pair live, a bounded
// queue in replay whose pairs wait for the tracker's INTEGRITY of the pair before them, and the process/ keys.
#include <gtest/gtest.h>

#include "ips/e3d/stereo_jobs.hpp"
#include "ips/test_support/temp_yaml.hpp"

using ips::test_support::writeTempYaml;

namespace {

using ips::e3d::StereoJob;
using ips::e3d::StereoJobQueue;

constexpr int64_t kPeriod = 125'000;  // 8 Hz

StereoJob job(int64_t seq) { return StereoJob{(seq + 1) * kPeriod, seq, seq * kPeriod, cv::Mat(), cv::Mat()}; }

TEST(StereoJobQueue, SelectsEveryNthPairBySequenceNumber) {
  const StereoJobQueue every(1, false, 16), fourth(4, false, 16);
  for (int64_t seq = 0; seq < 9; ++seq) {
    EXPECT_TRUE(every.selects(seq));
    EXPECT_EQ(fourth.selects(seq), seq % 4 == 0) << seq;
  }
}

TEST(StereoJobQueue, LiveTheNewestPairSupersedesThoseWaiting) {
  StereoJobQueue q(1, false, 16);
  EXPECT_EQ(q.push(job(0)).superseded, 0);
  const StereoJobQueue::Dropped d = q.push(job(1));
  EXPECT_EQ(d.superseded, 1);
  EXPECT_FALSE(d.queue_full);
  ASSERT_EQ(q.size(), 1u);
  q.integritySeen(kPeriod / 2);  // live, a pair never waits for INTEGRITY
  EXPECT_TRUE(q.frontReady());
  EXPECT_EQ(q.pop().seq, 1);
  EXPECT_TRUE(q.empty());
}

TEST(StereoJobQueue, ReplayKeepsMaxQueuePairsAndDropsTheOldest) {
  StereoJobQueue q(1, true, 3);
  for (int64_t seq = 0; seq < 3; ++seq) {
    const StereoJobQueue::Dropped d = q.push(job(seq));
    EXPECT_EQ(d.superseded, 0);
    EXPECT_FALSE(d.queue_full);
  }
  EXPECT_TRUE(q.push(job(3)).queue_full);
  ASSERT_EQ(q.size(), 3u);
  EXPECT_EQ(q.pop().seq, 1);
  EXPECT_EQ(q.pop().seq, 2);
  EXPECT_EQ(q.pop().seq, 3);
}

TEST(StereoJobQueue, ReplayAPairWaitsForTheIntegrityOfThePairBeforeIt) {
  StereoJobQueue q(1, true, 16);
  q.push(job(2));               // the pair before it has stamp 2 * kPeriod
  EXPECT_TRUE(q.frontReady());  // no tracker has sent INTEGRITY: nothing to wait for
  q.integritySeen(kPeriod);
  EXPECT_FALSE(q.frontReady());
  q.integritySeen(2 * kPeriod);
  EXPECT_TRUE(q.frontReady());
  q.integritySeen(kPeriod);  // an older one later changes nothing
  EXPECT_TRUE(q.frontReady());
}

TEST(E3dProcessParams, ConfigKeysWithTheCommandLineOverAndRangesChecked) {
  const ips::Config cfg(
      writeTempYaml("e3d_process.yaml", "process:\n  output_scale: 0.5\n  every_nth: 3\n  max_queue: 4\n"));
  ips::e3d::ProcessParams p = ips::e3d::loadProcessParams(cfg, std::nullopt, false);
  EXPECT_EQ(p.output_scale, 0.5);
  EXPECT_EQ(p.every_nth, 3);
  EXPECT_FALSE(p.queue_all);
  EXPECT_EQ(p.max_queue, 4u);
  EXPECT_TRUE(p.apply_integrity);  // the default
  EXPECT_FALSE(
      ips::e3d::loadProcessParams(
          ips::Config(writeTempYaml("e3d_no_integrity.yaml", "process:\n  apply_integrity: 0\n")), std::nullopt, false)
          .apply_integrity);
  p = ips::e3d::loadProcessParams(cfg, 8, true);
  EXPECT_EQ(p.every_nth, 8);
  EXPECT_TRUE(p.queue_all);
  EXPECT_THROW(ips::e3d::loadProcessParams(cfg, 0, false), ips::ConfigError);
  EXPECT_THROW(ips::e3d::loadProcessParams(cfg, 1LL << 40, false), ips::ConfigError);
  for (const char* bad : {"output_scale: 0", "output_scale: 1.5", "max_queue: 0", "max_queue: 257", "every_nth: -2"})
    EXPECT_THROW(
        ips::e3d::loadProcessParams(
            ips::Config(writeTempYaml("e3d_bad.yaml", std::string("process:\n  ") + bad + "\n")), std::nullopt, false),
        ips::ConfigError)
        << bad;
  const ips::e3d::ProcessParams def =
      ips::e3d::loadProcessParams(ips::Config(writeTempYaml("e3d_empty.yaml", "other: 1\n")), std::nullopt, false);
  EXPECT_EQ(def.every_nth, 1);
  EXPECT_EQ(def.max_queue, 16u);
  EXPECT_EQ(def.output_scale, 1.0);
}

}  // namespace
