#pragma once
// Camera to tilt sensor (the paper's section 3): "the orientation of the camera and the tilt angles are measured at
// a few static positions in front of a calibration chart which allows the determination of two tilt angles between
// stereo system and tilt sensor". The chart hangs plumb with its rows level, so its pose seen by camera 0 gives the
// direction of "up" in the camera at each station; the tilt sensor's two angles give it in the sensor's frame.
//
// Estimated: R_tilt_cam0 = exp(a x_tilt + b y_tilt + c z_tilt) * R_nominal. The two angles a, b about the sensor's
// own x and y axes are the paper's; they take up the sensor's mounting and its zero offsets alike, which is what the
// filter's model of the sensor needs. The turn c about its vertical changes what it reads only when the head is
// tilted (a 1 deg turn moves the readings by 0.2 deg at 12 deg of tilt): it is estimated when the stations' tilts
// determine it (its sigma within max_vertical_sigma_deg), and otherwise stays as the file has it. Least squares over
// the stations on the measured angles; sigmas from the residuals.
#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "ips/calib/stereo_calibration.hpp"
#include "ips/calibration.hpp"

namespace ips::calib {

// The chart's pose in one image of camera 0.
struct ChartView {
  int64_t utime = 0;
  Eigen::Matrix3d R_cam_chart = Eigen::Matrix3d::Identity();  // chart axes: x along the rows, y down the columns
  Eigen::Vector3d t_cam_chart = Eigen::Vector3d::Zero();
  // The middle of the board's corners in camera 0: where the board is, whichever end its corner order starts at.
  Eigen::Vector3d centre_in_camera = Eigen::Vector3d::Zero();
  double reprojection_px = 0;  // RMS of the board's corners against the fitted pose
};

// Finds the board in a raw (distorted) image of camera 0 and fits its pose with the camera's lens model. Empty when
// the board is not found.
std::optional<ChartView> chartPose(const cv::Mat& raw_image, const CameraIntrinsics& camera,
                                   const ChessboardSpec& board, int64_t utime);

struct TiltReading {
  int64_t utime = 0;
  double angle_x = 0, angle_y = 0;  // [rad] as tilt_sample_t
};

struct TiltCalibrationConfig {
  // A station: consecutive chart views whose pose stays within these of the station's first view, for at least
  // min_station_s. The tilt sensor's element settles (its time constant, 0.15 s for the Z260) before settle_s.
  double station_max_turn_deg = 0.05;
  double station_max_shift_m = 0.003;
  double min_station_s = 2.0;
  double settle_s = 1.0;
  int min_stations = 3;
  int min_readings = 10;  // tilt readings a station needs
  // The turn about the vertical is estimated only if the stations determine it this well (else: as designed).
  double max_vertical_sigma_deg = 0.5;
  // The sigmas take the stations' mean readings as no better than this (the Z260's 0.03 deg noise averaged over a
  // station, and its 0.1 deg steps): a fit that happens to leave no residual is not infinitely certain.
  double min_reading_sigma_deg = 0.01;
};

struct TiltStation {
  int64_t begin_utime = 0, end_utime = 0;  // first and last chart view
  int views = 0, readings = 0;
  Eigen::Vector3d up_in_camera = Eigen::Vector3d::Zero();  // from the chart
  Eigen::Vector2d measured_deg = Eigen::Vector2d::Zero();  // mean tilt angles x, y
  Eigen::Vector2d spread_deg = Eigen::Vector2d::Zero();    // their standard deviation within the station
  Eigen::Vector2d residual_deg = Eigen::Vector2d::Zero();  // measured - predicted by the fit
};

struct TiltCalibrationResult {
  bool ok = false;
  std::string reason;
  Eigen::Matrix3d R_tilt_cam0 = Eigen::Matrix3d::Identity();
  // a, b, c: the turn against the nominal about the sensor's x, y and vertical (c 0 when not estimated).
  Eigen::Vector3d angles_deg = Eigen::Vector3d::Zero();
  Eigen::Vector3d sigma_deg = Eigen::Vector3d::Zero();
  bool vertical_estimated = false;
  double residual_rms_deg = 0;
  std::vector<TiltStation> stations;
};

// `nominal` is the calibration's R_tilt_cam0 (the design). Views and readings in any order.
TiltCalibrationResult calibrateTilt(const std::vector<ChartView>& views, const std::vector<TiltReading>& readings,
                                    const Eigen::Matrix3d& nominal, const TiltCalibrationConfig& config = {});

// The tilt sensor's two angles for the direction "up" in its own frame (tilt_sample_t: asin of its x and y parts).
Eigen::Vector2d tiltAngles(const Eigen::Vector3d& up_in_tilt);

}  // namespace ips::calib
