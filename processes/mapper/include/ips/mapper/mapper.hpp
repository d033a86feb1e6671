#pragma once
// The mapper on plain inputs: disparity maps wait for the pose at their time, are placed in the world, cut by
// range, fused per voxel into the map, and come out as one frame of world points each. Time comes only from
// the inputs' stamps, so the same inputs in the same order give the same frames.
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "ips/calibration.hpp"
#include "ips/mapper/params.hpp"
#include "ips/mapper/stereo_points.hpp"
#include "ips/mapper/voxel_map.hpp"
#include "ips/pose_buffer.hpp"
#include "ips/tracker/delta_chain.hpp"

namespace ips::mapper {

// A disparity map of the rectified left image as it comes from E3D (its own rectified camera and scale).
struct DisparityInput {
  int64_t utime = 0, seq = 0;
  cv::Mat disparity;  // CV_32FC1 [px], NaN where invalid
  double focal_px = 0, cx = 0, cy = 0, baseline_m = 0;
};

// The points of one disparity map in the world, fused per voxel, and the pose that placed them.
struct MappedFrame {
  int64_t utime = 0, seq = 0;
  Pose pose;
  std::vector<Eigen::Vector3d> points;
  std::vector<uint8_t> intensity;
  bool has_grey = false;  // the raw left image of that pair was still held
  // The map's points with texture of their own, not fused (PointSet::alignment_points): what CloudOdometry aligns.
  // Empty unless the mapper keeps them (Mapper::keepAlignmentPoints).
  std::vector<Eigen::Vector3d> alignment_points;
  // Depth precision of the map's points: sigma_z = depth_sigma_per_m2 * z^2 (sigma_d / (f b)).
  double depth_sigma_per_m2 = 0;
};

// Body poses from the tracker's increments alone (a head without IMU): the world is the body at the first
// image, camera 0's chain turned onto the body. No uncertainty is carried along the chain (zero covariance).
class TrackerPoses {
 public:
  explicit TrackerPoses(const Eigen::Isometry3d& T_body_cam0) : T_body_cam0_(T_body_cam0) {}
  // One increment (as ips::tracker::DeltaChain takes it); `motion_unknown` set when it carried no motion.
  Pose add(int64_t utime, int64_t utime_prev, bool valid, const Eigen::Quaterniond& rotation,
           const Eigen::Vector3d& translation, bool* motion_unknown);

 private:
  Eigen::Isometry3d T_body_cam0_;
  ips::tracker::DeltaChain chain_;
};

class Mapper {
 public:
  // What happened to inputs that were not mapped, for the process's health counters.
  using Counter = std::function<void(const std::string& name, int64_t count)>;

  Mapper(const StereoCalibration& calib, const MapperParams& params, Counter dropped, Counter counted);

  // Frames carry alignment_points from now on (a mapper that aligns its maps, CloudOdometry).
  void keepAlignmentPoints() { alignment_points_ = true; }
  // The raw left image of a pair (mono8), for the grey values of its map's points.
  void addLeftImage(int64_t seq, const cv::Mat& raw_left);
  // Inputs in stamp order per stream; each returns the frames that became ready.
  std::vector<MappedFrame> addDisparity(const DisparityInput& map);
  std::vector<MappedFrame> addPose(const Pose& pose);

  const VoxelMap& map() const { return map_; }
  // The range the depth precision allows for this camera pair (for the log).
  double rangeFor(const DisparityInput& map) const;

 private:
  std::vector<MappedFrame> drain();
  MappedFrame place(const DisparityInput& map, const Pose& pose);
  cv::Mat rectifiedLeft(const cv::Mat& raw, int width);

  const StereoCalibration calib_;
  const MapperParams params_;
  bool alignment_points_ = false;
  Counter dropped_, counted_;
  HeadGeometry head_;
  PoseBuffer poses_;
  VoxelMap map_;
  std::optional<StereoRectification> rect_;  // at the disparity maps' scale
  std::map<int64_t, cv::Mat> lefts_;         // by seq
  std::deque<DisparityInput> pending_;
};

}  // namespace ips::mapper
