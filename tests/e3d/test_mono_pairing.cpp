// Which pairs give a map from one camera and when it is released, against a hand-worked sequence: pairs 2 apart,
// every 8th pair, navigation states every 10 ms.
#include <gtest/gtest.h>

#include "ips/e3d/mono_pairing.hpp"

namespace ips::e3d {
namespace {

constexpr int64_t kPairUs = 125000;  // 8 Hz
int64_t stamp(int64_t seq) { return 1000000 + seq * kPairUs; }

Pose stateAt(int64_t utime) {
  Pose p;
  p.utime = utime;
  p.T_world_body.translation() = Eigen::Vector3d(1e-6 * utime, 0, 0);  // 1 m/s along x
  return p;
}

TEST(MonoPairing, PairsGapApartAreReleasedOnceTheFilterHasPassedTheLaterOne) {
  MonoPairing pairing(2, 8);
  std::vector<int64_t> wanted;
  for (int64_t seq = 0; seq <= 17; ++seq) {
    if (!pairing.wants(seq)) continue;
    wanted.push_back(seq);
    const cv::Mat left(4, 4, CV_8U, cv::Scalar(static_cast<double>(seq)));
    EXPECT_EQ(pairing.addPair(seq, stamp(seq), left).dropped, 0);
  }
  EXPECT_EQ(wanted, (std::vector<int64_t>{0, 6, 8, 14, 16}));
  // Pair 0 has no earlier image; 8 (from 6) and 16 (from 14) wait.
  EXPECT_EQ(pairing.pending(), 2u);

  MonoPairing::Released released;
  for (int64_t t = stamp(5); t < stamp(8); t += 10000) {
    const MonoPairing::Released r = pairing.addPose(stateAt(t));
    EXPECT_TRUE(r.ready.empty()) << "released before the filter passed the later exposure";
  }
  for (int64_t t = stamp(8); released.ready.empty(); t += 10000) released = pairing.addPose(stateAt(t));
  ASSERT_EQ(released.ready.size(), 1u);
  const MonoJob& job = released.ready.front();
  EXPECT_EQ(job.seq_b, 8);
  EXPECT_EQ(job.utime_a, stamp(6));
  EXPECT_EQ(job.left_a.at<uint8_t>(0, 0), 6);
  EXPECT_EQ(job.left_b.at<uint8_t>(0, 0), 8);
  // Interpolated at the stamps (the states are 10 ms apart, the stamps between them).
  EXPECT_NEAR(job.pose_a.T_world_body.translation().x(), 1e-6 * stamp(6), 1e-9);
  EXPECT_NEAR(job.pose_b.T_world_body.translation().x(), 1e-6 * stamp(8), 1e-9);
  EXPECT_EQ(pairing.pending(), 1u);
}

TEST(MonoPairing, AFilterThatStalledOrNeverCameDropsMaps) {
  MonoPairing pairing(1, 2);
  // A state before the earlier exposure, then one after the later one 0.3 s on: a gap, no pose.
  pairing.addPose(stateAt(stamp(0)));
  pairing.addPair(1, stamp(1), cv::Mat());
  pairing.addPair(2, stamp(2), cv::Mat());
  const MonoPairing::Released r = pairing.addPose(stateAt(stamp(2) + 200000));
  EXPECT_TRUE(r.ready.empty());
  EXPECT_EQ(r.without_pose, 1);
  // With no filter at all, at most kMaxPending maps wait; each one more drops the oldest.
  int64_t dropped = 0;
  for (int64_t seq = 3; seq < 3 + 2 * static_cast<int64_t>(MonoPairing::kMaxPending + 3); ++seq)
    dropped += pairing.addPair(seq, stamp(seq), cv::Mat()).dropped;
  EXPECT_EQ(pairing.pending(), MonoPairing::kMaxPending);
  EXPECT_EQ(dropped, 3);
}

// The state that passes a map's later exposure may overtake that pair on the network (a small message beside a large
// one): the map then leaves with the pair, with the same poses as in the other order.
TEST(MonoPairing, AMapIsTheSameWhetherThePairOrThePassingStateComesFirst) {
  MonoPairing pair_first(2, 8), state_first(2, 8);
  for (MonoPairing* p : {&pair_first, &state_first}) p->addPair(6, stamp(6), cv::Mat(4, 4, CV_8U, cv::Scalar(6)));
  for (int64_t t = stamp(5); t < stamp(8); t += 10000) {
    pair_first.addPose(stateAt(t));
    state_first.addPose(stateAt(t));
  }
  const cv::Mat left8(4, 4, CV_8U, cv::Scalar(8));
  EXPECT_TRUE(pair_first.addPair(8, stamp(8), left8).ready.empty());
  const MonoPairing::Released a = pair_first.addPose(stateAt(stamp(8) + 5000));
  EXPECT_TRUE(state_first.addPose(stateAt(stamp(8) + 5000)).ready.empty());
  const MonoPairing::Released b = state_first.addPair(8, stamp(8), left8);
  ASSERT_EQ(a.ready.size(), 1u);
  ASSERT_EQ(b.ready.size(), 1u);
  EXPECT_EQ(b.ready[0].seq_b, 8);
  EXPECT_EQ(state_first.pending(), 0u);
  EXPECT_TRUE(a.ready[0].pose_a.T_world_body.isApprox(b.ready[0].pose_a.T_world_body));
  EXPECT_TRUE(a.ready[0].pose_b.T_world_body.isApprox(b.ready[0].pose_b.T_world_body));
  EXPECT_NEAR(b.ready[0].pose_b.T_world_body.translation().x(), 1e-6 * stamp(8), 1e-9);
}

}  // namespace
}  // namespace ips::e3d
