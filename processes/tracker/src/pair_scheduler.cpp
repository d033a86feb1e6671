#include "ips/tracker/pair_scheduler.hpp"

#include <algorithm>

namespace ips::tracker {

DisparityWait loadDisparityWait(const Config& cfg, bool queue) {
  DisparityWait w;
  w.enabled = cfg.getBool("process/intra_from_disparity", w.enabled);
  w.every_nth = cfg.getInt("process/disparity_every_nth", w.every_nth);
  w.wait_pairs = cfg.getInt("process/disparity_wait_pairs", w.wait_pairs);
  w.max_pending = cfg.getInt("process/disparity_max_pending", w.max_pending);
  const double max_backlog_s = cfg.getDouble("process/max_backlog_s", w.max_backlog_us * 1e-6);
  w.max_backlog_us = static_cast<int64_t>(max_backlog_s * 1e6);
  w.queue = queue;
  if (w.every_nth < 1 || w.wait_pairs < 0 || w.max_pending < 2 || !(max_backlog_s > 0))
    throw ConfigError(cfg.path() +
                      ": process/ scheduling keys out of range (disparity_every_nth >= 1, disparity_wait_pairs >= 0, "
                      "disparity_max_pending >= 2, max_backlog_s > 0)");
  return w;
}

bool priorReady(const PriorBuilder& priors, int64_t utime) {
  const bool gyro_ready = !priors.gyroSeen() || priors.gyroCovers(utime);
  if (!priors.filterSeen()) return gyro_ready;
  // Without a state from the filter the pair falls back on the gyro: then it waits for that too.
  return priors.hasFilterState(utime) || (priors.filterAnswered(utime) && gyro_ready);
}

void PairScheduler::addPair(PendingPair p) {
  const int64_t utime = p.utime;
  pending_.emplace(utime, std::move(p));
}

bool PairScheduler::acceptsMap(int64_t utime) const {
  return utime > last_utime_ && maps_.size() < static_cast<size_t>(wait_.max_pending);
}

bool PairScheduler::addMap(int64_t utime, int64_t seq, DisparityGuide guide) {
  if (!acceptsMap(utime)) return false;
  newest_map_utime_ = std::max(newest_map_utime_, utime);
  maps_[utime] = StoredMap{seq, std::move(guide)};
  return true;
}

bool PairScheduler::waitsForMap(const PendingPair& p) const {
  if (!expectsMap(p.seq)) return false;
  return maps_.count(p.utime) == 0 && newest_map_utime_ < p.utime;  // a later map: E3D skipped this pair
}

bool PairScheduler::oldestGoesOn(bool prior_ready) const {
  const bool map_wait = waitsForMap(pending_.begin()->second);
  const size_t hold = !map_wait ? 1 : wait_.queue ? wait_.max_pending : 1 + wait_.wait_pairs;
  return (prior_ready && !map_wait) || pending_.size() > hold;
}

int PairScheduler::dropStale() {
  if (wait_.queue || pending_.empty()) return 0;
  const int64_t oldest_kept = pending_.rbegin()->first - wait_.max_backlog_us;
  int dropped = 0;
  while (pending_.begin()->first < oldest_kept) {
    pending_.erase(pending_.begin());
    ++dropped;
  }
  return dropped;
}

PendingPair PairScheduler::takeOldest() {
  PendingPair p = std::move(pending_.begin()->second);
  pending_.erase(pending_.begin());
  return p;
}

const DisparityGuide* PairScheduler::mapFor(const PendingPair& p) const {
  auto map = maps_.find(p.utime);
  return map != maps_.end() && map->second.seq == p.seq ? &map->second.guide : nullptr;
}

void PairScheduler::tracked(int64_t utime) {
  maps_.erase(maps_.begin(), maps_.upper_bound(utime));
  last_utime_ = utime;
}

}  // namespace ips::tracker
