// EuRoC cam0/cam1 sensor.yaml -> the project's calibration file.
#include <cstdio>

#include "ips/args.hpp"
#include "ips/tracker/euroc_calibration.hpp"

int main(int argc, char** argv) {
  try {
    ips::Args args(argc, argv, "EuRoC cam0/cam1 sensor.yaml -> the project's calibration file");
    args.required("--out", "CALIB.yaml", "calibration file to write")
        .positionals("SENSOR.yaml", "the EuRoC sensor files of cam0 and cam1, in this order", 2, 2);
    if (!args.parse()) return 0;
    const std::string out = args.get("--out");
    const ips::StereoCalibration calib = ips::tracker::calibrationFromEuroc(args.positional()[0], args.positional()[1]);
    ips::saveCalibration(out, calib);
    std::printf("wrote %s: %dx%d, baseline %.5f m\n", out.c_str(), calib.cam0.width, calib.cam0.height,
                calib.baseline());
    return 0;
  } catch (const ips::ArgError& e) {
    std::fprintf(stderr, "%s\n", e.what());  // names the program and the option
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "calib_from_euroc: %s\n", e.what());
    return 1;
  }
}
