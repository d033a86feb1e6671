// tracker: the IPS stereo tracker as a process. STEREO pairs in, TRACKER_DELTA out.
// The search windows of the inter-matching are placed by the best motion prior on the bus: the filter's
// a-priori state at the new image time (FILTER_PRIOR) when a filter runs, else the gyro (IMU), else constant
// velocity. When a filter has been seen, a pair waits for its answer (the filter answers every image time: a prior on
// FILTER_PRIOR, or FILTER_PRIOR_NONE before its start), else for the IMU to cover its time, so that a replayed log
// gives the same deltas as the live run.
// A tracker behind the camera (a starved host) reads what has piled up in its socket first and skips the pairs it
// cannot catch up with (health: dropped, stale_pair), so that its deltas still reach the filter's image clones;
// with --queue (replay) it tracks every pair, so that a replay on a loaded host still equals the offline tracker.
// With process/intra_from_disparity, a pair E3D matches (seq % disparity_every_nth == 0) also waits for its
// DISPARITY map and takes its intra-matches from it: live until disparity_wait_pairs newer pairs are pending,
// with --queue until the map or a later one arrives, so that the replay repeats itself.
// With integrity/enabled, every pair also goes through the epipolar integrity monitor: INTEGRITY out, and the right
// camera's correction, once certain, used for the following pairs (and by E3D).
#include "app/tracker_process.hpp"
#include "ips/calibration.hpp"
#include "ips/config.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/process.hpp"
#include "ips/log.hpp"
#include "ips/tracker/pair_scheduler.hpp"
#include "ips/tracker/params.hpp"

int main(int argc, char** argv) {
  return ips::fw::guardedMain("tracker", [&]() {
    ips::Args args(argc, argv, "IPS stereo tracker: STEREO pairs in, TRACKER_DELTA (relative motion) out");
    args.required("--calib", "FILE", "calibration of the stereo head (project format)")
        .flag("--queue",
              "replay: every pair is tracked however far behind (none dropped stale), and with "
              "process/intra_from_disparity waits for its DISPARITY map however late");
    ips::fw::addCommonOptions(args, "config/tracker.yaml");
    if (!args.parse()) return 0;
    ips::fw::applyCommonOptions(args);
    const ips::StereoCalibration calib = ips::loadCalibration(args.get("--calib"));
    const ips::Config cfg(args.get("--config"));
    const ips::tracker::TrackerParams params = ips::tracker::loadTrackerParams(cfg);
    const ips::tracker::IntegrityParams integrity = ips::tracker::loadIntegrityParams(cfg);
    const ips::tracker::PriorBuilderParams prior_builder = ips::tracker::loadPriorBuilderParams(cfg);
    const ips::tracker::DisparityWait wait = ips::tracker::loadDisparityWait(cfg, args.getFlag("--queue"));
    if (ips::fw::configChecked(args, cfg)) return 0;
    ips::fw::Node node("tracker", args.get("--lcm-url"));
    ips::tracker_app::TrackerProcess process(node, calib, params, integrity, prior_builder, wait);
    IPS_INFO("tracking " << calib.cam0.width << "x" << calib.cam0.height << " pairs");
    const int rc = node.run([&process]() { process.drain(); });
    process.flush();
    // The counters with what the flush applied: the report reads the last health message.
    node.publishHealth(1.0);
    return rc;
  });
}
