// calib_convert: reads the calibration files of Kalibr, ROS camera_info, OpenCV's stereo_calib or EuRoC and
// writes the project's calibration file. Formats and conventions: processes/calib/include/ips/calib/formats.hpp.
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "ips/calib/formats.hpp"
#include "ips/config.hpp"

namespace {

const char* kUsage =
    "usage: calib_convert --from kalibr   CAMCHAIN.yaml                   --out CALIB.yaml\n"
    "       calib_convert --from ros      LEFT.yaml RIGHT.yaml            --out CALIB.yaml\n"
    "       calib_convert --from opencv   INTRINSICS.yml [EXTRINSICS.yml] --size WxH [--units-per-metre N] --out "
    "CALIB.yaml\n"
    "       calib_convert --from euroc    CAM0/sensor.yaml CAM1/sensor.yaml --out CALIB.yaml\n"
    "Kalibr: camchain or imu-camchain (T_cn_cnm1, T_cam_imu; radtan or equidistant). ROS: camera_info of the\n"
    "left and right camera. OpenCV: stereo_calib's M1 D1 M2 D2 R T (the image size is not in them).\n";

struct Usage : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace

int main(int argc, char** argv) {
  try {
    std::string from, out;
    std::vector<std::string> files;
    cv::Size size;
    double units_per_metre = 1.0;
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto value = [&]() -> std::string {
        if (i + 1 >= argc) throw Usage(a + " needs a value");
        return argv[++i];
      };
      if (a == "-h" || a == "--help") {
        std::fputs(kUsage, stdout);
        return 0;
      } else if (a == "--from") {
        from = value();
      } else if (a == "--out") {
        out = value();
      } else if (a == "--size") {
        const std::string v = value();
        if (std::sscanf(v.c_str(), "%dx%d", &size.width, &size.height) != 2) throw Usage("--size needs WxH");
      } else if (a == "--units-per-metre") {
        units_per_metre = std::stod(value());
      } else if (!a.empty() && a[0] == '-') {
        throw Usage("unknown option " + a);
      } else {
        files.push_back(a);
      }
    }
    if (out.empty()) throw Usage("--out is required");
    auto need = [&](size_t lo, size_t hi) {
      if (files.size() < lo || files.size() > hi) throw Usage("--from " + from + ": wrong number of files");
    };
    ips::StereoCalibration calib;
    if (from == "kalibr") {
      need(1, 1);
      calib = ips::calib::readKalibr(files[0]);
    } else if (from == "ros") {
      need(2, 2);
      calib = ips::calib::readRosCameraInfo(files[0], files[1]);
    } else if (from == "opencv") {
      need(1, 2);
      calib = ips::calib::readOpenCvStereo(files, size, units_per_metre);
    } else if (from == "euroc") {
      need(2, 2);
      calib = ips::calib::readEuroc(files[0], files[1]);
    } else {
      throw Usage("--from needs kalibr, ros, opencv or euroc");
    }
    ips::saveCalibration(out, calib);
    std::printf("wrote %s: %dx%d, %s, baseline %.5f m\n", out.c_str(), calib.cam0.width, calib.cam0.height,
                calib.cam0.model == ips::DistortionModel::kEquidistant ? "equidistant" : "radial-tangential",
                calib.baseline());
    return 0;
  } catch (const Usage& e) {
    std::fprintf(stderr, "calib_convert: %s\n%s", e.what(), kUsage);
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "calib_convert: %s\n", e.what());
    return 1;
  }
}
