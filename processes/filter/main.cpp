// filter: the IPS state estimation as a process. IMU, TILT, STEREO_TIME (image times), TRACKER_DELTA, and E3D's
// KEYFRAME with the mapper's CLOUD_DELTA (the alignment of successive dense maps) in;
// FILTER_STATE (a posteriori, at IMU rate or decimated) and FILTER_PRIOR (a priori at every image time, for the
// tracker's window prediction) out. Time comes from the message stamps only.
#include <optional>
#include <string>

#include "app/filter_process.hpp"
#include "ips/calibration.hpp"
#include "ips/config.hpp"
#include "ips/filter/estimator.hpp"
#include "ips/filter/params.hpp"
#include "ips/framework/channels.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/process.hpp"
#include "ips/log.hpp"

int main(int argc, char** argv) {
  return ips::fw::guardedMain("filter", [&]() {
    ips::Args args(argc, argv, "IPS navigation filter (EKF or scaled UKF): IMU, tilt and tracker deltas fused");
    args.required("--calib", "FILE", "calibration of the sensor head (camera-IMU and camera-tilt mounting)")
        .option("--filter", "TYPE", "override the config's filter type: ekf or ukf")
        .option("--name", "NAME", "process name (health channel HEALTH_<NAME>), to run several filters side by side",
                "filter")
        .option("--state-channel", "CH", "channel of the a-posteriori states", ips::channels::kFilterState)
        .option("--prior-channel", "CH",
                "channel of the a-priori states at image times, and CH_NONE of the image times without one ('none': do "
                "not publish)",
                ips::channels::kFilterPrior);
    ips::fw::addCommonOptions(args, "config/filter.yaml");
    if (!args.parse()) return 0;
    ips::fw::applyCommonOptions(args);
    const ips::StereoCalibration calib = ips::loadCalibration(args.get("--calib"));
    // The IMU's noise is the head's own (processes/filter/README.md, "Describing the head's IMU").
    if (!calib.imu)
      throw ips::ConfigError(args.get("--calib") +
                             ": no 'imu' block: the filter needs the head's IMU (rate, noise densities, bias random "
                             "walks, turn-on biases); dataset_to_lcm and the simulator write it, calib_convert --imu "
                             "adds it from EuRoC's or Kalibr's IMU file");
    const ips::Config cfg(args.get("--config"));
    ips::filter::FilterParams params = ips::filter::loadFilterParams(cfg.has("filter") ? cfg.section("filter") : cfg);
    if (ips::fw::configChecked(args, cfg)) return 0;
    if (args.has("--filter")) {
      const std::optional<ips::filter::FilterType> type = ips::filter::filterTypeFromString(args.get("--filter"));
      if (!type) throw ips::ArgError("--filter must be ekf or ukf");
      params.type = *type;
    }
    ips::filter::Estimator estimator(params, calib);
    ips::fw::Node node(args.get("--name"), args.get("--lcm-url"));
    const std::string prior_channel = args.get("--prior-channel") == "none" ? "" : args.get("--prior-channel");
    ips::filter_app::FilterProcess process(node, estimator, args.get("--state-channel"), prior_channel);
    IPS_INFO("running the " << ips::filter::toString(params.type) << " filter on the IMU "
                            << (calib.imu->model.empty() ? "of the calibration" : calib.imu->model)
                            << (calib.tilt ? " and the tilt sensor" : ", no tilt sensor"));
    const int rc = node.run([&process] { process.publishOutputs(); });
    process.flush();
    // The counters with what the flush applied: the report reads the last health message.
    node.publishHealth(1.0);
    return rc;
  });
}
