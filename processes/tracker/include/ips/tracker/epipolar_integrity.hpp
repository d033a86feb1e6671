#pragma once
// Epipolar integrity and self-calibration from the tracker's intra-matching (paper section 6: "IPS intra-matching
// can be used for verifying epipolar geometry being necessary for E3D and providing self-calibration").
//
// After rectification a matched point lies on the same row in both images. When the right camera turns against the
// left after calibration (a knock, temperature), rows stop matching and E3D's disparity degrades without a sign.
// Corners of the rectified left image are searched in the right image over a band of rows (matchAcrossRows); their
// vertical disparity dy, to first order in a right-camera correction c = [wx wy wz s] (rotation vector in the
// rectified right frame, relative focal error) is
//
//   dy = f * [ (1 + v^2) wx  -  u v wy  -  u wz  +  v s ]        u = (x_right - cx) / f, v = (y - cy) / f
//
// (a right-camera principal point error in y acts as wx; horizontal terms change disparity, not rows, and are not
// seen). Each pair gives a robust least-squares estimate of c; a random-walk Kalman filter over the pairs follows a
// slow drift, a run of pairs outside its gate is a step (a knock) and restarts it from the newest pair. The monitor
// raises an alarm while the rectification in use leaves rows apart by more than alarm_px somewhere in the image, and
// hands out a new correction when its estimate is certain and differs from the one in use by more than apply_px;
// the tracker and E3D then rectify with it (ips::computeRectification's right_correction). A correction moves columns
// too, and a column is a disparity, so certain means known in rows and columns; the yaw, seen in rows only through a
// keystone, corrects that keystone and no column (RightCameraCorrection).
//
// Knows nothing of LCM; IntegrityStatus maps one to one onto ips_integrity_t.
#include <Eigen/Core>
#include <cstdint>
#include <deque>
#include <utility>
#include <vector>

#include "ips/calibration.hpp"
#include "ips/config.hpp"
#include "ips/tracker/matching.hpp"
#include "ips/tracker/stereo_tracker.hpp"

namespace ips::tracker {

struct IntegrityParams {
  bool enabled = true;
  // Probe: corners searched over a band of rows.
  int max_probes = 150;         // corners per pair, taken evenly from the detector's (which are spread on its grid)
  int search_rows = 6;          // rows either side: a 0.5 deg turn moves rows by 6.5 px at f = 744 px
  double min_ncc = 0.8;         // as the intra-matching's
  double uniqueness = 0.03;     // second best peak (more than one row or column away) this much lower
  int min_points = 30;          // a pair with fewer matches gives no measurement
  double outlier_sigmas = 3.0;  // residuals beyond this many robust sigmas leave the pair's fit
  double point_sigma_floor_px = 0.05;  // floor of a pair's residual scatter (subpixel quantisation of the peak)
  // Filter over the pairs.
  double initial_rotation_sigma_deg = 0.5;  // before the first pair: the head as calibrated, within half a degree
  double initial_focal_sigma = 0.005;
  // Drift followed: with a pair every 1/8 s the filter averages over about 2 s, so 0.1 deg per minute lags by
  // 0.003 deg; a faster change is a step.
  double rotation_walk_deg_sqrt_s = 0.0005;
  double focal_walk_sqrt_s = 5e-6;
  double pair_sigma_floor_deg = 0.003;  // per-pair disturbances beyond point noise (camera sync, rolling shutter)
  double gate_chi2 = 18.47;             // a pair's estimate against the filter's (4 dof, 99.9 %)
  int step_pairs = 8;  // this many pairs outside the gate in a row, and their mean too: a step; restart from it
  // Decisions.
  double alarm_px = 0.5;     // rows apart by more than this somewhere in the image: alarm (half the row spacing)
  int alarm_pairs = 8;       // ... by the mean of this many last pairs (and beyond its noise, gate_chi2)
  double certain_px = 0.05;  // certain: the estimate's row and column offsets' std below this everywhere
  double apply_px = 0.1;     // a certain estimate this far from the correction in use replaces it
  // Pairs probed at about this rate at most [Hz], by their stamps: the pair counts above (step_pairs, alarm_pairs) are
  // set for the paper's 8 Hz head, and a pair's probe costs half the tracker's time on it. A pair less than three
  // quarters of the period after the last probed one is skipped: a head at this rate or slower keeps every pair
  // whatever its stamps' jitter, a 20 Hz head has every second one probed.
  double max_rate_hz = 8.0;
};

// Reads the `integrity/` section of a tracker config (keys as in config/tracker.yaml); the others keep their
// defaults. Throws ConfigError on a bad value.
IntegrityParams loadIntegrityParams(const Config& cfg);

// The vertical disparity of one left corner.
struct VerticalMatch {
  float xl = 0, y = 0;  // left pixel (the corner's)
  float xr = 0;         // right column (subpixel)
  float dy = 0;         // right row - left row (subpixel)
  float ncc = 0;
};

// Each corner's template searched in the right image over the matcher's disparity range on rows y - search_rows ..
// y + search_rows; the best correlation above min_ncc, unique (no other peak more than one row or column away within
// `uniqueness`: a corner on an edge has none along it), and not on the band's edge, refined to subpixel in both
// directions by parabolas through its neighbours.
std::vector<VerticalMatch> matchAcrossRows(const cv::Mat& left8, const cv::Mat& right8,
                                           const std::vector<Corner>& corners, const MatcherParams& matcher,
                                           const IntegrityParams& params);

// What the monitor says after a pair; one to one with ips_integrity_t.
struct IntegrityStatus {
  enum class State : int8_t { NoData = 0, Ok = 1, Alarm = 2 };  // = STATE_* of the message
  int64_t utime = 0;
  State state = State::NoData;
  // This pair's vertical disparities in the rectification in use.
  int num_probes = 0, num_points = 0, num_outliers = 0;
  double dy_median_px = 0, dy_rms_px = 0;  // over the pair's inliers (rms about zero)
  double pair_offset_px = 0;               // the pair's estimate: largest row offset it leaves in the image
  bool pair_valid = false;
  double pair_chi2 = 0;  // the pair's estimate against the correction in use (4 dof)
  double pair_nis = 0;   // ... against the filter's estimate
  // The filter's estimate of the correction the head needs (relative to the calibration file), with covariance
  // [wx wy wz s] (rad, rad, rad, 1).
  RightCameraCorrection estimate;
  Eigen::Matrix4d covariance = Eigen::Matrix4d::Zero();
  double estimate_offset_px = 0;  // largest row offset the correction in use leaves, by the estimate
  double estimate_sigma_px = 0;   // the estimate's std of row and column offsets, largest in the image
  bool certain = false;           // estimate_sigma_px below certain_px (and no step under way)
  // The correction the tracker and E3D rectify with, and the stamp of the pair that decided it (it applies to pairs
  // after that one).
  RightCameraCorrection applied;
  int64_t applied_utime = 0;
  bool applied_now = false;  // this pair changed it
  // Counters since start.
  int64_t alarms = 0, steps = 0, corrections = 0, pairs_without_measurement = 0, pairs_outside_gate = 0;
};

class EpipolarMonitor {
 public:
  // The rectified geometry of the pairs (f, cx, cy, size). Throws std::invalid_argument on bad parameters.
  EpipolarMonitor(const StereoRectification& rect, const IntegrityParams& params);

  // One rectified pair's vertical matches (rectified with status().applied); time must increase (an older pair
  // is ignored: returns the status unchanged).
  const IntegrityStatus& update(int64_t utime, const std::vector<VerticalMatch>& matches, int num_probes);
  const IntegrityStatus& status() const { return status_; }
  // Whether the pair with this stamp is probed (max_rate_hz since the last probed one).
  bool due(int64_t utime) const {
    return params_.enabled && (last_utime_ <= 0 || (utime - last_utime_) * 1e-6 * params_.max_rate_hz >= 0.75);
  }
  const IntegrityParams& params() const { return params_; }

  // Row offset [px] the correction c leaves at rectified pixel (x, y): the model above.
  double rowOffset(const Eigen::Vector4d& c, double x, double y) const;
  // Largest |rowOffset| over the image's border points, and the largest std of it under covariance P.
  double largestOffset(const Eigen::Vector4d& c) const;
  double largestSigma(const Eigen::Matrix4d& P) const;
  // The same over rows and columns together: the correction moves columns too, dx = f (u v wx + v wz + u s) (the yaw
  // moves rows only, RightCameraCorrection), which is a change of disparity.
  double largestImageOffset(const Eigen::Vector4d& c) const;
  double largestImageSigma(const Eigen::Matrix4d& P) const;

 private:
  Eigen::Matrix<double, 1, 4> row(double x, double y) const;
  Eigen::Matrix<double, 2, 4> rowAndColumn(double x, double y) const;  // row offset, column offset per term
  void kalmanUpdate(const Eigen::Vector4d& z, const Eigen::Matrix4d& S);
  // The mean of the last `pairs` pairs' estimates (fewer when fewer are held) and their mean covariance.
  void recentMean(int pairs, Eigen::Vector4d& z, Eigen::Matrix4d& S) const;

  StereoRectification rect_;  // geometry only (maps not kept)
  IntegrityParams params_;
  std::vector<Eigen::Vector2d> border_;  // where the largest offsets are evaluated
  Eigen::Vector4d x_ = Eigen::Vector4d::Zero();
  Eigen::Matrix4d P_;
  int64_t last_utime_ = 0;
  int outside_run_ = 0;
  std::deque<std::pair<Eigen::Vector4d, Eigen::Matrix4d>> recent_;  // the last pairs' estimates and covariances
  IntegrityStatus status_;
};

// The monitor on a tracker's last pair (StereoTracker::process first): up to max_probes of its corners, taken evenly,
// searched across rows; when the monitor hands out a new correction, the tracker rectifies the following pairs with
// it. A disabled monitor (params().enabled false), or a pair that is not due (EpipolarMonitor::due), does nothing and
// returns the status unchanged.
const IntegrityStatus& monitorPair(EpipolarMonitor& monitor, StereoTracker& tracker, int64_t utime);

Eigen::Vector4d toVector(const RightCameraCorrection& c);
RightCameraCorrection toCorrection(const Eigen::Vector4d& v);

}  // namespace ips::tracker
