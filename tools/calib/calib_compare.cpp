// calib_compare: how far one calibration file is from another (an estimate against the truth, a head after a knock
// against before): focal lengths, principal points, distortion at the image corner, the cameras' relative orientation
// and baseline, the IMU's and the tilt sensor's mounting. The last line is
// `focal_pct=... principal_px=... stereo_rotation_deg=... baseline_pct=... imu_rotation_deg=... tilt_x_deg=...
// tilt_y_deg=...`.
#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>

#include "ips/args.hpp"
#include "ips/calibration.hpp"
#include "ips/rotation.hpp"

int main(int argc, char** argv) {
  try {
    ips::Args args(argc, argv, "How far the calibration --b is from --a (e.g. an estimate from the truth)");
    args.required("--a", "FILE", "the reference calibration")
        .required("--b", "FILE", "the calibration compared with it");
    if (!args.parse()) return 0;
    const ips::StereoCalibration a = ips::loadCalibration(args.get("--a")), b = ips::loadCalibration(args.get("--b"));
    if (a.cam0.width != b.cam0.width || a.cam0.height != b.cam0.height)
      throw std::runtime_error("the files are of different image sizes");
    double focal = 0, principal = 0;
    const char* names[] = {"cam0", "cam1"};
    int i = 0;
    for (const auto& [ca, cb] : {std::pair{&a.cam0, &b.cam0}, std::pair{&a.cam1, &b.cam1}}) {
      const double fx = 100 * (cb->K(0, 0) / ca->K(0, 0) - 1), fy = 100 * (cb->K(1, 1) / ca->K(1, 1) - 1);
      const double cx = cb->K(0, 2) - ca->K(0, 2), cy = cb->K(1, 2) - ca->K(1, 2);
      std::printf("%s: focal length %+.4f %% %+.4f %%, principal point %+.3f %+.3f px\n", names[i++], fx, fy, cx, cy);
      focal = std::max({focal, std::fabs(fx), std::fabs(fy)});
      principal = std::max({principal, std::fabs(cx), std::fabs(cy)});
    }
    const Eigen::Vector3d stereo = ips::rotationVectorDeg(a.R_cam1_cam0.transpose() * b.R_cam1_cam0);
    const double baseline = 100 * (b.baseline() / a.baseline() - 1);
    std::printf("relative orientation: %.4f deg (rotation vector %+.4f %+.4f %+.4f), baseline %+.4f %%\n",
                stereo.norm(), stereo.x(), stereo.y(), stereo.z(), baseline);
    const Eigen::Vector3d imu = ips::rotationVectorDeg(a.T_imu_cam0.linear().transpose() * b.T_imu_cam0.linear());
    const Eigen::Vector3d lever = b.T_imu_cam0.translation() - a.T_imu_cam0.translation();
    std::printf("camera to IMU: %.4f deg (in camera 0: %+.4f %+.4f %+.4f), lever arm %+.4f %+.4f %+.4f m\n", imu.norm(),
                imu.x(), imu.y(), imu.z(), lever.x(), lever.y(), lever.z());
    // In the tilt sensor's frame: about its x and y the turn changes what it reads; about its vertical it does not.
    const Eigen::Vector3d tilt = ips::rotationVectorDeg(b.R_tilt_cam0 * a.R_tilt_cam0.transpose());
    std::printf("camera to tilt sensor: about its x %+.4f deg, y %+.4f deg (about its vertical %+.4f deg)\n", tilt.x(),
                tilt.y(), tilt.z());
    std::printf(
        "focal_pct=%.4f principal_px=%.3f stereo_rotation_deg=%.4f baseline_pct=%.4f imu_rotation_deg=%.4f "
        "tilt_x_deg=%.4f tilt_y_deg=%.4f\n",
        focal, principal, stereo.norm(), std::fabs(baseline), imu.norm(), tilt.x(), tilt.y());
    return 0;
  } catch (const ips::ArgError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "calib_compare: %s\n", e.what());
    return 1;
  }
}
