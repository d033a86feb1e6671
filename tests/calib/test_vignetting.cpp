// Flat-field calibration (ips/calib/vignetting.hpp): a flat target through a lens with natural cos^4 vignetting
// gives back the gain (1 + t)^2; a walk of the simulator's hard head (its renderer's cos^4 vignetting, auto
// exposure, motion blur) gives it back from ordinary views; calibrate_vignetting on image files writes the gains
// into the calibration it reads.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>

#include "ips/calib/formats.hpp"
#include "ips/calib/image_files.hpp"
#include "ips/calib/vignetting.hpp"
#include "ips/calibration.hpp"
#include "ips/data_dir.hpp"
#include "ips/shared_data_test.hpp"
#include "ips/sim/rig.hpp"
#include "ips/test_support/command_output.hpp"

using namespace ips::calib;

namespace {

// The largest relative error of the estimated gain against the natural vignetting's (1 + t)^2 for rays up to
// widest_tan2 (default: the whole image's).
double worstGainError(const ips::CameraIntrinsics& camera, const VignettingEstimate& e, double widest_tan2 = -1) {
  ips::CameraIntrinsics estimated = camera;
  estimated.vignetting_gain = e.gain;
  const double widest = widest_tan2 >= 0 ? widest_tan2 : e.widest_tan2;
  double worst = 0;
  for (int i = 0; i <= 100; ++i) {
    const double t = widest * i / 100;
    worst = std::max(worst, std::abs(estimated.flatFieldGain(t) / ((1 + t) * (1 + t)) - 1));
  }
  return worst;
}

// A pinhole camera of 106 deg across its diagonal: t reaches 1.77 in the corners (gain 7.6).
ips::CameraIntrinsics widePinhole() {
  ips::CameraIntrinsics camera;
  camera.width = 320;
  camera.height = 240;
  camera.K << 150, 0, 159.5, 0, 150, 119.5, 0, 0, 1;
  return camera;
}

// Images of an even grey surface through `camera` with cos^4 vignetting and sensor noise: t from the pinhole
// directly (no distortion), independent of ips::rayTan2Image.
std::vector<cv::Mat> flatTargetImages(const ips::CameraIntrinsics& camera, int count, double grey) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0, 2.0);
  std::vector<cv::Mat> images;
  for (int k = 0; k < count; ++k) {
    cv::Mat image(camera.height, camera.width, CV_8UC1);
    for (int y = 0; y < camera.height; ++y)
      for (int x = 0; x < camera.width; ++x) {
        const double u = (x - camera.K(0, 2)) / camera.K(0, 0), v = (y - camera.K(1, 2)) / camera.K(1, 1);
        const double t = u * u + v * v;
        image.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(grey / ((1 + t) * (1 + t)) + noise(rng));
      }
    images.push_back(image);
  }
  return images;
}

}  // namespace

TEST(Vignetting, FlatTargetGivesNaturalVignettingsGain) {
  const ips::CameraIntrinsics camera = widePinhole();
  VignettingOptions options;
  options.source = FlatFieldSource::kFlatTarget;
  VignettingAccumulator accumulator(camera, options);
  for (const cv::Mat& image : flatTargetImages(camera, 5, 230)) accumulator.add(image);
  const VignettingEstimate e = accumulator.estimate();
  std::cout << "flat target: gain 1 + " << e.gain.transpose() << ", corners x" << e.corner_gain << " (true "
            << (1 + e.widest_tan2) * (1 + e.widest_tan2) << "), flatness left " << 100 * e.relative_residual << " %\n";
  EXPECT_NEAR(e.widest_tan2, (159.5 * 159.5 + 119.5 * 119.5) / (150.0 * 150.0), 1e-4);  // pixel (0, 0)
  // The corners hold greys of 30 with noise 2 and the grey's rounding: the gain within 1.5 % everywhere.
  EXPECT_LT(worstGainError(camera, e), 0.015);
  EXPECT_LT(e.relative_residual, 0.01);
}

TEST(Vignetting, ClippedAndBadImagesAreLeftOut) {
  const ips::CameraIntrinsics camera = widePinhole();
  VignettingOptions options;
  options.source = FlatFieldSource::kFlatTarget;
  VignettingAccumulator accumulator(camera, options);
  EXPECT_THROW(accumulator.estimate(), std::runtime_error);  // no image yet
  EXPECT_THROW(accumulator.add(cv::Mat(10, 10, CV_8UC1)), std::invalid_argument);
  // A brighter surface clips the centre at 255: those pixels must not enter the fit (they would flatten the gain).
  for (const cv::Mat& image : flatTargetImages(camera, 5, 400)) accumulator.add(image);
  const VignettingEstimate e = accumulator.estimate();
  EXPECT_LT(worstGainError(camera, e), 0.015) << e.gain.transpose();
}

TEST(Vignetting, WalkOfTheSimulatedHardHeadGivesItsLensGain) {
  // The hard walk (config/sim_hard.yaml): views of an ordinary building, auto exposure, motion blur, people, the
  // renderer's cos^4 vignetting of its 85 deg lenses; two consecutive raw pairs every two seconds of the walk.
  ips::sim::Scenario scenario = ips::sim::Scenario::load(std::string(IPS_SOURCE_DIR) + "/config/sim_hard.yaml");
  const ips::sim::Rig rig(scenario);
  // The lenses as the stereo calibration gives them, without the vignetting to estimate.
  ips::StereoCalibration lenses = rig.head.calibration;
  lenses.cam0.vignetting_gain = lenses.cam1.vignetting_gain = Eigen::Vector3d::Zero();
  VignettingAccumulator cameras[2] = {VignettingAccumulator(lenses.cam0), VignettingAccumulator(lenses.cam1)};
  // The widest ray E3D's rectified view (alpha 0: valid pixels only) sees, from the true gain at its corners.
  double rectified_widest_tan2[2] = {0, 0};
  {
    const ips::StereoRectification rect = ips::computeRectification(rig.head.calibration);
    double highest[2] = {0, 0};
    cv::minMaxLoc(rect.gain0, nullptr, &highest[0]);
    cv::minMaxLoc(rect.gain1, nullptr, &highest[1]);
    for (int c = 0; c < 2; ++c) rectified_widest_tan2[c] = std::sqrt(highest[c]) - 1;
  }
  const int64_t step = std::llround(2 * scenario.camera.rate_hz);
  const int64_t frames = std::llround(rig.trajectory.duration() * scenario.camera.rate_hz);
  for (int64_t k = 0; k + 1 < frames; k += step) {
    bool first_taken = false;
    for (int64_t j = k; j <= k + 1; ++j) {
      const ips::sim::StereoFrame f = rig.renderer.render(j, false);
      if (f.left.empty()) continue;  // a pair the head lost (frame_loss): no track across it
      cameras[0].add(f.left, j == k + 1 && first_taken);
      cameras[1].add(f.right, j == k + 1 && first_taken);
      first_taken = true;
    }
  }
  for (int c = 0; c < 2; ++c) {
    const VignettingEstimate e = cameras[c].estimate();
    const ips::CameraIntrinsics& lens = c == 0 ? lenses.cam0 : lenses.cam1;
    const double rectified_error = worstGainError(lens, e, rectified_widest_tan2[c]);
    const double error = worstGainError(lens, e);
    std::cout << "camera " << c << ": " << cameras[c].tracks() << " tracks in " << e.images << " images, gain 1 + "
              << e.gain.transpose() << "; worst error over the rectified view (t <= " << rectified_widest_tan2[c]
              << ") " << 100 * rectified_error << " %, over the raw image (t <= " << e.widest_tan2 << ", corners x"
              << e.corner_gain << ", true " << (1 + e.widest_tan2) * (1 + e.widest_tan2) << ") " << 100 * error
              << " %, residual " << 100 * e.relative_residual << " %\n";
    // Measured 5.2 and 4.3 %; tracking on the raw greys (the fall-off pulls the tracks) gave 24 %.
    EXPECT_LT(rectified_error, 0.08) << "camera " << c;
  }
}

TEST(Vignetting, ToolWritesBothCamerasGainsIntoTheCalibration) {
  // calibrate_vignetting on image files of a flat target: five pairs through two wide pinhole lenses with cos^4
  // vignetting; the calibration it writes holds both gains and the rest of the calibration it read.
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("ips_vignetting_tool_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  ips::StereoCalibration calib;
  calib.cam0 = calib.cam1 = widePinhole();
  calib.t_cam1_cam0 = Eigen::Vector3d(-0.2, 0, 0);
  const std::string in = (dir / "head.calib.yaml").string(), out = (dir / "flat.calib.yaml").string();
  ips::saveCalibration(in, calib);
  const std::vector<cv::Mat> images = flatTargetImages(calib.cam0, 5, 230);
  for (size_t i = 0; i < images.size(); ++i) {
    cv::imwrite((dir / ("left_" + std::to_string(i) + ".png")).string(), images[i]);
    cv::imwrite((dir / ("right_" + std::to_string(i) + ".png")).string(), images[i]);
  }
  const std::string output = ips::test_support::commandOutput(
      std::string(CALIBRATE_VIGNETTING) + " --source flat --left '" + (dir / "left_*.png").string() + "' --right '" +
      (dir / "right_*.png").string() + "' --calib " + in + " --out " + out + "; echo exit=$?");
  EXPECT_NE(output.find("corner_gain0="), std::string::npos) << output;
  EXPECT_NE(output.find("exit=0"), std::string::npos) << output;
  const ips::StereoCalibration written = ips::loadCalibration(out);
  EXPECT_EQ(written.source, "estimated");
  EXPECT_NEAR((written.t_cam1_cam0 - calib.t_cam1_cam0).norm(), 0, 1e-12);
  for (const ips::CameraIntrinsics& cam : {written.cam0, written.cam1}) {
    VignettingEstimate e;
    e.gain = cam.vignetting_gain;
    e.widest_tan2 = ips::widestRayTan2(cam);
    EXPECT_LT(worstGainError(cam, e), 0.015) << cam.vignetting_gain.transpose();
  }
  // Too few images for a moving scene's default (50): an error that says so, exit status 1.
  const std::string refused = ips::test_support::commandOutput(
      std::string(CALIBRATE_VIGNETTING) + " --left '" + (dir / "left_*.png").string() + "' --right '" +
      (dir / "right_*.png").string() + "' --calib " + in + " 2>&1; echo exit=$?");
  EXPECT_NE(refused.find("need at least 50"), std::string::npos) << refused;
  EXPECT_NE(refused.find("exit=1"), std::string::npos) << refused;
  fs::remove_all(dir);
}

TEST(Vignetting, SimulatedStereoPairsFollowTheFlatField) {
  // The flat field of a rectified pair checked by the other camera: a point seen in both images of a pair lies at
  // another place of each lens's fall-off, so the log grey ratio of its two patches is log G_right(its right
  // position) - log G_left(its left position), plus the pair's exposure difference. Regressed on that prediction
  // (StereoRectification's gains of the simulated hard head's true lenses), the ratios of the plain rectified pairs
  // follow it (slope 1) and those of the flat-fielded pairs do not (slope 0). Matches from OpenCV's StereoSGBM on
  // the plain pair, the same matches for both.
  ips::sim::Scenario scenario = ips::sim::Scenario::load(std::string(IPS_SOURCE_DIR) + "/config/sim_hard.yaml");
  const ips::sim::Rig rig(scenario);
  const ips::StereoRectification flat = ips::computeRectification(rig.head.calibration);
  ASSERT_TRUE(flat.hasFlatField());
  ips::StereoRectification plain = flat;
  plain.gain0 = plain.gain1 = cv::Mat();
  const cv::Ptr<cv::StereoSGBM> sgbm = cv::StereoSGBM::create(0, 128, 5, 8 * 25, 32 * 25, 1, 0, 10, 100, 2);
  double covariance[2] = {0, 0}, variance = 0;
  size_t matches = 0;
  for (int64_t k = 100; k < 700; k += 40) {
    const ips::sim::StereoFrame f = rig.renderer.render(k, false);
    if (f.left.empty()) continue;
    cv::Mat images[2][2], disparity;
    rectifyPair(plain, f.left, f.right, images[0][0], images[0][1]);
    rectifyPair(flat, f.left, f.right, images[1][0], images[1][1]);
    sgbm->compute(images[0][0], images[0][1], disparity);
    cv::Mat mean[2][2];
    for (int version = 0; version < 2; ++version)
      for (int c = 0; c < 2; ++c) cv::blur(images[version][c], mean[version][c], cv::Size(5, 5));
    std::vector<double> predicted, ratio[2];
    for (int y = 8; y < disparity.rows - 8; y += 4)
      for (int x = 136; x < disparity.cols - 8; x += 4) {
        const int d16 = disparity.at<int16_t>(y, x);
        if (d16 <= 0) continue;
        const int xr = x - (d16 + 8) / 16;
        double r[2];
        bool usable = true;
        for (int version = 0; version < 2; ++version) {
          const uint8_t l = mean[version][0].at<uint8_t>(y, x), g = mean[version][1].at<uint8_t>(y, xr);
          usable &= l >= 10 && g >= 10 && l <= 245 && g <= 245;
          r[version] = std::log(double(l)) - std::log(double(g));
        }
        if (!usable) continue;
        predicted.push_back(std::log(flat.gain1.at<float>(y, xr)) - std::log(flat.gain0.at<float>(y, x)));
        for (int version = 0; version < 2; ++version) ratio[version].push_back(r[version]);
      }
    // Centred per pair: the pair's exposure difference.
    const auto centre = [](std::vector<double>& v) {
      double m = 0;
      for (double a : v) m += a;
      m /= static_cast<double>(v.size());
      for (double& a : v) a -= m;
    };
    centre(predicted);
    for (int version = 0; version < 2; ++version) centre(ratio[version]);
    for (size_t i = 0; i < predicted.size(); ++i) {
      variance += predicted[i] * predicted[i];
      for (int version = 0; version < 2; ++version) covariance[version] += predicted[i] * ratio[version][i];
    }
    matches += predicted.size();
  }
  const double slope_plain = covariance[0] / variance, slope_flat = covariance[1] / variance;
  std::cout << matches << " stereo matches: the grey ratio follows the predicted fall-off (spread "
            << std::sqrt(variance / static_cast<double>(matches)) << ") with slope " << slope_plain
            << " on the plain pairs, " << slope_flat << " on the flat-fielded ones\n";
  ASSERT_GT(matches, 100000u);
  EXPECT_NEAR(slope_plain, 1.0, 0.15);
  EXPECT_NEAR(slope_flat, 0.0, 0.15);
}

TEST(Vignetting, EurocCamerasAndDirectionsAgree) {
  // A real head: EuRoC MH_01's two cameras (752x480, the same wide-angle lens model), the flat field estimated from
  // the 150 consecutive images of each camera. There is no flat-field truth; what must hold is consistency: the two
  // cameras, estimated from their own images, and the images taken in reverse order (an effect of the motion, such
  // as approaching a surface, would change with the direction; the lens's fall-off does not).
  IPS_REQUIRE_SHARED_DATA("euroc/MH_01_easy_first150/mav0");
  const std::string mav0 = ips::dataDir() + "/euroc/MH_01_easy_first150/mav0";
  const ips::StereoCalibration calib = readEuroc(mav0 + "/cam0/sensor.yaml", mav0 + "/cam1/sensor.yaml");
  const std::vector<std::string> files[2] = {matchingFiles(mav0 + "/cam0/data/*.png"),
                                             matchingFiles(mav0 + "/cam1/data/*.png")};
  ASSERT_EQ(files[0].size(), 150u);
  VignettingAccumulator left(calib.cam0), right(calib.cam1), left_reversed(calib.cam0);
  for (const std::string& file : files[0]) left.add(cv::imread(file, cv::IMREAD_GRAYSCALE));
  for (const std::string& file : files[1]) right.add(cv::imread(file, cv::IMREAD_GRAYSCALE));
  for (auto file = files[0].rbegin(); file != files[0].rend(); ++file)
    left_reversed.add(cv::imread(*file, cv::IMREAD_GRAYSCALE));
  const VignettingEstimate e[3] = {left.estimate(), right.estimate(), left_reversed.estimate()};
  std::cout << "EuRoC MH_01: corners lifted " << e[0].corner_gain << " (left), " << e[1].corner_gain << " (right), "
            << e[2].corner_gain << " (left, images reversed); residual " << 100 * e[0].relative_residual << " %\n";
  EXPECT_NEAR(e[1].corner_gain / e[0].corner_gain, 1.0, 0.05);
  EXPECT_NEAR(e[2].corner_gain / e[0].corner_gain, 1.0, 0.02);
  for (const VignettingEstimate& estimate : e) EXPECT_LT(estimate.relative_residual, 0.03);
  // The same images taken for a flat target: their mean is no flat field, and the fit says so rather than writing a
  // gain that turns negative in the corners.
  VignettingOptions flat_target;
  flat_target.source = FlatFieldSource::kFlatTarget;
  VignettingAccumulator wrong_source(calib.cam0, flat_target);
  for (const std::string& file : files[0]) wrong_source.add(cv::imread(file, cv::IMREAD_GRAYSCALE));
  EXPECT_THROW(wrong_source.estimate(), std::runtime_error);
}
