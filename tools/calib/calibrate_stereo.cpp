// calibrate_stereo: both cameras and the stereo geometry of a head from chessboard or ChArUco image pairs (image files,
// or the head's LCM log), written as the project's calibration file. The library (ips/calib/stereo_calibration.hpp)
// does the work; this reads the images and prints the figures. The last line is `rms_px=... epipolar_px=...
// heldout_epipolar_px=...`.
#include <cmath>
#include <cstdio>
#include <ips/stereo_pair_t.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "ips/args.hpp"
#include "ips/calib/charuco.hpp"
#include "ips/calib/image_files.hpp"
#include "ips/calib/stereo_calibration.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/log_reader.hpp"
#include "ips/framework/validate.hpp"

namespace {

// A printed sheet of the ChArUco board: 300 dots per inch, so that printed at 100 % the squares have the size asked
// for (to the nearest dot); a white margin of half a square.
void writeCharucoSheet(const ips::calib::CharucoSpec& board, const std::string& path) {
  constexpr double kDpi = 300, kInch = 0.0254;
  const int px = static_cast<int>(std::lround(board.square_m / kInch * kDpi));
  const cv::Mat sheet = ips::calib::drawCharucoSheet(board, px, px / 2);
  if (!cv::imwrite(path, sheet)) throw std::runtime_error("--write-charuco-sheet " + path + ": cannot write");
  const double mm_per_px = kInch / kDpi * 1000;
  std::printf(
      "wrote %s: %dx%d px at 300 dpi; print at 100 %% (no fit to page): squares %.2f mm, markers about %.1f mm, "
      "sheet %.0f x %.0f mm. Measure the printed squares (over the whole board, divided by %d) and give that to "
      "--square.\n",
      path.c_str(), sheet.cols, sheet.rows, px * mm_per_px, board.marker_m / board.square_m * px * mm_per_px,
      sheet.cols * mm_per_px, sheet.rows * mm_per_px, board.squares.width);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    ips::Args args(argc, argv,
                   "Stereo calibration from chessboard or ChArUco image pairs -> the project's calibration file");
    args.option("--left", "GLOB", "left images (quoted glob; sorted, paired by order with --right)")
        .option("--right", "GLOB", "right images")
        .option("--log", "FILE.lcmlog",
                "instead of --left/--right: the head's recording; one view per pose, taken while the board stands "
                "still")
        .option("--stereo-channel", "NAME", "with --log: channel of ips::stereo_pair_t", "STEREO")
        .option("--board", "WxH", "a chessboard: inner corners per row and column, e.g. 9x6 (or --charuco)")
        .option("--charuco", "WxH",
                "a ChArUco board (OpenCV's aruco module): squares per row and column, e.g. 10x7 (or --board); views "
                "of part of the board are used")
        .required("--square", "METRES", "edge of one board square")
        .option("--marker", "METRES", "with --charuco: edge of one marker")
        .option("--dictionary", "NAME",
                "with --charuco: OpenCV's predefined ArUco dictionary (DICT_4X4_50 ... DICT_APRILTAG_36h11); the "
                "default is that of OpenCV's ChArUco tutorial",
                ips::calib::kDefaultCharucoDictionary)
        .option("--min-common-corners", "N",
                "with --charuco: a pair is used when both images see at least N of the same corners", "12")
        .option("--write-charuco-sheet", "FILE.png",
                "write the --charuco board to print (300 dpi) and stop; needs no images")
        .option("--out", "FILE.yaml", "calibration file to write (required unless --write-charuco-sheet)")
        .option("--lens-model", "MODEL",
                "auto (both fitted, the lower held-out epipolar error chosen), radial-tangential or equidistant",
                "auto")
        .option("--calib", "FILE",
                "the head's calibration so far (or as designed): its IMU and tilt sensor mounting go into --out "
                "unchanged (without it they are the identity, to be calibrated)")
        .option("--check-png", "FILE.png", "write the first pair rectified, with horizontal lines, to this file");
    if (!args.parse()) return 0;
    if (args.has("--board") == args.has("--charuco"))
      throw ips::ArgError(args.has("--board")
                              ? "calibrate_stereo: give --board (a chessboard) or --charuco (a ChArUco board), not both"
                              : "calibrate_stereo: give --board WxH (a chessboard) or --charuco WxH (a ChArUco board)");
    const bool charuco = args.has("--charuco");
    if (args.has("--marker") && !charuco) throw ips::ArgError("calibrate_stereo: --marker is for --charuco boards");
    if (args.has("--write-charuco-sheet") && !charuco)
      throw ips::ArgError("calibrate_stereo: --write-charuco-sheet needs --charuco, --square and --marker");
    ips::calib::ChessboardSpec board;
    ips::calib::CharucoSpec charuco_board;
    if (charuco) {
      if (std::sscanf(args.get("--charuco").c_str(), "%dx%d", &charuco_board.squares.width,
                      &charuco_board.squares.height) != 2)
        throw ips::ArgError("calibrate_stereo: --charuco " + args.get("--charuco") +
                            ": expected squares per row and column, e.g. 10x7");
      if (!args.has("--marker"))
        throw ips::ArgError("calibrate_stereo: --charuco needs --marker METRES (the edge of one marker)");
      charuco_board.square_m = args.getDouble("--square");
      charuco_board.marker_m = args.getDouble("--marker");
      charuco_board.dictionary = args.get("--dictionary");
      try {
        ips::calib::validateCharucoSpec(charuco_board);
      } catch (const std::invalid_argument& e) {
        throw ips::ArgError(std::string("calibrate_stereo: --charuco: ") + e.what());
      }
      if (!ips::calib::charucoAvailable())
        throw std::runtime_error(
            "ChArUco boards need OpenCV's aruco module (Debian: libopencv-contrib-dev); "
            "this build has none");
      if (args.has("--write-charuco-sheet")) {
        writeCharucoSheet(charuco_board, args.get("--write-charuco-sheet"));
        return 0;
      }
    } else {
      if (std::sscanf(args.get("--board").c_str(), "%dx%d", &board.inner_corners.width, &board.inner_corners.height) !=
          2)
        throw std::runtime_error("--board " + args.get("--board") + ": expected WxH, e.g. 9x6");
      board.square_m = args.getDouble("--square");
    }
    if (!args.has("--out")) throw ips::ArgError("calibrate_stereo: --out FILE.yaml is required");
    if (args.has("--log") == (args.has("--left") || args.has("--right")) ||
        (!args.has("--log") && !(args.has("--left") && args.has("--right"))))
      throw ips::ArgError("calibrate_stereo: give --left and --right, or --log (see --help)");
    ips::calib::CalibrationOptions options;
    if (args.getInt("--min-common-corners") < 4)
      throw ips::ArgError("calibrate_stereo: --min-common-corners must be at least 4 (a homography's)");
    options.min_common_corners = static_cast<size_t>(args.getInt("--min-common-corners"));
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
      std::vector<ips::calib::StereoView> views;  // ChArUco: each with the corners both images saw
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
        const std::string name = "utime " + std::to_string(m.utime);
        if (charuco) {
          // Still and moved are judged on the corners by id: a corner that comes and goes does not count.
          ips::calib::CharucoDetection l, r;
          ips::calib::detectCharuco(left, charuco_board, l);
          if (!picker.offer(l.ids, l.corners)) continue;
          ips::calib::detectCharuco(right, charuco_board, r);
          ips::calib::StereoView view;
          view.name = name;
          const std::string why = ips::calib::charucoStereoView(charuco_board, l, r, options.min_common_corners, view);
          if (!why.empty()) {
            rejected.push_back({name, why});
            continue;
          }
          if (pairs.empty()) pairs.push_back({name, left.clone(), right.clone()});
          names.push_back(name);
          views.push_back(std::move(view));
          continue;
        }
        std::vector<cv::Point2f> l, r;
        if (!ips::calib::detectChessboard(left, board.inner_corners, l)) l.clear();
        if (!picker.offer(l)) continue;
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
      result = charuco ? ips::calib::calibrateStereoFromViews(views, size, options, rejected)
                       : ips::calib::calibrateStereoFromCorners(names, left_corners, right_corners, board, size,
                                                                options, rejected);
    } else {
      const std::vector<std::string> left = ips::calib::matchingFiles(args.get("--left")),
                                     right = ips::calib::matchingFiles(args.get("--right"));
      if (left.empty()) throw std::runtime_error("--left " + args.get("--left") + ": no files matched");
      if (right.empty()) throw std::runtime_error("--right " + args.get("--right") + ": no files matched");
      if (left.size() != right.size())
        throw std::runtime_error("--left matched " + std::to_string(left.size()) + " files, --right " +
                                 std::to_string(right.size()));
      for (size_t i = 0; i < left.size(); ++i)
        pairs.push_back(
            {left[i], cv::imread(left[i], cv::IMREAD_GRAYSCALE), cv::imread(right[i], cv::IMREAD_GRAYSCALE)});
      result = charuco ? ips::calib::calibrateStereoCharuco(pairs, charuco_board, options)
                       : ips::calib::calibrateStereo(pairs, board, options);
    }

    for (const auto& r : result.rejected) std::printf("rejected %s: %s\n", r.name.c_str(), r.reason.c_str());
    for (const auto& v : result.views)
      std::printf("view %s: rms_left_px=%.3f rms_right_px=%.3f epipolar_px=%.3f corners=%zu\n", v.name.c_str(),
                  v.rms_left_px, v.rms_right_px, v.epipolar_px, v.corners);
    if (charuco) {
      size_t partial = 0;
      for (const auto& v : result.views)
        partial += v.corners < static_cast<size_t>(ips::calib::charucoCornerCount(charuco_board));
      std::printf("views with part of the board %zu of %zu (the board has %d corners)\n", partial, result.views.size(),
                  ips::calib::charucoCornerCount(charuco_board));
    }
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
