#include "ips/e3d/stereo_jobs.hpp"

#include <limits>
#include <string>

namespace ips::e3d {

ProcessParams loadProcessParams(const Config& cfg, std::optional<long long> every_nth, bool queue) {
  ProcessParams p;
  p.output_scale = cfg.getDouble("process/output_scale", 1.0);
  if (!(p.output_scale > 0 && p.output_scale <= 1))
    throw ConfigError(cfg.path() + ": key 'process/output_scale' must be in (0, 1]");
  // The file's values are read (and so known) even where the command line overrides them.
  const long long file_every_nth = cfg.getInt("process/every_nth", 1);
  const long long every_nth_value = every_nth ? *every_nth : file_every_nth;
  // A pair is selected when seq % N == 0: N below 1 selects nothing (or divides by zero).
  if (every_nth_value < 1 || every_nth_value > std::numeric_limits<int>::max())
    throw ConfigError(cfg.path() + ": 'process/every_nth' (or --every-nth) must be at least 1, got " +
                      std::to_string(every_nth_value));
  p.every_nth = static_cast<int>(every_nth_value);
  p.queue_all = cfg.getBool("process/queue_all", false) || queue;
  // The queue holds decoded pairs (two full images each): at least one, and bounded so memory stays flat.
  const long long max_queue_value = cfg.getInt("process/max_queue", 16);
  if (max_queue_value < 1 || max_queue_value > kMaxQueueLimit)
    throw ConfigError(cfg.path() + ": key 'process/max_queue' must be in [1, " + std::to_string(kMaxQueueLimit) +
                      "], got " + std::to_string(max_queue_value));
  p.max_queue = static_cast<size_t>(max_queue_value);
  p.apply_integrity = cfg.getBool("process/apply_integrity", p.apply_integrity);
  return p;
}

StereoJobQueue::Dropped StereoJobQueue::push(StereoJob job) {
  Dropped d;
  if (!queue_all_) {
    d.superseded = static_cast<int64_t>(jobs_.size());
    jobs_.clear();
  } else if (jobs_.size() >= max_queue_) {
    jobs_.pop_front();
    d.queue_full = true;
  }
  jobs_.push_back(std::move(job));
  return d;
}

bool StereoJobQueue::frontReady() const {
  return !queue_all_ || integrity_seen_utime_ == 0 || integrity_seen_utime_ >= jobs_.front().prev_utime;
}

StereoJob StereoJobQueue::pop() {
  StereoJob job = std::move(jobs_.front());
  jobs_.pop_front();
  return job;
}

}  // namespace ips::e3d
