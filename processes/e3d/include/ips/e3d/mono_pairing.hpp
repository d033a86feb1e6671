#pragma once
// Which stereo pairs give a map from one camera, and when it can be made: the left image of the pair gap_pairs
// before each selected pair (seq a multiple of every_nth) is kept, and the map waits until the navigation states
// have passed its later exposure; it then leaves with the poses at both stamps. Every decision follows from stamps
// and sequence numbers, so a replay repeats it. No LCM: the E3D process feeds it pairs and filter states.
#include <cstdint>
#include <deque>
#include <map>
#include <opencv2/core.hpp>
#include <utility>
#include <vector>

#include "ips/pose_buffer.hpp"

namespace ips::e3d {

// A map from one camera: the left images of two pairs and, once released, the body poses at their stamps.
struct MonoJob {
  int64_t utime_a = 0, utime_b = 0, seq_b = 0;
  cv::Mat left_a, left_b;
  Pose pose_a, pose_b;
};

class MonoPairing {
 public:
  // The navigation states come at IMU rate: neighbours further apart than this mean the filter stalled.
  static constexpr double kPoseMaxGapS = 0.1;
  // States kept: enough for the maps still waiting.
  static constexpr double kPoseKeepS = 30.0;
  // Maps waiting for the filter: beyond this many (one per every_nth pairs, over 40 s at 8 Hz and every 48th) the
  // filter is not there, and the oldest goes.
  static constexpr size_t kMaxPending = 8;

  MonoPairing(int gap_pairs, int every_nth);

  // Whether a pair's left image is needed, as the earlier or the later exposure of a map.
  bool wants(int64_t seq) const;
  struct Released {
    std::vector<MonoJob> ready;  // with both poses
    int64_t without_pose = 0;    // the filter has passed them, but has no state at one of the two stamps
    int64_t dropped = 0;         // waiting maps dropped to make room (kMaxPending)
  };
  // A pair's left image (the caller's copy is kept). A map whose later exposure the states have already passed
  // leaves at once: the pair and the state that passes it may come in either order (a small state overtakes a large
  // pair on the network), and the map must not depend on which came first.
  Released addPair(int64_t seq, int64_t utime, const cv::Mat& left);
  // A navigation state (in time order). Releases the maps whose later exposure it has reached.
  Released addPose(const Pose& pose);

  // Maps still waiting for the filter.
  size_t pending() const { return pending_.size(); }

 private:
  // The waiting maps whose later exposure the newest state has reached, with their poses.
  Released release();
  int gap_pairs_, every_nth_;
  std::map<int64_t, std::pair<int64_t, cv::Mat>> earlier_;  // by the seq of the pair it is for: stamp, left image
  std::deque<MonoJob> pending_;
  PoseBuffer poses_;
};

}  // namespace ips::e3d
