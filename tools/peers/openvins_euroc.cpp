// openvins_euroc: OpenVINS (rpng/open_vins, ov_msckf built with ENABLE_ROS=OFF outside this project) over an EuRoC
// ASL folder, for the comparison of the navigation filters with the best open VIO on the same recordings (README
// "Navigation on real data"). Only OpenVINS's API is called; nothing of it is in this repository, and this file is
// not part of the project's build: compile it against an OpenVINS build of your own (its ov_core, ov_init and ov_msckf
// include folders and ov_msckf_lib).
//
//   openvins_euroc ESTIMATOR_CONFIG.yaml MAV0_DIR OUT.tum [--first N] [--last N]
//
// Feeds mav0/imu0/data.csv and the stereo pairs of mav0/cam0, mav0/cam1 (data.csv, frames first..last) in time
// order on one thread (use_multi_threading_subs off), and writes the IMU's pose in OpenVINS's global frame after each
// pair once it has initialised, in TUM format ("t tx ty tz qx qy qz qw", Hamilton, IMU to global), the same body frame
// as EuRoC's ground truth. Last line: "frames=N initialised_at=K ms_per_frame=X".
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "core/VioManager.h"
#include "core/VioManagerOptions.h"
#include "state/State.h"
#include "types/IMU.h"
#include "utils/quat_ops.h"

namespace {

std::vector<std::vector<std::string>> csv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::vector<std::vector<std::string>> rows;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
    std::vector<std::string> row;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) row.push_back(cell);
    rows.push_back(row);
  }
  return rows;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: openvins_euroc ESTIMATOR_CONFIG.yaml MAV0_DIR OUT.tum [--first N] [--last N]\n");
    return 2;
  }
  const std::string config = argv[1], mav0 = argv[2], out_path = argv[3];
  long first = 0, last = -1;
  for (int i = 4; i + 1 < argc; i += 2) {
    if (std::string(argv[i]) == "--first") first = std::stol(argv[i + 1]);
    if (std::string(argv[i]) == "--last") last = std::stol(argv[i + 1]);
  }
  auto parser = std::make_shared<ov_core::YamlParser>(config);
  std::string verbosity = "WARNING";
  parser->parse_config("verbosity", verbosity);
  ov_core::Printer::setPrintLevel(verbosity);
  ov_msckf::VioManagerOptions params;
  params.print_and_load(parser);
  params.use_multi_threading_subs = false;
  params.num_opencv_threads = 1;
  if (!parser->successful()) {
    std::fprintf(stderr, "openvins_euroc: %s does not parse completely\n", config.c_str());
    return 1;
  }
  ov_msckf::VioManager vio(params);

  const auto imu = csv(mav0 + "/imu0/data.csv");
  const auto cams = csv(mav0 + "/cam0/data.csv");
  if (last < 0 || last >= static_cast<long>(cams.size())) last = static_cast<long>(cams.size()) - 1;
  std::ofstream out(out_path);
  out << std::fixed;
  size_t next_imu = 0;
  double total_ms = 0;
  long frames = 0, initialised_at = -1;
  for (long f = first; f <= last; ++f) {
    const double t = std::stod(cams[f][0]) * 1e-9;
    // Every IMU sample up to (and one past) the image: OpenVINS propagates to the image time.
    for (; next_imu < imu.size(); ++next_imu) {
      const double ti = std::stod(imu[next_imu][0]) * 1e-9;
      ov_core::ImuData m;
      m.timestamp = ti;
      m.wm << std::stod(imu[next_imu][1]), std::stod(imu[next_imu][2]), std::stod(imu[next_imu][3]);
      m.am << std::stod(imu[next_imu][4]), std::stod(imu[next_imu][5]), std::stod(imu[next_imu][6]);
      vio.feed_measurement_imu(m);
      if (ti > t) {
        ++next_imu;
        break;
      }
    }
    ov_core::CameraData cam;
    cam.timestamp = t;
    cam.sensor_ids = {0, 1};
    for (const char* c : {"/cam0/data/", "/cam1/data/"}) {
      cv::Mat img = cv::imread(mav0 + c + cams[f][1], cv::IMREAD_GRAYSCALE);
      if (img.empty()) throw std::runtime_error("cannot read " + mav0 + c + cams[f][1]);
      cam.images.push_back(img);
      cam.masks.push_back(cv::Mat::zeros(img.rows, img.cols, CV_8UC1));
    }
    const auto t0 = std::chrono::steady_clock::now();
    vio.feed_measurement_camera(cam);
    total_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    ++frames;
    if (!vio.initialized()) continue;
    if (initialised_at < 0) initialised_at = f;
    const auto state = vio.get_state();
    // OpenVINS's quaternion is JPL, global to IMU: its rotation matrix is R_GtoI.
    const Eigen::Matrix3d R_ItoG = ov_core::quat_2_Rot(state->_imu->quat()).transpose();
    const Eigen::Quaterniond q(R_ItoG);
    const Eigen::Vector3d p = state->_imu->pos();
    out << std::setprecision(9) << state->_timestamp << ' ' << p.x() << ' ' << p.y() << ' ' << p.z() << ' ' << q.x()
        << ' ' << q.y() << ' ' << q.z() << ' ' << q.w() << '\n';
  }
  std::printf("frames=%ld initialised_at=%ld ms_per_frame=%.2f\n", frames, initialised_at,
              frames ? total_ms / frames : 0.0);
  return 0;
}
