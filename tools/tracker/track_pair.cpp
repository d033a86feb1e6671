// Relative motion of camera 0 between two raw stereo pairs. The last output line is
// "tx ty tz rx ry rz": camera 0 at time 1 in camera 0 at time 0 (metres, rotation vector in radians).
#include <cstdio>
#include <iostream>

#include "common.hpp"
#include "ips/calibration.hpp"
#include "ips/tracker/stereo_tracker.hpp"

namespace {
const char* kUsage =
    "usage: track_pair --calib CALIB.yaml --left0 A.png --right0 B.png --left1 C.png --right1 D.png\n"
    "                  [--params config/tracker.yaml] [--dt SECONDS (default 0.1)]\n"
    "Prints statistics, then as the LAST line: tx ty tz rx ry rz of camera 0 at time 1 in camera 0 at time 0.\n";
}

int main(int argc, char** argv) {
  using namespace ips::tracker;
  try {
    auto opts = tools::parseOptions(argc, argv, 1);
    if (opts.count("help")) {
      std::cout << kUsage;
      return 0;
    }
    for (const char* k : {"calib", "left0", "right0", "left1", "right1"})
      if (!opts.count(k)) throw std::invalid_argument(std::string("missing --") + k);
    const ips::StereoCalibration calib = ips::loadCalibration(opts["calib"]);
    const TrackerParams params = opts.count("params") ? loadTrackerParams(opts["params"]) : TrackerParams();
    const double dt = opts.count("dt") ? std::stod(opts["dt"]) : 0.1;
    StereoTracker tracker(calib, params);
    tracker.process(0, tools::loadGray(opts["left0"]), tools::loadGray(opts["right0"]));
    const TrackResult r =
        tracker.process(int64_t(dt * 1e6), tools::loadGray(opts["left1"]), tools::loadGray(opts["right1"]));
    std::printf("features %d intra %d inter %d inliers %d rms %.4f m %.3f px guided %d\n", r.num_features,
                r.num_intra_matches, r.num_inter_matches, r.num_inliers, r.residual_rms, r.residual_rms_px,
                int(r.guided_pass));
    std::printf("sigma t [m] %.4f %.4f %.4f r [rad] %.5f %.5f %.5f\n", std::sqrt(r.covariance(0, 0)),
                std::sqrt(r.covariance(1, 1)), std::sqrt(r.covariance(2, 2)), std::sqrt(r.covariance(3, 3)),
                std::sqrt(r.covariance(4, 4)), std::sqrt(r.covariance(5, 5)));
    std::printf("times [ms] rectify %.2f detect %.2f intra %.2f inter %.2f motion %.2f total %.2f\n", r.times.rectify,
                r.times.detect, r.times.intra, r.times.inter, r.times.motion, r.times.total);
    if (!r.valid) {
      std::fprintf(stderr, "track_pair: no valid motion (%d inliers)\n", r.num_inliers);
      return 2;
    }
    const Eigen::Vector3d rv = r.rotationVector();
    std::printf("%.6f %.6f %.6f %.6f %.6f %.6f\n", r.translation.x(), r.translation.y(), r.translation.z(), rv.x(),
                rv.y(), rv.z());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "track_pair: %s\n%s", e.what(), kUsage);
    return 1;
  }
}
