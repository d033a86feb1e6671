#pragma once
// The flat-field calibration of a camera (its vignetting, CameraIntrinsics::vignetting_gain) from raw images of
// that camera. The fall-off is a function of the ray's angle to the optical axis only (t = tan^2 theta,
// ips::rayTan2Image); the fit finds the gain G(t) = 1 + g1 t + g2 t^2 + g3 t^3 that undoes it:
//  - kFlatTarget: images of a uniformly lit, evenly grey surface filling the view (a white wall, a diffuser): the
//    mean image times G is flat, mean(u, v) G(t(u, v)) = s, linear in g and the one level s.
//  - kMovingScene: a recording of the head moving through an ordinary scene. A scene point tracked from one image
//    to the next (OpenCV's pyramidal Lucas-Kanade, checked backwards) keeps its radiance but moves to another t, so
//    log I'(q) - log I(p) = log V(t_q) - log V(t_p) + the exposure change: its grey changes by the fall-off between
//    the two positions, whatever the scene. The exposure change of each image pair is a level of its own (auto
//    exposure), so only the shape of G across the image counts, and G(0) = 1 fixes its scale. The mean image of a
//    moving scene is no flat field (corridors, sky and ground leave their own pattern: 15-18 % wrong on the
//    simulator's walk), so it is not used for scenes.
// The library knows nothing of LCM; calibrate_vignetting reads the images.
#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <vector>

#include "ips/calibration.hpp"

namespace ips::calib {

enum class FlatFieldSource { kFlatTarget, kMovingScene };

struct VignettingEstimate {
  Eigen::Vector3d gain = Eigen::Vector3d::Zero();  // g1 g2 g3, as CameraIntrinsics::vignetting_gain
  int images = 0;                                  // images averaged
  double widest_tan2 = 0;                          // t of the widest ray of the image (its corners)
  double corner_gain = 1;                          // G at the widest ray: how much the corners are lifted
  // RMS of mean x G against the levels, relative to the mean level, over the blocks fitted: how flat the corrected
  // mean is (a flat target: its unevenness and the noise; a moving scene: also what the scene left).
  double relative_residual = 0;
};

struct VignettingOptions {
  FlatFieldSource source = FlatFieldSource::kMovingScene;
  // A pixel takes part only with a grey in [lowest_grey, highest_grey]: clipped pixels do not show the fall-off.
  int lowest_grey = 3;
  int highest_grey = 252;
  int min_images = 1;  // fewer is an error (calibrate_vignetting: 5 for a flat target, 50 for a scene)
  // kFlatTarget: the mean image is fitted in blocks of this many pixels square (the fall-off is smooth; blocks
  // average the noise and keep the least-squares problem small); a block takes part when each of its pixels was
  // unclipped in at least min_valid_fraction of the images.
  int block_px = 8;
  double min_valid_fraction = 0.5;
  // kMovingScene: up to max_tracks corners per image pair (cv::goodFeaturesToTrack, corners at least
  // min_track_distance_px apart so that they spread over the image; found and tracked on the images with their
  // local contrast normalised); a track counts when the backward track
  // returns within max_return_px; the grey of a point is the mean of the patch_px square about it (the sensor's
  // noise averaged; a patch moved by a few pixels still shows the same scene).
  int max_tracks = 800;
  double min_track_distance_px = 12;
  double max_return_px = 0.5;
  int patch_px = 7;
  // The tracker sees the images with their local mean and contrast taken out over Gaussian windows of this sigma:
  // a few times the tracker's window of 21 px, so that the texture stays and the lens's smooth fall-off goes.
  double normalisation_sigma_px = 8;
};

class VignettingAccumulator {
 public:
  explicit VignettingAccumulator(const CameraIntrinsics& camera, const VignettingOptions& options = {});
  // A raw image of the camera (CV_8UC1 of its size); throws std::invalid_argument otherwise. kMovingScene: when
  // `follows_previous`, the image is the one taken right after the previous one added (consecutive frames of the
  // recording), and points are tracked from that one into it.
  void add(const cv::Mat& raw, bool follows_previous = true);
  int images() const { return images_; }
  size_t tracks() const { return tracks_.size(); }
  // Throws std::runtime_error with fewer than min_images images or too little to fit.
  VignettingEstimate estimate() const;

 private:
  struct Track {
    float tan2_from, tan2_to;  // t where the point was and where it is
    float log_ratio;           // log grey there minus log grey here
    int pair;                  // which image pair: its exposure change
  };
  VignettingEstimate estimateFlatTarget() const;
  VignettingEstimate estimateMovingScene() const;
  VignettingEstimate finish(const Eigen::Vector3d& gain, double relative_residual) const;

  CameraIntrinsics camera_;
  VignettingOptions options_;
  cv::Mat tan2_;          // CV_32F, rayTan2Image
  cv::Mat sum_, counts_;  // kFlatTarget: CV_64F sum of valid greys, CV_32S how many images were valid at each pixel
  cv::Mat previous_;      // kMovingScene: the image added last
  cv::Mat previous_normalised_;  // and what the tracker saw of it
  std::vector<Track> tracks_;
  int pairs_ = 0;
  int images_ = 0;
};

}  // namespace ips::calib
