#pragma once
// The calibration tools each write their figures as a block of the calibration file (calibration_figures from
// calibrate_stereo, tilt_figures, camera_imu_figures): the chain stereo -> tilt -> camera-IMU updates one file, and
// each tool keeps the blocks the earlier ones wrote.
#include <opencv2/core.hpp>
#include <string>

namespace ips::calib {

// Inside saveCalibration's write_more: copies every top-level block of the file `previous` whose key ends in
// "_figures", except `except` (the block the caller writes anew). A missing or unreadable file copies nothing.
void copyFigureBlocks(cv::FileStorage& out, const std::string& previous, const std::string& except);

// The date and time now (UTC, ISO 8601), for a figures block.
std::string utcNow();

}  // namespace ips::calib
