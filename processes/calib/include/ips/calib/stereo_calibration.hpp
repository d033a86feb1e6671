#pragma once
// Stereo calibration of a head from chessboard (or ChArUco, ips/calib/charuco.hpp) image pairs: both cameras' interior
// orientation and their relative exterior orientation, for two lens models (OpenCV's radial-tangential k1 k2 p1 p2 k3,
// and the equidistant fisheye model k1..k4), the model chosen by its epipolar error on views left out of the fit.
// No LCM: the tool and the tests hand it images.
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "ips/calibration.hpp"

namespace ips::calib {

struct ChessboardSpec {
  cv::Size inner_corners;  // corners per row and column (OpenCV's patternSize), e.g. 9x6
  double square_m = 0;     // edge of one square, metres
};

struct StereoImagePair {
  std::string name;  // for messages: the left file name or the log's timestamp
  cv::Mat left, right;
};

enum class LensModel { kRadialTangential, kFisheye };
std::string lensModelName(LensModel model);
// "radial-tangential" or "equidistant" (lensModelName's words); std::invalid_argument otherwise.
LensModel lensModelFromName(const std::string& name);

struct CalibrationOptions {
  // A view whose RMS reprojection error exceeds this multiple of the median view's is dropped and the fit repeated:
  // a sub-pixel detection leaves every view within a small multiple of the median; a view several times worse has a
  // misdetected or blurred board and would bias the fit.
  double outlier_rms_factor = 3.0;
  // Views below this RMS are never outliers (detection noise of a sharp board is a few tenths of a pixel).
  double outlier_rms_floor_px = 1.0;
  // The lens models fitted; the one with the lowest held-out epipolar error is chosen. One model when the lens is
  // known (half the time: each model takes a leave-one-out fit per view).
  std::vector<LensModel> lens_models{LensModel::kRadialTangential, LensModel::kFisheye};
  // ChArUco: a pair is used when both images see at least this many of the same corners. A planar view's pose has 6
  // unknowns and a homography 8: 4 corners fix a homography exactly, with nothing left to notice a misplaced corner
  // or to average the detection noise. 12 corners (24 equations per image, three times a homography's unknowns; a
  // 3x4 block of corners, say) overdetermine the homography that starts each view's pose (calibrateCamera and
  // fisheye::calibrate both initialise from one) and the pose itself, while still admitting the small pieces of the
  // board near the image corners that are the reason for using ChArUco.
  size_t min_common_corners = 12;
};

struct RejectedView {
  std::string name;
  std::string reason;
};

struct ViewFigures {
  std::string name;
  double rms_left_px = 0, rms_right_px = 0;  // each camera's board pose fitted to the view, its corners reprojected
  double epipolar_px = 0;                    // as ModelFigures::epipolar_px, on this view
  size_t corners = 0;                        // corners used (both images); fewer than the board's: a partial view
};

struct ModelFigures {
  LensModel model = LensModel::kRadialTangential;
  double rms_px = 0;  // stereo fit's RMS reprojection error over all views, both cameras
  // Epipolar error as OpenCV's stereo_calib sample measures it: corners undistorted into the original camera
  // matrix, each corner's distance to the epipolar line of its partner, both images' distances summed per corner
  // pair, averaged over pairs.
  double epipolar_px = 0;
  double heldout_epipolar_px = 0;  // the same, each view scored by a fit that left it out (leave one out)
  double rectified_row_px = 0;     // mean |y_left - y_right| of corners after rectification, fit views
  double heldout_rectified_row_px = 0;
  bool ok = false;
  std::string failure;  // why the model could not be fitted (ok == false)
};

struct StereoCalibrationResult {
  StereoCalibration calib;  // the chosen model's; source "estimated"
  LensModel model = LensModel::kRadialTangential;
  ModelFigures figures;                  // the chosen model's
  std::vector<ModelFigures> candidates;  // every model tried
  std::vector<ViewFigures> views;        // the views used, chosen model
  std::vector<RejectedView> rejected;
  cv::Size image_size;
};

// Finds the board in one image (findChessboardCorners + cornerSubPix). Returns false when it is not found.
bool detectChessboard(const cv::Mat& image, cv::Size inner_corners, std::vector<cv::Point2f>& corners);

// Throws std::runtime_error with a one-line message when the pairs differ in size, the board is found in fewer
// than three pairs, or no model can be fitted.
StereoCalibrationResult calibrateStereo(const std::vector<StereoImagePair>& pairs, const ChessboardSpec& board,
                                        const CalibrationOptions& options = {});

// The same from corners already found: for each view its name and both images' corners in the board's row-major
// order (as detectChessboard returns them). `rejected` lists views dropped before (carried into the result).
StereoCalibrationResult calibrateStereoFromCorners(const std::vector<std::string>& names,
                                                   const std::vector<std::vector<cv::Point2f>>& left,
                                                   const std::vector<std::vector<cv::Point2f>>& right,
                                                   const ChessboardSpec& board, cv::Size image_size,
                                                   const CalibrationOptions& options = {},
                                                   std::vector<RejectedView> rejected = {});

// One view of a board in both images: the corners seen in both, each with its board coordinates (metres, z = 0) and
// its position in the left and right image, in the same order in all three. A chessboard view holds the whole grid,
// a ChArUco view the corners both images found.
struct StereoView {
  std::string name;
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2f> left, right;
};

// The same from views that carry their own board points (views of a ChArUco board seeing different parts of it).
// Throws as calibrateStereo; std::invalid_argument when a view's three lists differ in length.
StereoCalibrationResult calibrateStereoFromViews(const std::vector<StereoView>& views, cv::Size image_size,
                                                 const CalibrationOptions& options = {},
                                                 std::vector<RejectedView> rejected = {});

// Picks calibration views from a recording (an LCM log of the head), one per pose: a view is taken when the board
// stands still (its corners moved less than still_px on average since the previous image, so there is no motion
// blur) and it has moved by at least distinct_px on average since the last view taken.
class StillViewPicker {
 public:
  explicit StillViewPicker(double still_px = 0.5, double distinct_px = 20.0)
      : still_px_(still_px), distinct_px_(distinct_px) {}
  // Corners of the board in one image of the stream (empty: not found). True: take this view.
  bool offer(const std::vector<cv::Point2f>& corners);
  // The same for a board whose corners carry ids (ChArUco): the shifts are averaged over the corners seen in both
  // images compared (matched by id); none in common counts as moved.
  bool offer(const std::vector<int>& ids, const std::vector<cv::Point2f>& corners);

 private:
  double still_px_, distinct_px_;
  std::vector<int> previous_ids_, last_taken_ids_;
  std::vector<cv::Point2f> previous_, last_taken_;
};

// Writes the calibration (saveCalibration) followed by the figures, the rejected views and the date; the figure blocks
// of the file `previous` (the other tools'), if given, are kept.
void saveStereoCalibration(const std::string& path, const StereoCalibrationResult& result,
                           const std::string& previous = "");

// One rectified pair side by side with horizontal lines every `line_spacing_px` rows: matching points must lie on
// the same line.
cv::Mat drawRectifiedCheck(const StereoCalibration& calib, const cv::Mat& left, const cv::Mat& right,
                           int line_spacing_px = 32);

}  // namespace ips::calib
