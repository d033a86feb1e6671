#include "ips/mapper/mapper.hpp"

#include <opencv2/imgproc.hpp>

namespace ips::mapper {

Pose TrackerPoses::add(int64_t utime, int64_t utime_prev, bool valid, const Eigen::Quaterniond& rotation,
                       const Eigen::Vector3d& translation, bool* motion_unknown) {
  const int64_t invalid_before = chain_.invalid();
  chain_.add(utime, utime_prev, valid, rotation, translation);
  *motion_unknown = chain_.invalid() > invalid_before;
  Pose pose;
  pose.utime = chain_.poses().back().utime;
  pose.T_world_body = T_body_cam0_ * chain_.poses().back().T_world_cam0 * T_body_cam0_.inverse();
  return pose;
}

Mapper::Mapper(const StereoCalibration& calib, const MapperParams& params, Counter dropped, Counter counted)
    : calib_(calib),
      params_(params),
      dropped_(std::move(dropped)),
      counted_(std::move(counted)),
      poses_(params.max_pose_gap_s, 10.0),
      map_(params.voxel_size_m, params.max_voxels) {
  head_.R_rect0_cam0 = computeRectification(calib).R_rect0_cam0;
  head_.T_body_cam0 = calib.T_imu_cam0;
}

void Mapper::addLeftImage(int64_t seq, const cv::Mat& raw_left) {
  lefts_[seq] = raw_left.clone();
  while (static_cast<int>(lefts_.size()) > params_.max_pending_images) lefts_.erase(lefts_.begin());
}

std::vector<MappedFrame> Mapper::addDisparity(const DisparityInput& map) {
  pending_.push_back(map);
  if (static_cast<int>(pending_.size()) > params_.max_pending_maps) {
    pending_.pop_front();
    dropped_("map_waited_too_long_for_a_pose", 1);
  }
  return drain();
}

std::vector<MappedFrame> Mapper::addPose(const Pose& pose) {
  if (!poses_.add(pose)) counted_("pose_time_went_back", 1);
  return drain();
}

double Mapper::rangeFor(const DisparityInput& map) const {
  return rangeForDepthSigma(params_, map.focal_px, map.baseline_m);
}

std::vector<MappedFrame> Mapper::drain() {
  std::vector<MappedFrame> out;
  while (!pending_.empty()) {
    Pose pose;
    const PoseBuffer::Lookup found = poses_.at(pending_.front().utime, &pose);
    if (found == PoseBuffer::Lookup::kNotYet) break;
    if (found == PoseBuffer::Lookup::kFound)
      out.push_back(place(pending_.front(), pose));
    else
      dropped_(found == PoseBuffer::Lookup::kGap ? "no_pose_gap" : "no_pose_before_map", 1);
    pending_.pop_front();
  }
  return out;
}

MappedFrame Mapper::place(const DisparityInput& map, const Pose& pose) {
  DisparityImage image;
  image.disparity = map.disparity;
  image.focal_px = map.focal_px, image.cx = map.cx, image.cy = map.cy, image.baseline_m = map.baseline_m;
  const auto left = lefts_.find(map.seq);
  if (left != lefts_.end()) image.grey = rectifiedLeft(left->second, map.disparity.cols);
  PointSet set = triangulate(image, head_, pose.T_world_body, params_, alignment_points_);
  VoxelMap::downsample(params_.voxel_size_m, &set.points, &set.intensity);
  const int64_t dropped = map_.insert(set.points, set.intensity, pose.T_world_body.translation());
  if (dropped > 0) counted_("voxels_dropped_far_from_head", dropped);
  MappedFrame frame;
  frame.utime = map.utime;
  frame.seq = map.seq;
  frame.pose = pose;
  frame.points = std::move(set.points);
  frame.intensity = std::move(set.intensity);
  frame.has_grey = !image.grey.empty();
  frame.alignment_points = std::move(set.alignment_points);
  frame.depth_sigma_per_m2 = params_.disparity_sigma_px / (map.focal_px * map.baseline_m);
  return frame;
}

cv::Mat Mapper::rectifiedLeft(const cv::Mat& raw, int width) {
  // E3D may match at a reduced scale: the left image is rectified at the map's.
  if (!rect_ || rect_->size.width != width)
    rect_ = scaledRectification(calib_, static_cast<double>(width) / calib_.cam0.width);
  cv::Mat out;
  cv::remap(raw, out, rect_->map0x, rect_->map0y, cv::INTER_LINEAR);
  return out;
}

}  // namespace ips::mapper
