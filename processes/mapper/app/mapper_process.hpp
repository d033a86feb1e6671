#pragma once
// The mapper's LCM side: STEREO, DISPARITY and the poses of one source (FILTER_STATE, TRACKER_DELTA chained or
// GT_POSE) in, converted to ips_mapper's plain inputs; its frames out as POINTS, the alignments of successive maps
// as CLOUD_DELTA.
#include <ips/disparity_map_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <optional>
#include <string>
#include <vector>

#include "ips/calibration.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/validate.hpp"
#include "ips/mapper/cloud_odometry.hpp"
#include "ips/mapper/mapper.hpp"

namespace ips::mapper_app {

// Where the poses that place the maps come from.
enum class PoseSource { kFilter, kTracker, kTruth };
// "filter", "tracker" or "truth"; nothing for any other name.
std::optional<PoseSource> poseSourceFromName(const std::string& name);

class MapperProcess {
 public:
  // pose_channel empty: the source's own channel. cloud_delta_channel empty: no alignment of successive maps.
  MapperProcess(fw::Node& node, const StereoCalibration& calib, const mapper::MapperParams& params,
                const std::string& points_channel, const std::string& cloud_delta_channel,
                const mapper::CloudOdometryParams& cloud_params, PoseSource source, const std::string& pose_channel);

  // Writes the fused map (nothing with an empty path).
  void save(const std::string& path);

 private:
  void onStereo(const stereo_pair_t& m);
  void onDisparity(const disparity_map_t& m);
  void onPose(const Pose& p);
  void subscribePoses(PoseSource source, const std::string& channel);
  // Runs one input through the mapper and publishes what came out; the processing time per map for health.
  template <class Fn>
  void timed(Fn fn);
  void publish(const std::vector<mapper::MappedFrame>& frames);
  // The map aligned with the previous one: a relative pose of camera 0 for the filter (CLOUD_DELTA, with the
  // convention and covariance order of a tracker delta; seq counts the alignments).
  void align(const mapper::MappedFrame& f);

  fw::Node& node_;
  const std::string points_channel_, cloud_delta_channel_;
  const Eigen::Isometry3d T_body_cam0_;
  mapper::Mapper mapper_;
  std::optional<mapper::CloudOdometry> odometry_;
  std::optional<mapper::TrackerPoses> tracker_poses_;  // with PoseSource::kTracker
  int64_t cloud_seq_ = 0;
  fw::StereoAdmission stereo_admission_;
  fw::StreamOrder disparity_order_, pose_order_;
  bool logged_range_ = false;
};

}  // namespace ips::mapper_app
