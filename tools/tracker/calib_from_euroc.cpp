// EuRoC cam0/cam1 sensor.yaml -> the project's calibration file.
#include <cstdio>
#include <iostream>

#include "common.hpp"
#include "ips/tracker/euroc_calibration.hpp"

namespace {
const char* kUsage = "usage: calib_from_euroc CAM0_SENSOR.yaml CAM1_SENSOR.yaml --out CALIB.yaml\n";
}

int main(int argc, char** argv) {
  try {
    std::vector<std::string> pos;
    auto opts = ips::tracker::tools::parseOptions(argc, argv, 1, &pos);
    if (opts.count("help")) {
      std::cout << kUsage;
      return 0;
    }
    if (pos.size() != 2 || !opts.count("out")) throw std::invalid_argument("need two sensor files and --out");
    const ips::StereoCalibration calib = ips::tracker::calibrationFromEuroc(pos[0], pos[1]);
    ips::saveCalibration(opts["out"], calib);
    std::printf("wrote %s: %dx%d, baseline %.5f m\n", opts["out"].c_str(), calib.cam0.width, calib.cam0.height,
                calib.baseline());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "calib_from_euroc: %s\n%s", e.what(), kUsage);
    return 1;
  }
}
