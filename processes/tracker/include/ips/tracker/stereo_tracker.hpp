#pragma once
// The IPS stereo tracker: from consecutive raw stereo pairs to the relative motion of camera 0.
//
//   process(pair N+1): rectify -> Harris corners (left) -> intra-matching (NCC along rows) -> triangulation
//   -> inter-matching against pair N in windows placed by the motion prior -> RANSAC(Umeyama) ->
//   Gauss-Newton refinement -> covariance -> (guided second matching pass when the prior was weak).
//
// Knows nothing of LCM; TrackResult maps one to one onto ips_tracker_delta_t.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>

#include "ips/calibration.hpp"
#include "ips/tracker/disparity_offset.hpp"
#include "ips/tracker/matching.hpp"
#include "ips/tracker/motion.hpp"
#include "ips/tracker/params.hpp"

namespace ips::tracker {

// A prediction of the motion of camera 0 from the previous image pair to the new one, in the tracker
// delta's semantic (X_prev = R * X_now + t, camera 0 frames) with its uncertainty.
struct MotionPrior {
  enum class Source : int8_t { None = 0, ConstantVelocity = 1, Imu = 2, Filter = 3 };  // = PRIOR_* of the message
  Source source = Source::None;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  Matrix6d covariance = Matrix6d::Identity();  // [tx ty tz rx ry rz], rotation as right perturbation

  // From the filter's a-priori state: the predicted pose of camera 0 at the new time in camera 0 at the
  // previous image time.
  static MotionPrior fromFilter(const Eigen::Matrix3d& R, const Eigen::Vector3d& t, const Matrix6d& covariance);
  // From gyro rates (IMU frame, bias-corrected, mean over the interval [rad/s]): rotation only; the
  // translation is unknown within params.imu_translation_sigma_per_s.
  static MotionPrior fromImuRates(const Eigen::Vector3d& omega_imu, const Eigen::Matrix3d& R_imu_cam0, double dt_s,
                                  double omega_sigma, const PriorParams& params);
};

struct StageTimes {  // [ms] measured with a monotonic clock, for benchmarks and health
  double rectify = 0, detect = 0, intra = 0, inter = 0, motion = 0, total = 0;
};

// One-to-one with ips_tracker_delta_t (seq is the caller's), plus prediction statistics and timings.
struct TrackResult {
  int64_t utime = 0;
  int64_t utime_prev = 0;
  bool valid = false;
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();  // [m] in camera 0 at utime_prev
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Matrix6d covariance = Matrix6d::Identity();
  int num_features = 0;
  int num_intra_matches = 0;
  int num_inter_matches = 0;
  int num_inliers = 0;
  double residual_rms = 0;  // [m]
  MotionPrior::Source prior_source = MotionPrior::Source::None;
  bool prior_ok = false;

  double residual_rms_px = 0;            // stereo reprojection rms of the inliers
  int num_predictions_ok = 0;            // inliers found within prior_ok_px of where the prior predicted them
  double prediction_ok_ratio = 0;        // ... as a share of the inliers; prior_ok = ratio >= prior_ok_fraction
  bool wide_retry = false;               // the prior's windows failed; matched again with the widest windows
  bool retry_around_own_motion = false;  // ... placed by the tracker's own last motion, not the given prior
  bool guided_pass = false;              // a second matching pass around the first estimate was run
  bool intra_guided = false;             // intra-matching took E3D's disparity map of this pair
  GuidedIntraCounts guided_intra;        // ... and what it did with the corners
  StageTimes times;

  // Rotation from far points alone (FarRotationParams), in the semantic and frame of `rotation`; independent of
  // the 6-DoF estimate's points (those within motion/max_depth), so a filter can take it as a further measurement.
  bool far_valid = false;
  Eigen::Quaterniond far_rotation = Eigen::Quaterniond::Identity();
  Eigen::Matrix3d far_covariance = Eigen::Matrix3d::Identity();  // rotation vector [rad^2], camera 0 at utime_prev
  int num_far_matches = 0;                                       // inter-matches beyond motion/max_depth
  int num_far_inliers = 0;
  double far_residual_rms_px = 0;

  // The disparity offset (DisparityOffsetParams) this pair was triangulated with, and the estimate after it.
  double disparity_offset_used_px = 0;
  double disparity_offset_px = 0;
  double disparity_offset_sigma_px = 0;
  bool disparity_offset_observed = false;  // this pair's observation entered the estimate
  bool disparity_offset_rejected = false;  // ... or its gate refused it
  bool disparity_offset_applied = false;   // the estimate replaced the offset in use after this pair

  Eigen::Vector3d rotationVector() const;
};

// The 6-DoF increment updated with the far rotation as a measurement of its rotation (a Kalman update on the 6-vector
// [t, r], gated at gate_chi2, FarRotationParams::fuse_chi2), for chains of increments without a filter (track_log,
// tracker_sim_eval). Returns the increment unchanged when either part is invalid or the gate refuses the far rotation.
struct FusedIncrement {
  bool far_used = false;
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  Matrix6d covariance = Matrix6d::Identity();
};
FusedIncrement fuseFarRotation(const TrackResult& r, double gate_chi2);

// Running counts of how often the prediction was right, since construction or reset().
struct PredictionStats {
  int64_t frames_with_prior = 0;
  int64_t frames_prior_ok = 0;
  int64_t matches = 0;     // inliers of frames with a prior
  int64_t matches_ok = 0;  // ... found within prior_ok_px of the prediction
};

class StereoTracker {
 public:
  // Throws std::invalid_argument on an unusable calibration or parameters.
  StereoTracker(const StereoCalibration& calib, const TrackerParams& params);

  // Raw (distorted, unrectified) 8-bit grey pair of the calibration's size (3-channel images are converted).
  // prior == nullptr: constant velocity from the last valid delta when there is one, else no prior.
  // guide: a disparity map of this pair (E3D) that places each corner's right position (matchWithDisparity);
  // corners without a disparity in it are matched along their rows as without one.
  // The first pair, a time that does not increase, or too few inliers give valid == false; the new pair is
  // then the reference for the next one, unless it has too few stereo features to be one (then the old
  // reference stays and utime_prev of the next result names it). Throws std::invalid_argument on empty or wrongly sized
  // images.
  TrackResult process(int64_t utime, const cv::Mat& left_raw, const cv::Mat& right_raw,
                      const MotionPrior* prior = nullptr, const DisparityGuide* guide = nullptr);

  void reset();  // forget the reference pair and the constant-velocity state
  // Rectify the right images of the following pairs with this correction of the right camera (the epipolar integrity
  // monitor's); the left rectification, and so the reference pair, stay as they are.
  void setRightCorrection(const RightCameraCorrection& correction);
  const RightCameraCorrection& rightCorrection() const { return right_correction_; }
  const StereoRectification& rectification() const { return rect_; }
  const StereoCalibration& calibration() const { return calib_; }
  const RectifiedStereo& rectifiedStereo() const { return stereo_; }
  const PredictionStats& predictionStats() const { return stats_; }
  // The disparity offset in use [px], its estimate and the estimate's 1-sigma (infinite before the first
  // observation).
  double disparityOffset() const { return stereo_.disparity_offset; }
  // The stamp of the pair after which the offset in use was applied (0: in use from the start).
  int64_t disparityOffsetAppliedUtime() const { return offset_applied_utime_; }
  double disparityOffsetEstimate() const { return offset_.estimate(); }
  double disparityOffsetSigma() const { return offset_.sigma(); }
  const TrackerParams& params() const { return params_; }

  // The last processed rectified pair and its stereo features (for tools and tests).
  const cv::Mat& rectifiedLeft() const { return cur_->left; }
  const cv::Mat& rectifiedRight() const { return cur_->right; }
  const StereoFeatures& features() const { return cur_->features; }
  const std::vector<Corner>& corners() const { return cur_->corners; }  // of the last rectified left image
  // Time of the pair the next one will be measured against (0 when there is none).
  int64_t referenceTime() const { return ref_ ? ref_->utime : 0; }

 private:
  struct Frame {
    int64_t utime = 0;
    cv::Mat left, right;  // rectified
    std::vector<Corner> corners;
    StereoFeatures features;
    bool valid = false;
  };
  std::vector<Prediction> predict(const RigidMotion& m_rect, const Matrix6d& cov_rect, bool have_prior) const;
  // Near correspondences (both points within motion/max_depth, for the 6-DoF estimate) and, if `far` is given, the
  // others (for the rotation from far points); split by disparity, so that points at infinity are far.
  std::vector<Correspondence> correspondences(const std::vector<InterMatch>& matches,
                                              std::vector<Correspondence>* far = nullptr) const;

  TrackerParams params_;
  StereoCalibration calib_;
  StereoRectification rect_;
  RightCameraCorrection right_correction_;
  RectifiedStereo stereo_;
  cv::Mat map0a_, map0b_, map1a_, map1b_;  // fixed-point remap tables
  std::shared_ptr<Frame> ref_;             // the older pair of the next delta
  std::shared_ptr<Frame> cur_ = std::make_shared<Frame>();
  bool have_velocity_ = false;
  RigidMotion last_delta_;  // camera 0 frame
  double last_dt_s_ = 0;
  PredictionStats stats_;
  DisparityOffsetEstimator offset_;  // its inUse() is stereo_.disparity_offset
  int64_t offset_applied_utime_ = 0;
  void updateDisparityOffset(const std::vector<Correspondence>& corr, const MotionEstimate& est, TrackResult& res);
};

}  // namespace ips::tracker
