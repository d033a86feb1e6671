#pragma once
// Which STEREO pairs the E3D process matches, and when. A pair is selected when seq % every_nth == 0. Live, only the
// newest selected pair waits (a newer one supersedes it); for replay (queue_all) every selected pair is kept, up to
// max_queue, and waits for the tracker's INTEGRITY of the pair before it once a tracker has sent any: which
// correction a pair is matched with then depends on stamps, not on which process was faster, and a replay repeats
// the live run. No LCM and no locking: the process converts messages and guards the queue.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <opencv2/core.hpp>
#include <optional>

#include "ips/config.hpp"

namespace ips::e3d {

// A full-size pair is about 2.8 MB: 256 queued pairs is already 700 MB, more than a deployment wants held.
constexpr long long kMaxQueueLimit = 256;

struct ProcessParams {
  double output_scale = 1.0;    // process/output_scale, in (0, 1]: the maps' size over the calibration's
  int every_nth = 1;            // process/every_nth (or --every-nth), at least 1
  bool queue_all = false;       // process/queue_all (or --queue)
  size_t max_queue = 16;        // process/max_queue, in [1, kMaxQueueLimit]
  bool apply_integrity = true;  // process/apply_integrity: rectify with the tracker's correction and disparity offset
                                // (INTEGRITY)
};

// The process/ keys, every_nth and queue_all overridden by the command line where given. Throws ConfigError on a
// value out of range.
ProcessParams loadProcessParams(const Config& cfg, std::optional<long long> every_nth, bool queue);

struct StereoJob {
  int64_t utime = 0;
  int64_t seq = 0;
  int64_t prev_utime = 0;  // the stamp of the STEREO pair before this one (selected or not)
  cv::Mat left, right;     // raw 8-bit copies
};

class StereoJobQueue {
 public:
  StereoJobQueue(int every_nth, bool queue_all, size_t max_queue)
      : every_nth_(every_nth), queue_all_(queue_all), max_queue_(max_queue) {}

  bool selects(int64_t seq) const { return every_nth_ <= 1 || seq % every_nth_ == 0; }

  // What a push dropped: live, the pairs still waiting (superseded); in replay, the oldest when the queue was full.
  struct Dropped {
    int64_t superseded = 0;
    bool queue_full = false;
  };
  Dropped push(StereoJob job);

  // The pair of the newest INTEGRITY message the tracker sent.
  void integritySeen(int64_t utime) { integrity_seen_utime_ = std::max(integrity_seen_utime_, utime); }
  // Whether the oldest pair has what it waits for (live: nothing; replay: the INTEGRITY of the pair before it).
  bool frontReady() const;

  bool empty() const { return jobs_.empty(); }
  size_t size() const { return jobs_.size(); }
  StereoJob pop();
  void clear() { jobs_.clear(); }

 private:
  int every_nth_;
  bool queue_all_;
  size_t max_queue_;
  std::deque<StereoJob> jobs_;
  int64_t integrity_seen_utime_ = 0;
};

}  // namespace ips::e3d
