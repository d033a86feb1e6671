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
      world(World::build(scenario.world, scenario.seed)),
      head(SensorHead::make(scenario)),
      trajectory(scenario.trajectory, scenario.gravity),
      renderer(scenario, world, head, trajectory) {}

}  // namespace ips::sim
