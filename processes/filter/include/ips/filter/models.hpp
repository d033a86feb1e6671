#pragma once
// Process and measurement models of the IPS filter. Both filters use the same functions: the EKF their
// analytic Jacobians, the UKF only the functions themselves.
//
// Process (continuous, between any two measurement times): p' = v, v' = a, a' = jerk noise, w' = angular
// acceleration noise, biases random walks, q' = 1/2 q (x) (0, w) with w the body angular rate.
// Measurements: IMU sample (gyro = w + bg, accel = R^T (a + g e_z) + ba), tilt sample (inclination of the
// tilt sensor's x and y axes against the horizontal), tracker delta (relative pose of camera 0 between two
// image times, a function of two pose clones).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <deque>

#include "ips/filter/params.hpp"
#include "ips/filter/state.hpp"

namespace ips::filter {

// Mean propagation of the navigation state over dt [s] (exact for the constant-rate model).
NavState propagateNav(const NavState& x, double dt);
// Error-state transition: d(propagateNav(x (+) dx, dt)) / d(dx) at dx = 0.
Matrix21d processJacobian(const NavState& x, double dt);
// Discrete process noise over dt (integrated white jerk, angular acceleration and bias random walks);
// attitude-rate correlation uses the attitude at the end of the step.
Matrix21d processNoise(const NavState& x_end, double dt, const ProcessNoise& q);

// The head's motion as its IMU shows it, for the process noise (ProcessNoise::from_imu). Under the model, the
// acceleration (and the angular rate) of two consecutive samples differ by the jerk's (angular acceleration's)
// integral over dt, of variance psd dt, and by two draws of the sensor's white noise: psd = (E[df^2] - 2 sigma^2) / dt
// per axis, the mean square of the differences taken over the last window_s. The largest axis is taken (the model's
// noise is the same on every axis); what exceeds the configured densities is vibration (ProcessNoise::vibration_*).
// Deterministic in the samples, so a replay gives the same states.
class MotionNoise {
 public:
  MotionNoise(const ProcessNoise& floor, const ImuNoise& imu);
  void add(int64_t utime, const Eigen::Vector3d& angular_rate, const Eigen::Vector3d& specific_force);
  // The configured process noise with the vibration the samples show.
  const ProcessNoise& current() const { return current_; }

 private:
  struct Difference {
    int64_t utime = 0;
    Eigen::Vector3d gyro2, accel2;  // squared differences per axis, over dt
  };
  ProcessNoise floor_, current_;
  double gyro_var_ = 0, accel_var_ = 0;  // the sensor's white noise per sample
  int64_t max_dt_us_ = 0, window_us_ = 0;
  int64_t last_utime_ = INT64_MIN;
  Eigen::Vector3d last_w_ = Eigen::Vector3d::Zero(), last_f_ = Eigen::Vector3d::Zero();
  std::deque<Difference> window_;
  Eigen::Vector3d gyro_sum_ = Eigen::Vector3d::Zero(), accel_sum_ = Eigen::Vector3d::Zero();
};

// Residual vector of a measurement: at most 6 elements, kept on the stack.
using MeasVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 6, 1>;
using MeasMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 6, 6>;

// A measurement model. residual() = z (-) h(x); jacobian() = d h(x (+) dx) / d dx at dx = 0 (m x errorDim),
// so that residual(x (+) dx) ~= residual(x) - H dx.
class Measurement {
 public:
  virtual ~Measurement() = default;
  virtual int dim() const = 0;
  virtual MeasVector residual(const FullState& x) const = 0;
  virtual Eigen::MatrixXd jacobian(const FullState& x) const = 0;
  virtual MeasMatrix noise() const = 0;
  // True if h depends on the navigation state only (not on the clones): the UKF then needs sigma points
  // along the first 21 Cholesky columns only (the others leave h unchanged), which is exact.
  virtual bool coreOnly() const { return true; }
};

class ImuMeasurement : public Measurement {
 public:
  ImuMeasurement(const Eigen::Vector3d& angular_rate, const Eigen::Vector3d& specific_force, double gravity,
                 double gyro_sigma, double accel_sigma);
  int dim() const override { return 6; }
  MeasVector predict(const NavState& x) const;
  MeasVector residual(const FullState& x) const override;
  Eigen::MatrixXd jacobian(const FullState& x) const override;
  MeasMatrix noise() const override;

 private:
  Eigen::Vector3d gyro_, accel_;
  double gravity_, gyro_var_, accel_var_;
};

// Tilt angles of an inclinometer: the inclination of the tilt sensor's x and y axes against the plane normal
// to the vector it senses, angle_x = asin(f_x / |f|) with f in the tilt frame (positive when the x axis points
// up). An accelerometer-type inclinometer senses the specific force f = R^T (a + g e_z), so while the head
// accelerates it does not measure the attitude alone; with `specific_force` false it is modelled as sensing
// gravity only (f = R^T g e_z). R_body_tilt = R_imu_cam0 * R_tilt_cam0^T. `offset_state`: the state holds the
// sensor's constant offsets (FullState::tilt_offset), which add to the angles; sigma is then its white noise alone.
class TiltMeasurement : public Measurement {
 public:
  TiltMeasurement(double angle_x, double angle_y, const Eigen::Matrix3d& R_body_tilt, double sigma,
                  double gravity = 9.81, bool specific_force = true, bool offset_state = false);
  int dim() const override { return 2; }
  // Angles of a sensor at rest (gravity only).
  static Eigen::Vector2d predict(const Eigen::Quaterniond& q_world_body, const Eigen::Matrix3d& R_body_tilt);
  // Angles for a sensed vector u in world (g e_z at rest, a + g e_z for the specific force).
  static Eigen::Vector2d predict(const Eigen::Quaterniond& q_world_body, const Eigen::Matrix3d& R_body_tilt,
                                 const Eigen::Vector3d& u_world);
  MeasVector residual(const FullState& x) const override;
  Eigen::MatrixXd jacobian(const FullState& x) const override;
  MeasMatrix noise() const override;
  bool coreOnly() const override { return !offset_state_; }

 private:
  Eigen::Vector3d sensed(const NavState& x) const;
  Eigen::Vector2d z_;
  Eigen::Matrix3d R_body_tilt_;
  double var_;
  double gravity_;
  bool specific_force_;
  bool offset_state_;
};

// Relative pose of camera 0 between clone i0 (older) and clone i1: X_c0(t0) = R * X_c0(t1) + t. Residual
// [t_meas - t_pred; Log(R_meas R_pred^T)] (rotation error in camera 0 at t0), covariance order [t, rotvec].
// T_imu_cam0 is the calibration's, with the state's translation (the lever arm) and the state's camera alignment
// where the filter estimates them. `from_tracker` (a delta of the tracker): the measured translation is
// (1 + delta_scale) (I + [delta_direction]x) t where the state holds the tracker's scale error and the turn of its
// steps (the disparity errors the tracker has not found scale and turn every step alike), and its measured rotation is
// Exp(|t_meas| delta_rotation_drift) R where the state holds the tracker's rotation drift; a delta from elsewhere (the
// dense maps' alignment) is taken as it is.
class DeltaMeasurement : public Measurement {
 public:
  DeltaMeasurement(int clone0, int clone1, const Eigen::Isometry3d& T_c0_c1, const Matrix6d& covariance,
                   const Eigen::Isometry3d& T_imu_cam0, bool from_tracker = false);
  int dim() const override { return 6; }
  static Eigen::Isometry3d predict(const PoseClone& c0, const PoseClone& c1, const Eigen::Isometry3d& T_imu_cam0);
  MeasVector residual(const FullState& x) const override;
  Eigen::MatrixXd jacobian(const FullState& x) const override;
  MeasMatrix noise() const override { return cov_; }
  bool coreOnly() const override { return false; }

 private:
  double scaleOf(const FullState& x) const { return from_tracker_ && x.delta_scale ? 1.0 + *x.delta_scale : 1.0; }
  // I + [delta_direction]x for the tracker's deltas, else I.
  Eigen::Matrix3d turnOf(const FullState& x) const;
  // |t_meas| delta_rotation_drift for the tracker's deltas, else 0.
  Eigen::Vector3d rotationDriftOf(const FullState& x) const;
  int i0_, i1_;
  Eigen::Isometry3d z_;
  Matrix6d cov_;
  Eigen::Isometry3d T_imu_cam0_;
  bool from_tracker_;
};

// Relative rotation of camera 0 between clone i0 (older) and clone i1, alone: the tracker's rotation from far
// points (paper section 6), which carries no translation. Residual Log(R_meas R_pred^T) as DeltaMeasurement's
// rotation part, covariance 3x3.
class RotationMeasurement : public Measurement {
 public:
  RotationMeasurement(int clone0, int clone1, const Eigen::Matrix3d& R_c0_c1, const Eigen::Matrix3d& covariance,
                      const Eigen::Isometry3d& T_imu_cam0);
  int dim() const override { return 3; }
  MeasVector residual(const FullState& x) const override;
  Eigen::MatrixXd jacobian(const FullState& x) const override;
  MeasMatrix noise() const override { return cov_; }
  bool coreOnly() const override { return false; }

 private:
  int i0_, i1_;
  Eigen::Matrix3d z_;
  Eigen::Matrix3d cov_;
  Eigen::Isometry3d T_imu_cam0_;
};

// Quantile of the chi-square distribution with `dof` degrees of freedom: P(X <= x) = p.
double chiSquareQuantile(double p, int dof);
// Its cumulative distribution function.
double chiSquareCdf(double x, int dof);

}  // namespace ips::filter
