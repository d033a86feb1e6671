// Relative motion of camera 0 between two raw stereo pairs. The last output line is
// "tx ty tz rx ry rz": camera 0 at time 1 in camera 0 at time 0 (metres, rotation vector in radians).
#include <cmath>
#include <cstdio>

#include "ips/args.hpp"
#include "ips/calibration.hpp"
#include "ips/image_file.hpp"
#include "ips/tracker/stereo_tracker.hpp"

int main(int argc, char** argv) {
  using namespace ips::tracker;
  try {
    ips::Args args(argc, argv,
                   "relative motion of camera 0 between two raw stereo pairs\n"
                   "Prints statistics, then as the LAST line: tx ty tz rx ry rz of camera 0 at time 1 in camera 0 at "
                   "time 0\n(metres, rotation vector in radians).");
    args.required("--calib", "CALIB.yaml", "the project's calibration file")
        .required("--left0", "A.png", "left image at time 0")
        .required("--right0", "B.png", "right image at time 0")
        .required("--left1", "C.png", "left image at time 1")
        .required("--right1", "D.png", "right image at time 1")
        .option("--params", "TRACKER.yaml", "tracker parameters, e.g. config/tracker.yaml (default: built-in)")
        .option("--dt", "SECONDS", "time between the pairs", "0.1");
    if (!args.parse()) return 0;
    const ips::StereoCalibration calib = ips::loadCalibration(args.get("--calib"));
    const TrackerParams params = args.has("--params") ? loadTrackerParams(args.get("--params")) : TrackerParams();
    const double dt = args.getDouble("--dt");
    StereoTracker tracker(calib, params);
    tracker.process(0, ips::loadGrey(args.get("--left0")), ips::loadGrey(args.get("--right0")));
    const TrackResult r =
        tracker.process(int64_t(dt * 1e6), ips::loadGrey(args.get("--left1")), ips::loadGrey(args.get("--right1")));
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
  } catch (const ips::ArgError& e) {
    std::fprintf(stderr, "%s\n", e.what());  // names the program and the option
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "track_pair: %s\n", e.what());
    return 1;
  }
}
