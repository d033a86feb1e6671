#pragma once
// The motion of a body at one instant, and with its IMU's biases the inertial state: one type for every truth the
// project holds (the simulator's trajectories, a recording's ground truth, the ground_truth_t message) and the base
// of the filter's navigation state. World: local level, z up, gravity (0, 0, -g). Body: the IMU frame.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>

namespace ips {

struct KinematicState {
  int64_t utime = 0;                                                // [us]
  Eigen::Vector3d position = Eigen::Vector3d::Zero();               // body in world [m]
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();               // [m/s] in world
  Eigen::Vector3d acceleration = Eigen::Vector3d::Zero();           // [m/s^2] in world, kinematic (no gravity)
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  // body to world
  Eigen::Vector3d angular_rate = Eigen::Vector3d::Zero();           // [rad/s] of body against world, in body

  Eigen::Isometry3d pose() const {  // T_world_body
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.linear() = orientation.toRotationMatrix();
    t.translation() = position;
    return t;
  }
  // What an ideal accelerometer in the body measures: R^T (a - g_world), g_world = (0, 0, -gravity).
  Eigen::Vector3d specificForce(double gravity) const {
    return orientation.conjugate() * (acceleration + Eigen::Vector3d(0, 0, gravity));
  }
};

// A body carrying an IMU: its motion and the IMU's biases. The ground truth (ground_truth_t one to one: the true
// biases of a simulated IMU, EuRoC's estimated ones) and the filter's navigation state (its estimate of the same).
struct InertialState : KinematicState {
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();   // [rad/s] in body
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();  // [m/s^2] in body
};

}  // namespace ips
