// calibrate_stereo: both cameras and the stereo geometry of a head from chessboard image pairs (image files, or the
// head's LCM log), written as the project's calibration file. The library (ips/calib/stereo_calibration.hpp) does the
// work; this reads the images and prints the figures. The last line is `rms_px=... epipolar_px=...
// heldout_epipolar_px=...`.
#include <glob.h>

#include <cstdio>
#include <ips/stereo_pair_t.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "ips/args.hpp"
#include "ips/calib/stereo_calibration.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/log_reader.hpp"
#include "ips/framework/validate.hpp"

namespace {

std::vector<std::string> matching(const std::string& pattern) {
  // POSIX glob (sorted): the shell's syntax, including [..] sets, which cv::glob lacks.
  glob_t found{};
  std::vector<std::string> files;
  if (::glob(pattern.c_str(), 0, nullptr, &found) == 0)
    for (size_t i = 0; i < found.gl_pathc; ++i) files.emplace_back(found.gl_pathv[i]);
  globfree(&found);
  return files;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    ips::Args args(argc, argv, "Stereo calibration from chessboard image pairs -> the project's calibration file");
    args.option("--left", "GLOB", "left images (quoted glob; sorted, paired by order with --right)")
        .option("--right", "GLOB", "right images")
        .option("--log", "FILE.lcmlog",
                "instead of --left/--right: the head's recording; one view per pose, taken while the board stands "
                "still")
        .option("--stereo-channel", "NAME", "with --log: channel of ips::stereo_pair_t", "STEREO")
        .required("--board", "WxH", "inner corners per row and column, e.g. 9x6")
        .required("--square", "METRES", "edge of one board square")
        .required("--out", "FILE.yaml", "calibration file to write")
        .option("--lens-model", "MODEL",
                "auto (both fitted, the lower held-out epipolar error chosen), radial-tangential or equidistant",
                "auto")
        .option("--calib", "FILE",
                "the head's calibration so far (or as designed): its IMU and tilt sensor mounting go into --out "
                "unchanged (without it they are the identity, to be calibrated)")
        .option("--check-png", "FILE.png", "write the first pair rectified, with horizontal lines, to this file");
    if (!args.parse()) return 0;
    if (args.has("--log") == (args.has("--left") || args.has("--right")) ||
        (!args.has("--log") && !(args.has("--left") && args.has("--right"))))
      throw ips::ArgError("calibrate_stereo: give --left and --right, or --log (see --help)");
    ips::calib::ChessboardSpec board;
    if (std::sscanf(args.get("--board").c_str(), "%dx%d", &board.inner_corners.width, &board.inner_corners.height) != 2)
      throw std::runtime_error("--board " + args.get("--board") + ": expected WxH, e.g. 9x6");
    board.square_m = args.getDouble("--square");
    ips::calib::CalibrationOptions options;
    if (args.get("--lens-model") != "auto") {
      try {
        options.lens_models = {ips::calib::lensModelFromName(args.get("--lens-model"))};
      } catch (const std::invalid_argument& e) {
        throw ips::ArgError(std::string("calibrate_stereo: --lens-model: ") + e.what());
      }
    }

    std::vector<ips::calib::StereoImagePair> pairs;  // kept for the check picture
    ips::calib::StereoCalibrationResult result;
    if (args.has("--log")) {
      // One view per pose: corners only, so that a long recording does not stay in memory.
      std::vector<std::string> names;
      std::vector<std::vector<cv::Point2f>> left_corners, right_corners;
      std::vector<ips::calib::RejectedView> rejected;
      ips::calib::StillViewPicker picker;
      cv::Size size;
      long long seen = 0;
      ips::fw::LogReader log(args.get("--log"));
      ips::fw::LogMessage event;
      while (log.next(&event)) {
        if (event.channel != args.get("--stereo-channel")) continue;
        ips::stereo_pair_t m;
        if (m.decode(event.data.data(), 0, static_cast<int>(event.data.size())) < 0 || !ips::fw::validate(m).ok())
          continue;
        ++seen;
        const cv::Mat left = ips::fw::leftImage(m), right = ips::fw::rightImage(m);
        if (size.empty()) size = left.size();
        if (left.size() != size || right.size() != size)
          throw std::runtime_error("pair " + std::to_string(m.utime) + ": image size differs from the first pair's");
        std::vector<cv::Point2f> l, r;
        if (!ips::calib::detectChessboard(left, board.inner_corners, l)) l.clear();
        if (!picker.offer(l)) continue;
        const std::string name = "utime " + std::to_string(m.utime);
        if (!ips::calib::detectChessboard(right, board.inner_corners, r)) {
          rejected.push_back({name, "board not found in the right image"});
          continue;
        }
        if (pairs.empty()) pairs.push_back({name, left.clone(), right.clone()});
        names.push_back(name);
        left_corners.push_back(l);
        right_corners.push_back(r);
      }
      std::printf("pairs in the log %lld, views taken (board still, one per pose) %zu\n", seen, names.size());
      if (names.empty()) throw std::runtime_error(args.get("--log") + ": no still view of the board");
      result =
          ips::calib::calibrateStereoFromCorners(names, left_corners, right_corners, board, size, options, rejected);
    } else {
      const std::vector<std::string> left = matching(args.get("--left")), right = matching(args.get("--right"));
      if (left.empty()) throw std::runtime_error("--left " + args.get("--left") + ": no files matched");
      if (right.empty()) throw std::runtime_error("--right " + args.get("--right") + ": no files matched");
      if (left.size() != right.size())
        throw std::runtime_error("--left matched " + std::to_string(left.size()) + " files, --right " +
                                 std::to_string(right.size()));
      for (size_t i = 0; i < left.size(); ++i)
        pairs.push_back(
            {left[i], cv::imread(left[i], cv::IMREAD_GRAYSCALE), cv::imread(right[i], cv::IMREAD_GRAYSCALE)});
      result = ips::calib::calibrateStereo(pairs, board, options);
    }

    for (const auto& r : result.rejected) std::printf("rejected %s: %s\n", r.name.c_str(), r.reason.c_str());
    for (const auto& v : result.views)
      std::printf("view %s: rms_left_px=%.3f rms_right_px=%.3f epipolar_px=%.3f\n", v.name.c_str(), v.rms_left_px,
                  v.rms_right_px, v.epipolar_px);
    for (const auto& c : result.candidates) {
      if (c.ok)
        std::printf(
            "model %s: rms_px=%.3f epipolar_px=%.3f heldout_epipolar_px=%.3f rectified_row_px=%.3f "
            "heldout_rectified_row_px=%.3f\n",
            ips::calib::lensModelName(c.model).c_str(), c.rms_px, c.epipolar_px, c.heldout_epipolar_px,
            c.rectified_row_px, c.heldout_rectified_row_px);
      else
        std::printf("model %s: not fitted: %s\n", ips::calib::lensModelName(c.model).c_str(), c.failure.c_str());
    }
    std::printf("chosen %s (lowest held-out epipolar error), %zu views used, %zu rejected, baseline %.4f m\n",
                ips::calib::lensModelName(result.model).c_str(), result.views.size(), result.rejected.size(),
                result.calib.baseline());
    if (args.has("--calib")) {
      const ips::StereoCalibration before = ips::loadCalibration(args.get("--calib"));
      result.calib.T_imu_cam0 = before.T_imu_cam0;
      result.calib.R_tilt_cam0 = before.R_tilt_cam0;
    }
    ips::calib::saveStereoCalibration(args.get("--out"), result, args.has("--calib") ? args.get("--calib") : "");
    if (args.has("--check-png")) {
      const cv::Mat check = ips::calib::drawRectifiedCheck(result.calib, pairs.front().left, pairs.front().right);
      if (!cv::imwrite(args.get("--check-png"), check))
        throw std::runtime_error("--check-png " + args.get("--check-png") + ": cannot write");
    }
    std::printf("rms_px=%.4f epipolar_px=%.4f heldout_epipolar_px=%.4f\n", result.figures.rms_px,
                result.figures.epipolar_px, result.figures.heldout_epipolar_px);
    return 0;
  } catch (const ips::ArgError& e) {
    std::fprintf(stderr, "%s\n", e.what());  // names the program and the option
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "calibrate_stereo: %s\n", e.what());
    return 1;
  }
}
