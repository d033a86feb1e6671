#pragma once
// EuRoC / ASL sensor.yaml files into the project's calibration format: the reader lives in ips_calib (with
// the other tools' formats); these names stay for the tracker's tools and tests.
#include "ips/calib/formats.hpp"

namespace ips::tracker {

using calib::EurocCamera;
using calib::readEurocCamera;
inline StereoCalibration calibrationFromEuroc(const std::string& cam0_path, const std::string& cam1_path) {
  return calib::readEuroc(cam0_path, cam1_path);
}

}  // namespace ips::tracker
