// When a stereo pair goes on to the tracker: the wait for its motion prior (filter, else gyro), for E3D's map of
// the pair (live: a bounded number of newer pairs; replay: until the map or a later one), and which map it gets.
#include <gtest/gtest.h>

#include "ips/test_support/temp_yaml.hpp"
#include "ips/tracker/pair_scheduler.hpp"

using ips::test_support::writeTempYaml;

namespace {

using ips::tracker::DisparityGuide;
using ips::tracker::DisparityWait;
using ips::tracker::PairScheduler;
using ips::tracker::PendingPair;

constexpr int64_t kPeriod = 125'000;  // 8 Hz

PendingPair pair(int64_t seq) { return PendingPair{(seq + 1) * kPeriod, seq, cv::Mat(), cv::Mat()}; }

DisparityGuide guide(double scale) {
  DisparityGuide g;
  g.scale = scale;
  return g;
}

DisparityWait maps(int every_nth, int wait_pairs, bool queue, int max_pending = 64) {
  DisparityWait w;
  w.enabled = true;
  w.every_nth = every_nth;
  w.wait_pairs = wait_pairs;
  w.queue = queue;
  w.max_pending = max_pending;
  return w;
}

TEST(PairScheduler, WithoutMapsAPairWaitsForItsPriorButHoldsNoSecondOneBack) {
  PairScheduler s{DisparityWait{}};
  s.addPair(pair(0));
  EXPECT_FALSE(s.oldestGoesOn(false));
  EXPECT_TRUE(s.oldestGoesOn(true));
  s.addPair(pair(1));
  EXPECT_TRUE(s.oldestGoesOn(false));  // two pending: the oldest goes on with the fallback prior
  EXPECT_EQ(s.takeOldest().seq, 0);
  EXPECT_EQ(s.oldestUtime(), 2 * kPeriod);
  EXPECT_FALSE(s.expectsMap(0));
}

TEST(PairScheduler, LiveAPairE3DMatchesWaitsForWaitPairsNewerPairsAtMost) {
  PairScheduler s{maps(2, 2, false)};
  EXPECT_TRUE(s.expectsMap(0));
  EXPECT_FALSE(s.expectsMap(1));
  s.addPair(pair(0));
  EXPECT_FALSE(s.oldestGoesOn(true));  // prior ready, map not yet
  s.addPair(pair(1));
  s.addPair(pair(2));
  EXPECT_FALSE(s.oldestGoesOn(true));  // 3 pending = 1 + wait_pairs
  s.addPair(pair(3));
  EXPECT_TRUE(s.oldestGoesOn(false));  // a fourth: it goes on without map (and prior)
  const PendingPair p = s.takeOldest();
  EXPECT_EQ(s.mapFor(p), nullptr);
  // Seq 1, which E3D does not match, waits for nothing but its prior, and for that only while no newer pair is held.
  EXPECT_TRUE(s.oldestGoesOn(false));
  s.takeOldest();
  s.takeOldest();
  EXPECT_FALSE(s.oldestGoesOn(false));  // seq 3 alone
  EXPECT_TRUE(s.oldestGoesOn(true));
}

TEST(PairScheduler, TheMapOfThePairEndsItsWaitAndIsTheOneItGets) {
  PairScheduler s{maps(1, 2, false)};
  s.addPair(pair(0));
  EXPECT_FALSE(s.oldestGoesOn(true));
  EXPECT_TRUE(s.addMap(pair(0).utime, 0, guide(0.5)));
  EXPECT_FALSE(s.oldestGoesOn(false));  // the map is there, the prior not yet
  EXPECT_TRUE(s.oldestGoesOn(true));
  const PendingPair p = s.takeOldest();
  ASSERT_NE(s.mapFor(p), nullptr);
  EXPECT_EQ(s.mapFor(p)->scale, 0.5);
  // A map with the pair's stamp but another seq belongs to another pair.
  EXPECT_EQ(s.mapFor(PendingPair{p.utime, 7, cv::Mat(), cv::Mat()}), nullptr);
}

TEST(PairScheduler, ALaterMapMeansE3DSkippedThePair) {
  PairScheduler s{maps(1, 2, true)};
  s.addPair(pair(0));
  s.addPair(pair(1));
  EXPECT_FALSE(s.oldestGoesOn(true));
  EXPECT_TRUE(s.addMap(pair(1).utime, 1, guide(1.0)));
  EXPECT_TRUE(s.oldestGoesOn(true));
  EXPECT_EQ(s.mapFor(s.takeOldest()), nullptr);
}

TEST(PairScheduler, ReplayHoldsMaxPendingPairsForTheMap) {
  const int max_pending = 5;
  PairScheduler s{maps(1, 0, true, max_pending)};
  for (int seq = 0; seq < max_pending; ++seq) {
    s.addPair(pair(seq));
    EXPECT_FALSE(s.oldestGoesOn(true)) << seq;
  }
  s.addPair(pair(max_pending));
  EXPECT_TRUE(s.oldestGoesOn(false));
}

TEST(PairScheduler, MapsOfTrackedPairsAndBeyondTheBoundAreNotKept) {
  PairScheduler s{maps(1, 2, false, 3)};
  EXPECT_EQ(s.lastTracked(), 0);
  s.tracked(pair(0).utime);
  EXPECT_EQ(s.lastTracked(), pair(0).utime);
  EXPECT_FALSE(s.acceptsMap(pair(0).utime));  // its pair is tracked
  EXPECT_FALSE(s.addMap(pair(0).utime, 0, guide(1.0)));
  for (int seq = 1; seq <= 3; ++seq) EXPECT_TRUE(s.addMap(pair(seq).utime, seq, guide(1.0)));
  EXPECT_FALSE(s.acceptsMap(pair(4).utime));  // 3 held already
  EXPECT_FALSE(s.addMap(pair(4).utime, 4, guide(1.0)));
  // Tracking pair 2 drops its map and the older one: room for two more.
  s.tracked(pair(2).utime);
  EXPECT_TRUE(s.acceptsMap(pair(4).utime));
  EXPECT_EQ(s.mapFor(pair(1)), nullptr);
  EXPECT_EQ(s.mapFor(pair(2)), nullptr);
  EXPECT_NE(s.mapFor(pair(3)), nullptr);
  EXPECT_TRUE(s.addMap(pair(4).utime, 4, guide(1.0)));
  EXPECT_TRUE(s.addMap(pair(5).utime, 5, guide(1.0)));
  EXPECT_FALSE(s.addMap(pair(6).utime, 6, guide(1.0)));
}

TEST(PairScheduler, LiveABacklogBeyondMaxBacklogIsDroppedReplayKeepsIt) {
  // A tracker that read a burst of twelve pairs (1.5 s at 8 Hz: it was behind the camera) keeps those within
  // max_backlog_us (1 s) of the newest: the 9 newest, the oldest of which goes on first as always.
  DisparityWait no_maps;
  no_maps.max_backlog_us = 1'000'000;
  PairScheduler live{no_maps};
  for (int64_t seq = 0; seq < 12; ++seq) live.addPair(pair(seq));
  EXPECT_EQ(live.dropStale(), 3);
  ASSERT_EQ(live.size(), 9u);
  EXPECT_EQ(live.oldestUtime(), pair(3).utime);
  EXPECT_EQ(live.dropStale(), 0);
  // A backlog within the bound is worked through as it is (a replay on a busy machine repeats itself).
  PairScheduler short_backlog{no_maps};
  for (int64_t seq = 0; seq < 5; ++seq) short_backlog.addPair(pair(seq));
  EXPECT_EQ(short_backlog.dropStale(), 0);
  // Replay waits for every map and drops nothing.
  DisparityWait replay_wait = maps(2, 2, true);
  replay_wait.max_backlog_us = 1'000'000;
  PairScheduler replay{replay_wait};
  for (int64_t seq = 0; seq < 12; ++seq) replay.addPair(pair(seq));
  EXPECT_EQ(replay.dropStale(), 0);
  EXPECT_EQ(replay.size(), 12u);
}

TEST(PairScheduler, APairOfTheSameStampIsKeptOnce) {
  PairScheduler s{DisparityWait{}};
  s.addPair(pair(0));
  s.addPair(PendingPair{pair(0).utime, 9, cv::Mat(), cv::Mat()});
  EXPECT_EQ(s.size(), 1u);
  EXPECT_EQ(s.takeOldest().seq, 0);
  EXPECT_TRUE(s.empty());
}

TEST(PriorReady, TheFilterPriorOfTheImageTimeElseGyroUpToItElseNothingToWaitFor) {
  ips::tracker::PriorBuilder b(Eigen::Isometry3d::Identity(), ips::tracker::PriorBuilderParams{},
                               ips::tracker::PriorParams{});
  EXPECT_TRUE(ips::tracker::priorReady(b, 1'000'000));  // neither IMU nor filter on the bus
  b.addGyro(900'000, Eigen::Vector3d::Zero());
  EXPECT_FALSE(ips::tracker::priorReady(b, 1'000'000));
  b.addGyro(1'000'000, Eigen::Vector3d::Zero());
  EXPECT_TRUE(ips::tracker::priorReady(b, 1'000'000));
  ips::tracker::FilterPriorState st;
  st.utime = 875'000;
  b.addFilterState(st);  // from now on only the filter's prior of the image time counts
  EXPECT_FALSE(ips::tracker::priorReady(b, 1'000'000));
  st.utime = 1'000'000;
  b.addFilterState(st);
  EXPECT_TRUE(ips::tracker::priorReady(b, 1'000'000));
}

TEST(PriorReady, TheFiltersAnswerThatItHasNoPriorLetsThePairGoOnWithTheGyroOnceItCoversThePair) {
  ips::tracker::PriorBuilder b(Eigen::Isometry3d::Identity(), ips::tracker::PriorBuilderParams{},
                               ips::tracker::PriorParams{});
  b.addGyro(900'000, Eigen::Vector3d::Zero());
  b.addFilterNone(1'000'000);  // the filter has not started: it says so for this image time
  EXPECT_TRUE(b.filterSeen());
  EXPECT_FALSE(ips::tracker::priorReady(b, 1'000'000));  // the gyro does not reach the pair yet
  b.addGyro(1'000'000, Eigen::Vector3d::Zero());
  EXPECT_TRUE(ips::tracker::priorReady(b, 1'000'000));
  // The next pair waits for the filter's answer to it, though the gyro covers it already.
  b.addGyro(1'100'000, Eigen::Vector3d::Zero());
  EXPECT_FALSE(ips::tracker::priorReady(b, 1'050'000));
  b.addFilterNone(1'050'000);
  EXPECT_TRUE(ips::tracker::priorReady(b, 1'050'000));
  EXPECT_FALSE(b.fromFilter(1'000'000, 1'050'000).has_value());
}

TEST(LoadDisparityWait, ReadsTheProcessKeysAndRefusesValuesOutOfRange) {
  const DisparityWait w = ips::tracker::loadDisparityWait(
      ips::Config(writeTempYaml(
          "wait.yaml", "process:\n  intra_from_disparity: 1\n  disparity_every_nth: 3\n  max_backlog_s: 0.5\n")),
      true);
  EXPECT_TRUE(w.enabled);
  EXPECT_EQ(w.every_nth, 3);
  EXPECT_EQ(w.wait_pairs, 2);
  EXPECT_EQ(w.max_pending, 64);
  EXPECT_EQ(w.max_backlog_us, 500'000);
  EXPECT_TRUE(w.queue);
  for (const char* bad :
       {"disparity_every_nth: 0", "disparity_wait_pairs: -1", "disparity_max_pending: 1", "max_backlog_s: 0"})
    EXPECT_THROW(ips::tracker::loadDisparityWait(
                     ips::Config(writeTempYaml("wait_bad.yaml", std::string("process:\n  ") + bad + "\n")), false),
                 ips::ConfigError)
        << bad;
}

TEST(LoadPriorBuilderParams, ReadsTheProcessKeysAndRefusesValuesOutOfRange) {
  const ips::tracker::PriorBuilderParams p = ips::tracker::loadPriorBuilderParams(
      ips::Config(writeTempYaml("prior.yaml", "process:\n  max_filter_priors: 8\n  gyro_window_s: 2.5\n")));
  EXPECT_EQ(p.max_filter_states, 8);
  EXPECT_EQ(p.gyro_window_s, 2.5);
  EXPECT_EQ(p.gyro_rate_sigma, ips::tracker::PriorBuilderParams{}.gyro_rate_sigma);
  for (const char* bad : {"gyro_rate_sigma: 0", "filter_prior_rotation_floor: -1", "max_filter_priors: 1"})
    EXPECT_THROW(ips::tracker::loadPriorBuilderParams(
                     ips::Config(writeTempYaml("prior_bad.yaml", std::string("process:\n  ") + bad + "\n"))),
                 ips::ConfigError)
        << bad;
}

}  // namespace
