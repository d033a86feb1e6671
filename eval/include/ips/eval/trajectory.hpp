#pragma once
// Trajectory evaluation: TUM files, SE(3) alignment, ATE, relative error per distance, end-point error as a
// share of the distance travelled (the paper's figure), NEES, and a top-down plot.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <string>
#include <vector>

#include "ips/filter/estimator.hpp"

namespace ips::eval {

struct TrajPoint {
  double t = 0;  // [s]
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
};
using Trajectory = std::vector<TrajPoint>;

// TUM format: "t tx ty tz qx qy qz qw" per line, '#' comments. Throws std::runtime_error naming the file/line.
Trajectory readTum(const std::string& path);
void writeTum(const std::string& path, const Trajectory& traj);

// The reference interpolated at the times of `est` (linear / slerp); estimate points outside the reference's
// time span, or further than max_gap_s from a reference sample, are dropped. Returns the matched pairs.
void associate(const Trajectory& est, const Trajectory& ref, double max_gap_s, Trajectory* est_out,
               Trajectory* ref_out);

// A step in a ground truth's positions: between two consecutive samples the position moved by `step` more than the
// neighbouring increments say, at time t (the later sample's) [s].
struct PositionStep {
  double t = 0;
  Eigen::Vector3d step = Eigen::Vector3d::Zero();
};
// What a step must exceed, as the acceleration [m/s^2] that moves a head by it within one sample interval (step =
// a dt^2): 5 g, beyond what a walked, flown or driven head does between two samples of its truth (at 200 Hz 1.25 mm,
// at 10 Hz 0.5 m), while the increments of a smooth motion differ by a jerk's dt^3.
constexpr double kTruthStepAcceleration = 50.0;
// Removes the position steps of a ground truth sampled at a steady rate: each increment is compared with the mean of
// the increments before and after it (scaled by the intervals), and where it differs by more than
// max_acceleration dt^2 the difference is taken off every later position. Attitudes are kept. A motion capture's or
// a fused truth's re-acquisition leaves such steps (EuRoC MH_01: 4.9 mm in one 5 ms sample), which no estimator can
// follow and every estimator would be judged by. Samples further apart than twice their neighbours' interval are not
// judged. Returns the steps removed, in time order.
std::vector<PositionStep> removePositionSteps(Trajectory& truth, double max_acceleration = kTruthStepAcceleration);

// Rigid transform T (no scale) minimising sum |ref_i - T est_i|^2 (Umeyama / Horn). Needs >= 3 points.
Eigen::Isometry3d alignSE3(const Trajectory& est, const Trajectory& ref);

struct TrajectoryErrors {
  size_t matched = 0;
  double distance_m = 0;        // path length of the reference
  double ate_rmse_m = 0;        // after SE(3) alignment
  double rpe_percent = 0;       // mean translation error of segments of `segment_m` / segment length
  double endpoint_error_m = 0;  // no alignment (both start in the same frame)
  double endpoint_percent = 0;  // endpoint_error_m / distance_m * 100
};
// The trajectory's path length [m].
double distanceTravelled(const Trajectory& traj);

// The two-sided 95 % band of a chi-square variable with 3 degrees of freedom (a consistent filter's position NEES,
// one sample): its 2.5 % and 97.5 % quantiles.
constexpr double kChi2Dof3Lo = 0.2158, kChi2Dof3Hi = 9.3484;

// RMSE of the positions after alignSE3 (absolute trajectory error); both associated, >= 3 points.
double ateRmse(const Trajectory& est, const Trajectory& ref);

// Both trajectories must already be associated (same length, same times).
TrajectoryErrors evaluate(const Trajectory& est, const Trajectory& ref, double segment_m);

// Relative pose error as the KITTI odometry devkit computes it, but with every frame a start: for each start i
// and each length L, the first j whose path distance along the reference from i reaches L; the error of the
// relative motion E = inv(est_i^-1 est_j) (ref_i^-1 ref_j); translation |t(E)| / L and rotation angle(E) / L,
// averaged over all such sub-sequences. Lengths without any sub-sequence are skipped (and counted in `lengths`).
struct RelativeErrors {
  size_t subsequences = 0;
  size_t lengths = 0;          // lengths that had at least one sub-sequence
  double trans_pct = NAN;      // mean |t(E)| / L * 100
  double rot_deg_per_m = NAN;  // mean angle(E) / L in deg/m
};
RelativeErrors relativeErrors(const Trajectory& est, const Trajectory& ref, const std::vector<double>& lengths_m);

// The estimate expressed in the reference's frame by its first pose only (est_0 := ref_0, no other alignment):
// the end-point error of dead reckoning from a known start (the paper's figure).
Trajectory alignFirstPose(const Trajectory& est, const Trajectory& ref);

// End-point error [m] after alignFirstPose; both associated (same length, same times).
double endErrorFirstPoseAligned(const Trajectory& est, const Trajectory& ref);

// NEES of the pose (position and attitude error, 6 dof) of one filter output against the truth.
double poseNees(const filter::FilterOutput& out, const filter::NavState& truth);
// NEES of the full 21-dimensional error state.
double fullNees(const filter::FilterOutput& out, const filter::NavState& truth);

Trajectory toTrajectory(const std::vector<filter::FilterOutput>& outputs);

// The pose at time t: position linear, attitude slerp between the neighbouring poses; the end poses outside.
TrajPoint interpolate(const Trajectory& traj, double t);

// Each pose of `traj` (frame a in the world) times T_a_b: the trajectory of frame b, rigidly attached to a (the truth
// of the body carried to camera 0 with T_imu_cam0; camera 0 carried to the body with its inverse).
Trajectory rigidlyAttached(const Trajectory& traj, const Eigen::Isometry3d& T_a_b);

// A measured relative pose between times t0 and t1 (X_t0 = T X_t1, as the tracker's deltas) with its covariance
// (translation, then rotation vector).
struct RelativePoseMeasurement {
  double t0 = 0, t1 = 0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Identity();
};
// How honest such measurements' covariance is against the truth's poses (of the same frame): the mean NEES of the
// translation and of the rotation (3 dof each: 3 when honest) over the measurements inside the truth, and the lag-1
// correlation of the translation errors (0 for white errors, as a filter takes them).
struct DeltaConsistency {
  int deltas = 0;
  double nees_translation = NAN, nees_rotation = NAN, lag1_correlation = NAN;
};
DeltaConsistency deltaConsistency(const std::vector<RelativePoseMeasurement>& deltas, const Trajectory& truth);

// Top-down (x-y) plot of a reference and any number of estimates, written as PNG.
void plotTopDown(const std::string& path, const Trajectory& ref, const std::vector<Trajectory>& estimates,
                 const std::vector<std::string>& labels);

}  // namespace ips::eval
