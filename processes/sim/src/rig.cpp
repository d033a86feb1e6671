#include "ips/sim/rig.hpp"

namespace ips::sim {
namespace {

Scenario validated(const Scenario& scenario) {
  scenario.validate();
  return scenario;
}

}  // namespace

Rig::Rig(const Scenario& s)
    : scenario(validated(s)),
      trajectory(scenario.trajectory, scenario.gravity),
      world(World::build(scenario.world, scenario.seed, &trajectory)),
      head(SensorHead::make(scenario)),
      renderer(scenario, world, head, trajectory) {}

}  // namespace ips::sim
