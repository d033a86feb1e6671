// sim: the simulated sensor head. Batch mode writes an LCM log as fast as it can; live mode publishes in real
// time (or scaled by --rate). Channels: STEREO, IMU, TILT (as the real drivers), GT_POSE, GT_DISPARITY.
// The head's calibration goes to FILE.calib.yaml beside the log (batch) or to --calib-out (live): the truth, or
// with the scenario's calibration_errors a perturbed one (the truth then beside it as FILE.true.calib.yaml).
#include <cstdint>
#include <string>

#include "app/sim_process.hpp"
#include "ips/args.hpp"
#include "ips/framework/process.hpp"
#include "ips/log.hpp"
#include "ips/sim/output.hpp"
#include "ips/sim/simulation.hpp"

int main(int argc, char** argv) {
  return ips::fw::guardedMain("sim", [&]() -> int {
    ips::Args args(argc, argv,
                   "The simulated sensor head (stereo camera, IMU, tilt sensor) with ground truth.\n"
                   "Batch: sim --duration S --out FILE.lcmlog (writes FILE.calib.yaml beside it). "
                   "Live: sim [--rate F] [--lcm-url URL] [--calib-out FILE].");
    args.option("--duration", "SECONDS",
                "simulated time; default: until the trajectory ends; 0: only write the calibration")
        .option("--out", "FILE.lcmlog", "batch mode: write an LCM log as fast as possible")
        .option("--scenario", "FILE.yaml", "scenario (config/sim_*.yaml); default: the built-in walk")
        .option("--seed", "N", "random seed (overrides the scenario's)")
        .option("--gt-disparity-every", "N", "ground-truth disparity (GT_DISPARITY) for every N-th pair", "0")
        .option("--rate", "FACTOR", "live mode: speed relative to real time", "1")
        .option("--lcm-url", "URL", "live mode: LCM URL (default $LCM_DEFAULT_URL)")
        .option("--calib-out", "FILE", "live mode: where to write the calibration", "sim.calib.yaml")
        .option("--design-out", "FILE",
                "also write the head as designed (nominal lenses and mounting, source: design), where the "
                "calibration tools start")
        .option("--log-level", "LEVEL", "debug, info, warn, error", "info");
    if (!args.parse()) return 0;
    ips::setLogName("sim");
    ips::setLogLevel(ips::parseLogLevel(args.get("--log-level")));
    ips::sim::Scenario scenario =
        args.has("--scenario") ? ips::sim::Scenario::load(args.get("--scenario")) : ips::sim::Scenario::defaults();
    if (args.has("--seed")) {
      const long long seed = args.getInt("--seed");
      if (seed < 0) throw ips::ArgError("--seed must not be negative");
      scenario.seed = static_cast<uint64_t>(seed);
    }
    ips::sim::SimulationOptions options;
    options.gt_disparity_every = static_cast<int>(args.getInt("--gt-disparity-every"));
    if (options.gt_disparity_every < 0) throw ips::ArgError("--gt-disparity-every must not be negative");
    const ips::sim::Trajectory probe(scenario.trajectory, scenario.gravity);
    options.duration_s = args.has("--duration") ? args.getDouble("--duration") : probe.duration();
    if (!(options.duration_s >= 0)) throw ips::ArgError("--duration must not be negative");
    const double rate = args.getDouble("--rate");
    if (!(rate > 0)) throw ips::ArgError("--rate must be positive");

    const std::string calib_path = args.has("--out") ? args.get("--out") + ".calib.yaml" : args.get("--calib-out");
    if (args.has("--design-out"))
      ips::saveCalibration(args.get("--design-out"), ips::sim::SensorHead::design(scenario));
    if (options.duration_s == 0) {  // only the calibration (for processes started before the head)
      ips::sim::writeCalibrations(scenario, ips::sim::SensorHead::make(scenario), calib_path);
      IPS_INFO("--duration 0: wrote the calibration " << calib_path << " and nothing else");
      return 0;
    }
    ips::sim::Simulation sim(scenario, options);
    ips::sim::writeCalibrations(scenario, sim.head(), calib_path);
    IPS_INFO("scenario '" << scenario.name << "' (" << scenario.source << "), seed " << scenario.seed << ", "
                          << options.duration_s << " s of a " << sim.trajectory().duration() << " s, "
                          << sim.trajectory().pathLength() << " m trajectory; " << sim.world().quads.size()
                          << " quads, " << sim.world().photo_count << " photographs; calibration: " << calib_path);
    if (args.has("--out")) return ips::sim_app::runBatch(sim, args.get("--out"));
    return ips::sim_app::runLive(sim, args.get("--lcm-url"), rate);
  });
}
