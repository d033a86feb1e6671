// calibrate_tilt: the tilt sensor's angles against camera 0 from an LCM log of the head set down at a few static
// positions in front of a chessboard chart that hangs plumb (STEREO and TILT, as the head or the simulator records
// them). The library (ips/calib/tilt_calibration.hpp) does the work; this reads the log, prints the stations and
// writes the calibration with the estimated R_tilt_cam0. The last line is
// `angle_x_deg=... angle_y_deg=... vertical_deg=...|kept sigma_deg=... residual_deg=... stations=...`.
#include <cstdio>
#include <ips/stereo_pair_t.hpp>
#include <ips/tilt_sample_t.hpp>

#include "ips/args.hpp"
#include "ips/calib/figures.hpp"
#include "ips/calib/tilt_calibration.hpp"
#include "ips/calibration.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/log_reader.hpp"
#include "ips/framework/validate.hpp"

int main(int argc, char** argv) {
  try {
    ips::Args args(argc, argv,
                   "Tilt sensor to camera 0 (two angles) from static positions in front of a plumb chessboard chart");
    args.required("--log", "FILE", "LCM log with the stereo pairs and the tilt sensor's samples")
        .required("--calib", "FILE", "the head's calibration (camera 0's lens; R_tilt_cam0 as designed)")
        .required("--board", "WxH", "inner corners per row and column, e.g. 9x6")
        .required("--square", "METRES", "edge of one board square")
        .option("--out", "FILE.yaml", "write --calib with the estimated R_tilt_cam0 and the figures")
        .option("--stereo-channel", "NAME", "channel of ips::stereo_pair_t", "STEREO")
        .option("--tilt-channel", "NAME", "channel of ips::tilt_sample_t", "TILT")
        .option("--min-station-s", "S", "a static position lasts at least this long", "2.0")
        .epilog("Exit status: 0 estimated, 1 error, 2 bad command line, 3 too few static positions.");
    if (!args.parse()) return 0;
    ips::calib::ChessboardSpec board;
    if (std::sscanf(args.get("--board").c_str(), "%dx%d", &board.inner_corners.width, &board.inner_corners.height) != 2)
      throw std::runtime_error("--board " + args.get("--board") + ": expected WxH, e.g. 9x6");
    board.square_m = args.getDouble("--square");
    ips::StereoCalibration calib = ips::loadCalibration(args.get("--calib"));

    std::vector<ips::calib::ChartView> views;
    std::vector<ips::calib::TiltReading> readings;
    long long pairs = 0, without_board = 0, bad = 0;
    ips::fw::LogReader log(args.get("--log"));
    ips::fw::LogMessage event;
    const std::string stereo_channel = args.get("--stereo-channel"), tilt_channel = args.get("--tilt-channel");
    while (log.next(&event)) {
      if (event.channel == stereo_channel) {
        ips::stereo_pair_t m;
        if (m.decode(event.data.data(), 0, static_cast<int>(event.data.size())) < 0 || !ips::fw::validate(m).ok()) {
          ++bad;
          continue;
        }
        ++pairs;
        if (auto v = ips::calib::chartPose(ips::fw::leftImage(m), calib.cam0, board, m.utime))
          views.push_back(*v);
        else
          ++without_board;
      } else if (event.channel == tilt_channel) {
        ips::tilt_sample_t m;
        if (m.decode(event.data.data(), 0, static_cast<int>(event.data.size())) < 0) {
          ++bad;
          continue;
        }
        readings.push_back({m.utime, m.angle_x, m.angle_y});
      }
    }
    std::printf("pairs=%lld board_found=%zu without_board=%lld tilt_samples=%zu undecodable_or_invalid=%lld\n", pairs,
                views.size(), without_board, readings.size(), bad);
    ips::calib::TiltCalibrationConfig config;
    config.min_station_s = args.getDouble("--min-station-s");
    const ips::calib::TiltCalibrationResult r = ips::calib::calibrateTilt(views, readings, calib.R_tilt_cam0, config);
    for (const auto& st : r.stations)
      std::printf(
          "station %.2f-%.2f s: %d views, %d readings, tilt %.3f %.3f deg (spread %.3f %.3f), residual %.4f %.4f deg\n",
          (st.begin_utime - views.front().utime) * 1e-6, (st.end_utime - views.front().utime) * 1e-6, st.views,
          st.readings, st.measured_deg.x(), st.measured_deg.y(), st.spread_deg.x(), st.spread_deg.y(),
          st.residual_deg.x(), st.residual_deg.y());
    if (!r.ok) {
      std::printf("no estimate: %s\n", r.reason.c_str());
      return 3;
    }
    std::printf("turn against %s about the sensor's x and y: %.4f %.4f deg (sigma %.4f %.4f); about its vertical: ",
                args.get("--calib").c_str(), r.angles_deg.x(), r.angles_deg.y(), r.sigma_deg.x(), r.sigma_deg.y());
    if (r.vertical_estimated)
      std::printf("%.4f deg (sigma %.4f)\n", r.angles_deg.z(), r.sigma_deg.z());
    else
      std::printf("not determined by these stations (tilt the head more), kept\n");
    if (args.has("--out")) {
      calib.R_tilt_cam0 = r.R_tilt_cam0;
      calib.source = "estimated";
      ips::saveCalibration(args.get("--out"), calib, [&](cv::FileStorage& fs) {
        ips::calib::copyFigureBlocks(fs, args.get("--calib"), "tilt_figures");
        fs << "tilt_figures"
           << "{"
           << "date" << ips::calib::utcNow() << "log" << args.get("--log") << "angles_deg"
           << std::vector<double>{r.angles_deg.x(), r.angles_deg.y(), r.angles_deg.z()} << "sigma_deg"
           << std::vector<double>{r.sigma_deg.x(), r.sigma_deg.y(), r.sigma_deg.z()} << "vertical_estimated"
           << static_cast<int>(r.vertical_estimated) << "residual_rms_deg" << r.residual_rms_deg << "stations"
           << static_cast<int>(r.stations.size()) << "}";
      });
      std::printf("wrote %s\n", args.get("--out").c_str());
    }
    const std::string vertical = r.vertical_estimated ? std::to_string(r.angles_deg.z()) : std::string("kept");
    std::printf("angle_x_deg=%.4f angle_y_deg=%.4f vertical_deg=%s sigma_deg=%.4f residual_deg=%.4f stations=%zu\n",
                r.angles_deg.x(), r.angles_deg.y(), vertical.c_str(), r.sigma_deg.maxCoeff(), r.residual_rms_deg,
                r.stations.size());
    return 0;
  } catch (const ips::ArgError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "calibrate_tilt: %s\n", e.what());
    return 1;
  }
}
