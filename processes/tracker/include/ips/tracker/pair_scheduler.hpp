#pragma once
// When a stereo pair goes on to the tracker. A pair waits for the motion prior of its image time (the filter's
// a-priori state when a filter has been seen, else gyro samples up to its time), and, with intra-matching from
// E3D's maps, for the DISPARITY map of its pair: live until wait_pairs newer pairs are pending, in replay (queue)
// until the map or a later one arrives. Which prior and which map a pair gets then depends on stamps, not on
// arrival, and a replay repeats the live run. Plain types only; the process converts messages.
#include <cstdint>
#include <map>
#include <opencv2/core.hpp>

#include "ips/config.hpp"
#include "ips/tracker/matching.hpp"
#include "ips/tracker/prior_builder.hpp"

namespace ips::tracker {

// Intra-matching from E3D's maps: which pairs wait for one, and how long.
struct DisparityWait {
  bool enabled = false;
  int every_nth = 1;     // E3D's process/every_nth: the pairs it matches
  int wait_pairs = 2;    // live: newer pairs pending before a pair goes on without its map
  bool queue = false;    // replay: wait until the map (or a later one) arrives, and drop no pair stale
  int max_pending = 64;  // the bound on pairs held in either mode (two images each)
  // Live: a pending pair this much older than the newest pending one is dropped unseen (the tracker fell behind).
  int64_t max_backlog_us = 1'000'000;
};

// process/intra_from_disparity, disparity_every_nth, disparity_wait_pairs, disparity_max_pending, max_backlog_s;
// queue from the command line. Throws ConfigError on a value out of range.
DisparityWait loadDisparityWait(const Config& cfg, bool queue);

// With a filter on the bus, its prior of this image time; else, with an IMU, gyro samples up to the image time (a
// pair can arrive before the IMU samples of its exposure: images take longer to transfer); else nothing to wait for.
bool priorReady(const PriorBuilder& priors, int64_t utime);

struct PendingPair {
  int64_t utime = 0;
  int64_t seq = 0;
  cv::Mat left, right;  // 8-bit copies (a message's buffer is gone after its handler)
};

class PairScheduler {
 public:
  explicit PairScheduler(const DisparityWait& wait) : wait_(wait) {}

  const DisparityWait& wait() const { return wait_; }
  // A pair E3D matches (seq % every_nth == 0) when maps are in use.
  bool expectsMap(int64_t seq) const { return wait_.enabled && seq % wait_.every_nth == 0; }

  void addPair(PendingPair p);
  bool empty() const { return pending_.empty(); }
  size_t size() const { return pending_.size(); }
  int64_t oldestUtime() const { return pending_.begin()->first; }

  // Whether a map of the pair with this stamp would be kept: not when that pair is tracked already or max_pending
  // maps are held (asked before a map is copied out of its message).
  bool acceptsMap(int64_t utime) const;
  // Keeps E3D's map of the pair with this stamp and seq; false (not kept) where acceptsMap is false.
  bool addMap(int64_t utime, int64_t seq, DisparityGuide guide);
  // Whether the oldest pair goes on now, given whether its prior is ready: when nothing more is awaited, or when
  // too many pairs are held behind it (one at most, unless it waits for a map).
  bool oldestGoesOn(bool prior_ready) const;
  PendingPair takeOldest();
  // Live (not queue): pending pairs more than max_backlog_us older than the newest pending one are dropped, so
  // that a tracker that fell behind catches up while its deltas can still reach the filter's image clones.
  // Returns how many. Replay (queue) drops none.
  int dropStale();
  // E3D's map of this pair (same stamp and seq), or nullptr.
  const DisparityGuide* mapFor(const PendingPair& p) const;
  // The pair with this stamp is tracked: its map and older ones are of no further use.
  void tracked(int64_t utime);
  int64_t lastTracked() const { return last_utime_; }

 private:
  struct StoredMap {
    int64_t seq = 0;
    DisparityGuide guide;
  };
  // Whether the oldest pending pair waits for a map that may still come.
  bool waitsForMap(const PendingPair& p) const;

  DisparityWait wait_;
  std::map<int64_t, PendingPair> pending_;  // by stamp
  std::map<int64_t, StoredMap> maps_;       // by the pair's stamp
  int64_t newest_map_utime_ = INT64_MIN;
  int64_t last_utime_ = 0;
};

}  // namespace ips::tracker
