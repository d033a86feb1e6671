// calib_convert: reads the calibration files of Kalibr, ROS camera_info, OpenCV's stereo_calib or EuRoC and
// writes the project's calibration file. Formats and conventions: processes/calib/include/ips/calib/formats.hpp.
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "ips/args.hpp"
#include "ips/calib/formats.hpp"
#include "ips/config.hpp"

int main(int argc, char** argv) {
  try {
    ips::Args args(argc, argv,
                   "another tool's calibration files -> the project's calibration file\n"
                   "  --from kalibr  CAMCHAIN.yaml: camchain or imu-camchain (T_cn_cnm1, T_cam_imu;\n"
                   "                 radtan or equidistant)\n"
                   "  --from ros     LEFT.yaml RIGHT.yaml: camera_info of the left and right camera\n"
                   "  --from opencv  INTRINSICS.yml [EXTRINSICS.yml] --size WxH: stereo_calib's M1 D1 M2 D2 R T\n"
                   "                 (the image size is not in them)\n"
                   "  --from euroc   CAM0/sensor.yaml CAM1/sensor.yaml");
    args.required("--from", "FORMAT", "kalibr, ros, opencv or euroc")
        .required("--out", "CALIB.yaml", "calibration file to write")
        .option("--size", "WxH", "--from opencv: the image size")
        .option("--units-per-metre", "N", "--from opencv: units of T per metre", "1")
        .option("--imu", "FILE",
                "the IMU's noise: EuRoC's imu0/sensor.yaml or Kalibr's imu.yaml (the calibration's imu block)")
        .option("--gyro-bias-sigma", "RAD_S", "--imu: the gyro's turn-on bias (data sheet), 1 sigma per axis",
                std::to_string(ips::calib::kMemsGyroBiasSigma))
        .option("--accel-bias-sigma", "M_S2", "--imu: the accelerometer's turn-on bias, 1 sigma per axis",
                std::to_string(ips::calib::kMemsAccelBiasSigma))
        .positionals("FILE", "the calibration files of the format", 1, 2);
    if (!args.parse()) return 0;
    const std::string from = args.get("--from"), out = args.get("--out");
    const std::vector<std::string>& files = args.positional();
    cv::Size size;
    if (args.has("--size") && std::sscanf(args.get("--size").c_str(), "%dx%d", &size.width, &size.height) != 2)
      throw ips::ArgError("calib_convert: --size needs WxH");
    const double units_per_metre = args.getDouble("--units-per-metre");
    auto need = [&](size_t lo, size_t hi) {
      if (files.size() < lo || files.size() > hi)
        throw ips::ArgError("calib_convert: --from " + from + ": wrong number of files");
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
      throw ips::ArgError("calib_convert: --from needs kalibr, ros, opencv or euroc");
    }
    if (args.has("--imu"))
      calib.imu = ips::calib::readImuNoise(args.get("--imu"), args.getDouble("--gyro-bias-sigma"),
                                           args.getDouble("--accel-bias-sigma"));
    ips::saveCalibration(out, calib);
    std::printf("wrote %s: %dx%d, %s, baseline %.5f m%s\n", out.c_str(), calib.cam0.width, calib.cam0.height,
                calib.cam0.model == ips::DistortionModel::kEquidistant ? "equidistant" : "radial-tangential",
                calib.baseline(), calib.imu ? ", with the IMU's noise" : "");
    return 0;
  } catch (const ips::ArgError& e) {
    std::fprintf(stderr, "%s\n", e.what());  // names the program and the option
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "calib_convert: %s\n", e.what());
    return 1;
  }
}
