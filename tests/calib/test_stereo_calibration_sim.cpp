// Stereo calibration on the simulator's calibration recording (config/sim_stereo_calib.yaml: the walk's head, its
// true calibration known, a chessboard chart seen from 28 static positions): the sim process writes the log,
// calibrate_stereo --log picks one still view per position and fits both cameras and their relative orientation,
// which must recover the truth within the tolerances (focal length 0.1 %, principal point 0.5 px, the
// relative rotation 0.05 deg). The simulated lenses are radial-tangential, so only that model is fitted (the choice
// between models is tested on OpenCV's sample set). Label slow: 275 rendered pairs and 28 leave-one-out fits.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <string>

#include "ips/calibration.hpp"
#include "ips/test_support/command_output.hpp"

namespace {

using ips::test_support::commandOutput;

}  // namespace

TEST(StereoCalibrationSim, ChartFromManyPosesGivesTheTrueHead) {
  const std::string scenario = std::string(IPS_SOURCE_DIR) + "/config/sim_stereo_calib.yaml";
  const std::string log = ::testing::TempDir() + "stereo_calib_test.lcmlog";
  const std::string estimated_path = ::testing::TempDir() + "stereo_calib_estimated.yaml";
  ASSERT_EQ(
      std::system(
          (std::string(SIM_EXECUTABLE) + " --scenario " + scenario + " --out " + log + " --log-level warn").c_str()),
      0);
  const std::string out =
      commandOutput(std::string(CALIBRATE_STEREO) + " --log " + log +
                    " --board 9x6 --square 0.1 --lens-model radial-tangential --out " + estimated_path);
  ASSERT_NE(out.find("rms_px="), std::string::npos) << out;
  EXPECT_NE(out.find("views taken (board still, one per pose) 28"), std::string::npos) << out;
  const ips::StereoCalibration truth = ips::loadCalibration(log + ".calib.yaml");
  const ips::StereoCalibration est = ips::loadCalibration(estimated_path);
  ASSERT_EQ(truth.source, "true");
  double worst_focal = 0, worst_principal = 0;
  for (const auto& [t, e] : {std::pair{&truth.cam0, &est.cam0}, std::pair{&truth.cam1, &est.cam1}}) {
    for (int axis = 0; axis < 2; ++axis) {
      worst_focal = std::max(worst_focal, std::fabs(e->K(axis, axis) / t->K(axis, axis) - 1));
      worst_principal = std::max(worst_principal, std::fabs(e->K(axis, 2) - t->K(axis, 2)));
    }
  }
  const double rotation_deg = Eigen::AngleAxisd(truth.R_cam1_cam0.transpose() * est.R_cam1_cam0).angle() * 180 / M_PI;
  const double baseline_rel = est.baseline() / truth.baseline() - 1;
  std::printf(
      "%s[ SIM      ] focal length %.4f %%, principal point %.3f px, relative rotation %.4f deg, baseline "
      "%.4f %% (worst of both cameras)\n",
      out.substr(out.rfind("model ")).c_str(), 100 * worst_focal, worst_principal, rotation_deg, 100 * baseline_rel);
  EXPECT_LT(worst_focal, 1e-3);
  EXPECT_LT(worst_principal, 0.5);
  EXPECT_LT(rotation_deg, 0.05);
  EXPECT_LT(std::fabs(baseline_rel), 1e-3);
  std::remove(log.c_str());
  std::remove((log + ".calib.yaml").c_str());
  std::remove(estimated_path.c_str());
}
