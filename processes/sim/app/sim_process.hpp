#pragma once
// The `sim` process's LCM side: the simulation's events as messages, written to a log as fast as possible (batch)
// or published at their time (live).
#include <string>

#include "ips/sim/simulation.hpp"

namespace ips::sim_app {

// Writes every event to the LCM log `out`; returns the exit status.
int runBatch(sim::Simulation& sim, const std::string& out);
// Publishes every event at its time over `rate` until the end or a stop signal; returns the exit status.
int runLive(sim::Simulation& sim, const std::string& url, double rate);

}  // namespace ips::sim_app
