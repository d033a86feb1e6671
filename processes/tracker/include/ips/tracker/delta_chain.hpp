#pragma once
// The tracker's motion increments chained into a trajectory of camera 0 (the "tracker" entry of the report when
// no filter runs). An increment maps points of the new pair into the reference pair: X_prev = R X_now + t, so
// T_world_now = T_world_prev * [R | t], the reference being the pair stamped utime_prev (not always the pair
// just before: a pair too poor to be a reference is skipped). The first pair is the origin. An invalid increment
// (lost track) carries the last pose over (zero motion assumed) and is counted: the gap stays in the error.
#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <vector>

namespace ips::tracker {

class DeltaChain {
 public:
  struct Pose {
    int64_t utime = 0;
    Eigen::Isometry3d T_world_cam0 = Eigen::Isometry3d::Identity();
  };

  void add(int64_t utime, int64_t utime_prev, bool valid, const Eigen::Quaterniond& rotation,
           const Eigen::Vector3d& translation) {
    if (poses_.empty()) {
      push(utime, Eigen::Isometry3d::Identity());
      return;
    }
    auto ref = by_time_.find(utime_prev);
    if (!valid || ref == by_time_.end()) {
      ++invalid_;
      if (valid) ++unreferenced_;
      push(utime, poses_.back().T_world_cam0);
      return;
    }
    Eigen::Isometry3d T_prev_now = Eigen::Isometry3d::Identity();
    T_prev_now.linear() = rotation.normalized().toRotationMatrix();
    T_prev_now.translation() = translation;
    push(utime, poses_[ref->second].T_world_cam0 * T_prev_now);
  }

  const std::vector<Pose>& poses() const { return poses_; }
  int64_t invalid() const { return invalid_; }
  // Of those, valid increments whose reference pair the chain never saw: an increment missing before them (a
  // recording that lost messages).
  int64_t unreferenced() const { return unreferenced_; }

 private:
  void push(int64_t utime, const Eigen::Isometry3d& T) {
    by_time_[utime] = poses_.size();
    poses_.push_back({utime, T});
  }
  std::vector<Pose> poses_;
  std::map<int64_t, size_t> by_time_;
  int64_t invalid_ = 0, unreferenced_ = 0;
};

}  // namespace ips::tracker
