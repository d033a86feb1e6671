#pragma once
// The simulated head in its world on its trajectory, ready to render: what a simulation draws its pairs and truth
// from. Evaluations and tests that need rendered pairs and true poses but not the sensor streams build one of these;
// Simulation adds the IMU, the tilt sensor and the arrival order.
#include "ips/sim/stereo_renderer.hpp"
#include "ips/sim/scenario.hpp"
#include "ips/sim/sensors.hpp"
#include "ips/sim/trajectory.hpp"
#include "ips/sim/world.hpp"

namespace ips::sim {

struct Rig {
  // Validates the scenario (std::invalid_argument naming the bad entry).
  explicit Rig(const Scenario& scenario);
  // The renderer refers to the members: a rig stays where it was built.
  Rig(const Rig&) = delete;
  Rig& operator=(const Rig&) = delete;

  Scenario scenario;
  Trajectory trajectory;  // before the world: its people keep clear of the walker
  World world;
  SensorHead head;
  StereoRenderer renderer;
};

}  // namespace ips::sim
