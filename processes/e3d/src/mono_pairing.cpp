#include "ips/e3d/mono_pairing.hpp"

#include <stdexcept>

namespace ips::e3d {

MonoPairing::MonoPairing(int gap_pairs, int every_nth)
    : gap_pairs_(gap_pairs), every_nth_(every_nth), poses_(kPoseMaxGapS, kPoseKeepS) {
  if (gap_pairs < 1 || every_nth < 1) throw std::invalid_argument("MonoPairing: gap_pairs and every_nth must be >= 1");
}

bool MonoPairing::wants(int64_t seq) const { return seq % every_nth_ == 0 || (seq + gap_pairs_) % every_nth_ == 0; }

MonoPairing::Released MonoPairing::addPair(int64_t seq, int64_t utime, const cv::Mat& left) {
  int64_t dropped = 0;
  if (seq % every_nth_ == 0) {
    const auto it = earlier_.find(seq);
    if (it != earlier_.end()) {
      if (pending_.size() >= kMaxPending) {
        pending_.pop_front();
        ++dropped;
      }
      MonoJob job;
      job.utime_a = it->second.first;
      job.left_a = it->second.second;
      job.utime_b = utime;
      job.seq_b = seq;
      job.left_b = left;
      pending_.push_back(std::move(job));
    }
  }
  // Earlier images no later pair can use: for this pair or before it, or (after a sequence reset) too far ahead.
  for (auto it = earlier_.begin(); it != earlier_.end();)
    it = (it->first <= seq || it->first > seq + gap_pairs_) ? earlier_.erase(it) : std::next(it);
  if ((seq + gap_pairs_) % every_nth_ == 0) earlier_[seq + gap_pairs_] = {utime, left};
  Released out = release();
  out.dropped = dropped;
  return out;
}

MonoPairing::Released MonoPairing::addPose(const Pose& pose) {
  poses_.add(pose);
  return release();
}

MonoPairing::Released MonoPairing::release() {
  Released out;
  while (!pending_.empty() && poses_.newestUtime() >= pending_.front().utime_b) {
    MonoJob job = std::move(pending_.front());
    pending_.pop_front();
    if (poses_.at(job.utime_a, &job.pose_a) == PoseBuffer::Lookup::kFound &&
        poses_.at(job.utime_b, &job.pose_b) == PoseBuffer::Lookup::kFound)
      out.ready.push_back(std::move(job));
    else
      ++out.without_pose;
  }
  return out;
}

}  // namespace ips::e3d
