#pragma once
// The navigation state of the IPS filter (paper section 4.2): position, velocity, acceleration, accelerometer
// bias, angular rate, gyro bias (three each) and the attitude quaternion = 22 elements. The covariance is kept
// over a 21-dimensional error state in which the attitude error is a 3-vector (rotation vector in world).
// The optional states (parts of the head's calibration, when estimated online; their registry is
// ips/filter/optional_states.hpp) extend it, and so do stochastic clones of the body pose at image times, 6 each.
//
// Frames: world = local level, z up, gravity (0, 0, -g). Body = the IMU frame. The quaternion maps body to
// world. This is one to one the content of lcmtypes/ips_filter_state_t.lcm.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <vector>

#include "ips/kinematic_state.hpp"
#include "ips/rotation.hpp"

namespace ips::filter {

// Offsets into the 21-dimensional error state (and into filter_state_t.covariance).
enum ErrorIndex : int {
  kErrP = 0,    // position [m], world
  kErrV = 3,    // velocity [m/s], world
  kErrA = 6,    // acceleration (gravity removed) [m/s^2], world
  kErrBa = 9,   // accelerometer bias [m/s^2], body
  kErrW = 12,   // angular rate (bias removed) [rad/s], body
  kErrBg = 15,  // gyro bias [rad/s], body
  kErrTh = 18,  // attitude error, rotation vector in world: R_true = Exp(dtheta) * R_est
  kCoreErrorDim = 21,
  kCloneErrorDim = 6,  // per clone: position, attitude error (same conventions)
};
constexpr int kStateElements = 22;

// The optional states (the head's calibration, estimated when the configuration says so), in the error state's order
// after the core. What each is, its dimension and prior: the registry, ips/filter/optional_states.hpp.
enum OptionalState : int {
  kLeverArm,
  kDeltaScale,
  kDeltaDirection,
  kDeltaRotationDrift,
  kTiltOffset,
  kCameraAlignment,
  kOptionalStateCount
};

using Vector21d = Eigen::Matrix<double, 21, 1>;
using Matrix21d = Eigen::Matrix<double, 21, 21>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

// The filter's estimate of the body's motion and its IMU's biases (the same type as the ground truth).
struct NavState : InertialState {
  // The 22 elements in the order of filter_state_t (p v a ba w bg q[w x y z]).
  Eigen::Matrix<double, 22, 1> toVector() const;
  static NavState fromVector(const Eigen::Matrix<double, 22, 1>& x, int64_t utime);
};

// A stochastic clone: the body pose at an image time, kept in the state so that a relative pose between two
// image times is a proper measurement.
struct PoseClone {
  int64_t utime = 0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
};

// Mean of the estimator: the navigation state, the optional states that are estimated, then the clones (oldest
// first). Error-state layout: [21 core | each present optional state, in the registry's order | 6 per clone].
struct FullState {
  NavState nav;
  // Camera 0's origin in the IMU frame (T_imu_cam0's translation) [m], when the filter estimates it; otherwise the
  // measurement models take the calibration's.
  std::optional<Eigen::Vector3d> lever_arm;
  // The tracker's translations are (1 + delta_scale) times the true ones, when the filter estimates it
  // (FilterParams::estimate_delta_scale); otherwise they are taken as true to scale.
  std::optional<double> delta_scale;
  // The tracker's translations are turned by the small rotation delta_direction (camera 0 at the older image) against
  // the true ones, (1 + delta_scale) (I + [delta_direction]x) t, when the filter estimates it
  // (FilterParams::estimate_delta_direction); their rotations are not.
  std::optional<Eigen::Vector3d> delta_direction;
  // The tracker's rotations err by Exp(|t| delta_rotation_drift) (camera 0 at the older image; |t| the step's measured
  // length [m]) against the true ones, when the filter estimates it (FilterParams::estimate_delta_rotation_drift).
  std::optional<Eigen::Vector3d> delta_rotation_drift;
  // The tilt sensor's constant offsets [rad]: it reads (angle_x, angle_y) + tilt_offset, when the filter estimates
  // them (FilterParams::estimate_tilt_offset); otherwise they are part of its white noise.
  std::optional<Eigen::Vector2d> tilt_offset;
  // The camera's rotation against the calibration's, when the filter estimates it
  // (FilterParams::estimate_camera_alignment): T_imu_cam0's rotation is R_calibration * camera_alignment. Its error
  // acts from the right, in camera 0: camera_alignment_true = camera_alignment * Exp(dphi).
  std::optional<Eigen::Quaterniond> camera_alignment;
  std::vector<PoseClone> clones;

  // The offset of optional state id in the error state (valid only when it is present; kOptionalStateCount: the end
  // of the present ones), the dimensions of all present ones, and the offset of clone i.
  int offset(OptionalState id) const;
  int optionalDim() const;
  int cloneOffset(int i) const { return kCoreErrorDim + optionalDim() + kCloneErrorDim * i; }
  int errorDim() const { return cloneOffset(static_cast<int>(clones.size())); }
  // Index of the clone taken at utime, or -1.
  int findClone(int64_t utime) const;
};

// The same on the 21-dimensional core (navigation state only).
NavState boxplus(const NavState& x, const Eigen::Ref<const Vector21d>& dx);
Vector21d boxminus(const NavState& a, const NavState& b);

// x (+) dx: apply an error-state vector of size errorDim() (attitude errors act from the left, in world).
FullState boxplus(const FullState& x, const Eigen::Ref<const Eigen::VectorXd>& dx);
// The same, written into `out`, which must already have x's clone layout (no allocation).
void boxplusInto(const FullState& x, const Eigen::Ref<const Eigen::VectorXd>& dx, FullState& out);
// a (-) b: the error-state vector taking b to a (same layout required: the optional states and the clones).
Eigen::VectorXd boxminus(const FullState& a, const FullState& b);

// The start frame (FilterParams::output_frame): the world frame as the filter knew it when it took the clone `start`
// (its first image's pose as it was then), carried by `anchor`, its current estimate of that pose. Positions map as
// C (p - p_anchor) + p_start with C = R_start R_anchor^T; velocity, acceleration and attitude by C; the body-frame
// states stay.
NavState toStartFrame(const NavState& nav, const PoseClone& anchor, const PoseClone& start);
// The derivative of that map by x's error state, clone `anchor` being the anchor (21 x errorDim()): the start frame's
// covariance is J P J^T.
Eigen::MatrixXd startFrameJacobian(const FullState& x, int anchor, const PoseClone& start);

// SO(3): the project's maps (ips/rotation.hpp).
using ips::expQuat;
using ips::expSO3;
using ips::logQuat;
using ips::logSO3;
using ips::rightJacobianSO3;
using ips::skew;

}  // namespace ips::filter
