#pragma once
// The registry of the filter's optional states: the parts of the head's calibration the filter can estimate online.
// One entry each, with a comment on how it enters the measurements: its name (FILTER_STATE's calibration[].name, the
// report's key), unit, its value in FullState, the configuration's switch, its prior sigma, random walk and start.
// The error state holds the present ones in the registry's order after the core (FullState::offset); the estimator
// starts them, the filters propagate, apply and difference them, and the output and the message carry them, all by
// this table. Adding a state: a value in FullState, its entry here, its parameters and the term of its model.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <tuple>

#include "ips/filter/params.hpp"
#include "ips/filter/state.hpp"

namespace ips::filter {

// How a state's value type takes an error-state step: vectors add it, a rotation composes it from the right (its
// error acts in its own frame: R_true = R Exp(dphi)). value() is what the output carries (a rotation's rotation
// vector).
template <class T>
struct OptionalValue;
template <int N>
struct OptionalValue<Eigen::Matrix<double, N, 1>> {
  using Type = Eigen::Matrix<double, N, 1>;
  static constexpr int kDim = N;
  static void add(Type& v, const Eigen::Ref<const Eigen::VectorXd>& dx) { v += dx; }
  static Eigen::VectorXd minus(const Type& a, const Type& b) { return a - b; }
  static Eigen::VectorXd value(const Type& v) { return v; }
};
template <>
struct OptionalValue<double> {
  static constexpr int kDim = 1;
  static void add(double& v, const Eigen::Ref<const Eigen::VectorXd>& dx) { v += dx(0); }
  static Eigen::VectorXd minus(double a, double b) { return Eigen::VectorXd::Constant(1, a - b); }
  static Eigen::VectorXd value(double v) { return Eigen::VectorXd::Constant(1, v); }
};
template <>
struct OptionalValue<Eigen::Quaterniond> {
  static constexpr int kDim = 3;
  static void add(Eigen::Quaterniond& q, const Eigen::Ref<const Eigen::VectorXd>& dx) {
    q = (q * expQuat(Eigen::Vector3d(dx))).normalized();
  }
  static Eigen::VectorXd minus(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
    return logQuat(b.conjugate() * a);
  }
  static Eigen::VectorXd value(const Eigen::Quaterniond& q) { return logQuat(q); }
};

template <class T>
struct OptionalStateSpec {
  using Value = OptionalValue<T>;
  OptionalState id;
  const char* name;
  const char* unit;  // of the value and its sigma ("" for none)
  std::optional<T> FullState::*value;
  bool FilterParams::*estimate;                     // the configuration's switch
  double FilterParams::*prior_sigma;                // per dimension, of the start
  double ProcessNoise::*random_walk_psd;            // per dimension [unit^2/s]; nullptr: a constant
  T (*start)(const Eigen::Isometry3d& T_imu_cam0);  // the value it starts from (before anything is learnt)
  static constexpr int kDim = Value::kDim;
};

inline constexpr auto kOptionalStates = std::make_tuple(
    // camera 0's origin in the IMU frame (T_imu_cam0's translation): the deltas' and image models' lever arm
    OptionalStateSpec<Eigen::Vector3d>{kLeverArm, "lever_arm", "m", &FullState::lever_arm,
                                       &FilterParams::estimate_lever_arm, &FilterParams::lever_arm_sigma, nullptr,
                                       [](const Eigen::Isometry3d& T) { return Eigen::Vector3d(T.translation()); }},
    // the tracker's translations are (1 + delta_scale) times the true ones
    OptionalStateSpec<double>{kDeltaScale, "delta_scale", "", &FullState::delta_scale,
                              &FilterParams::estimate_delta_scale, &FilterParams::delta_scale_sigma,
                              &ProcessNoise::delta_scale_psd, [](const Eigen::Isometry3d&) { return 0.0; }},
    // the tracker's translations are turned by (I + [delta_direction]x) (camera 0 at the older image)
    OptionalStateSpec<Eigen::Vector3d>{kDeltaDirection, "delta_direction", "rad", &FullState::delta_direction,
                                       &FilterParams::estimate_delta_direction, &FilterParams::delta_direction_sigma,
                                       &ProcessNoise::delta_direction_psd,
                                       [](const Eigen::Isometry3d&) { return Eigen::Vector3d::Zero().eval(); }},
    // the tracker's rotations err by Exp(|t| delta_rotation_drift) (|t| the step's length, camera 0)
    OptionalStateSpec<Eigen::Vector3d>{kDeltaRotationDrift, "delta_rotation_drift", "rad_per_m",
                                       &FullState::delta_rotation_drift, &FilterParams::estimate_delta_rotation_drift,
                                       &FilterParams::delta_rotation_drift_sigma,
                                       &ProcessNoise::delta_rotation_drift_psd,
                                       [](const Eigen::Isometry3d&) { return Eigen::Vector3d::Zero().eval(); }},
    // the tilt sensor reads its two angles plus these constant offsets
    OptionalStateSpec<Eigen::Vector2d>{kTiltOffset, "tilt_offset", "rad", &FullState::tilt_offset,
                                       &FilterParams::estimate_tilt_offset, &FilterParams::tilt_sigma, nullptr,
                                       [](const Eigen::Isometry3d&) { return Eigen::Vector2d::Zero().eval(); }},
    // T_imu_cam0's rotation is the calibration's times this rotation (camera 0): the deltas' and image models'
    OptionalStateSpec<Eigen::Quaterniond>{kCameraAlignment, "camera_alignment", "rad", &FullState::camera_alignment,
                                          &FilterParams::estimate_camera_alignment,
                                          &FilterParams::camera_alignment_sigma, nullptr,
                                          [](const Eigen::Isometry3d&) { return Eigen::Quaterniond::Identity(); }});

static_assert(std::tuple_size_v<decltype(kOptionalStates)> == kOptionalStateCount,
              "every optional state has one registry entry");
constexpr bool registryInIdOrder() {
  int i = 0;
  bool in_order = true;
  std::apply([&](const auto&... spec) { ((in_order = in_order && spec.id == i++), ...); }, kOptionalStates);
  return in_order;
}
static_assert(registryInIdOrder(), "the registry lists the states in the order of OptionalState");

// f(spec) for each entry, in the registry's (and the error state's) order.
template <class F>
void forEachOptionalState(F&& f) {
  std::apply([&](const auto&... spec) { (f(spec), ...); }, kOptionalStates);
}

// The error dimensions of a state (present or not).
constexpr int optionalStateDim(OptionalState id) {
  int dim = 0;
  std::apply([&](const auto&... spec) { ((dim = spec.id == id ? spec.kDim : dim), ...); }, kOptionalStates);
  return dim;
}

}  // namespace ips::filter
