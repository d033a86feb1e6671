#pragma once
// Pairs left and right frames by time stamp. Frames of each camera arrive in time order, so when the two
// oldest waiting frames differ by more than the tolerance, the older one can never find its partner: it is
// dropped and counted, never paired with a wrong one. A camera that stops sending leaves its partner's frames
// to pile up; beyond `max_waiting` the oldest are dropped (counted the same way).
#include <cstdint>
#include <deque>
#include <optional>
#include <utility>

namespace ips::drivers {

struct FramePairerConfig {
  int64_t tolerance_us = 2000;  // |t_left - t_right| accepted as one exposure
  size_t max_waiting = 4;       // frames held per side while the other side is silent
};

template <class Frame>
class FramePairer {
 public:
  struct Pair {
    Frame left, right;
    int64_t left_us, right_us;
  };

  explicit FramePairer(FramePairerConfig config = {}) : config_(config) {}

  // side 0 = left, 1 = right. Returns the pair completed by this frame, if any.
  std::optional<Pair> push(int side, int64_t utime, Frame frame) {
    auto& q = queue_[side];
    if (have_last_[side] && utime <= last_utime_[side]) {
      ++out_of_order_[side];  // a stamp going backwards cannot be paired reliably
      return std::nullopt;
    }
    have_last_[side] = true;
    last_utime_[side] = utime;
    q.emplace_back(utime, std::move(frame));
    while (q.size() > config_.max_waiting) {
      q.pop_front();
      ++unpaired_[side];
    }
    while (!queue_[0].empty() && !queue_[1].empty()) {
      const int64_t tl = queue_[0].front().first, tr = queue_[1].front().first;
      if (tl - tr > config_.tolerance_us) {
        queue_[1].pop_front();
        ++unpaired_[1];
      } else if (tr - tl > config_.tolerance_us) {
        queue_[0].pop_front();
        ++unpaired_[0];
      } else {
        Pair p{std::move(queue_[0].front().second), std::move(queue_[1].front().second), tl, tr};
        queue_[0].pop_front();
        queue_[1].pop_front();
        ++pairs_;
        return p;
      }
    }
    return std::nullopt;
  }

  // Forgets the frames of one side (its camera reconnected: stamps restart); they are counted as unpaired.
  void clear(int side) {
    have_last_[side] = false;
    unpaired_[side] += static_cast<int64_t>(queue_[side].size());
    queue_[side].clear();
  }

  int64_t pairs() const { return pairs_; }
  int64_t unpaired(int side) const { return unpaired_[side]; }
  int64_t outOfOrder(int side) const { return out_of_order_[side]; }
  size_t waiting(int side) const { return queue_[side].size(); }

 private:
  FramePairerConfig config_;
  std::deque<std::pair<int64_t, Frame>> queue_[2];
  int64_t pairs_ = 0;
  int64_t unpaired_[2] = {0, 0};
  int64_t out_of_order_[2] = {0, 0};
  bool have_last_[2] = {false, false};
  int64_t last_utime_[2] = {0, 0};
};

}  // namespace ips::drivers
