#pragma once
// ChArUco boards for the stereo calibration (OpenCV's aruco module, Debian's libopencv-contrib-dev): a chessboard whose
// white squares hold ArUco markers, so that every inner corner is known by its id and a view of part of the board is
// usable. The board's corners near the image corners, where the distortion is largest, are seen in views that do not
// hold the whole board; a chessboard must be seen whole.
//
// Built without the aruco module (IPS_CALIB_HAVE_ARUCO undefined), every function here throws std::runtime_error
// saying so, except charucoAvailable().
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "ips/calib/stereo_calibration.hpp"

namespace ips::calib {

// The dictionary of OpenCV's ChArUco tutorial and of its create_board_charuco example (`-d=10`): a sheet printed from
// OpenCV's documentation is read without --dictionary. 6x6-bit markers, at least 11 bits between any two of the 250
// codes (a board uses the first squares/2 of them), so a misread marker is practically excluded; a board seen very
// small (markers under about 20 px) reads better with 5x5 or 4x4 bits (DICT_5X5_100, DICT_4X4_50).
inline const char* const kDefaultCharucoDictionary = "DICT_6X6_250";

struct CharucoSpec {
  cv::Size squares;     // squares per row and column (OpenCV's squaresX, squaresY), e.g. 10x7: 9x6 inner corners
  double square_m = 0;  // edge of one square, metres
  double marker_m = 0;  // edge of one marker, metres (less than square_m)
  std::string dictionary = kDefaultCharucoDictionary;  // OpenCV's name of a predefined dictionary, e.g. DICT_5X5_100
};

// True when the library was built with OpenCV's aruco module.
bool charucoAvailable();

// The predefined dictionaries' names (DICT_4X4_50 ... DICT_APRILTAG_36h11), as OpenCV spells them.
std::vector<std::string> charucoDictionaryNames();

// Throws std::invalid_argument with a one-line message when the board is not usable: fewer than 3x3 squares (no
// 2x2 inner corners), a size not positive, the marker not smaller than the square, an unknown dictionary, or more
// markers than the dictionary holds.
void validateCharucoSpec(const CharucoSpec& board);

// Number of inner corners: (squares.width - 1) * (squares.height - 1); corner id i lies in row i / (width - 1).
int charucoCornerCount(const CharucoSpec& board);

// Board coordinates (metres, z = 0, x along a row, y down the sheet, origin at the board's top-left outer corner) of
// every inner corner, indexed by corner id.
std::vector<cv::Point3d> charucoCornerPositions(const CharucoSpec& board);

// The board as OpenCV draws it (CharucoBoard::draw), px_per_square pixels per square, with a white margin of
// margin_px on every side: board coordinate x (metres) is at pixel column margin_px - 0.5 + x / square_m *
// px_per_square (pixel centres at whole numbers), likewise y.
cv::Mat drawCharucoSheet(const CharucoSpec& board, int px_per_square, int margin_px);

struct CharucoDetection {
  std::vector<int> ids;              // corner ids, ascending
  std::vector<cv::Point2f> corners;  // their image positions, same order
};

// Finds the markers (detectMarkers), the corners between them (interpolateCornersCharuco: a corner needs both of its
// neighbouring markers) and refines each corner (cornerSubPix, its window kept off the markers' edges). Returns
// false when no corner was found.
bool detectCharuco(const cv::Mat& image, const CharucoSpec& board, CharucoDetection& found);

// The stereo view of one pair's detections: the corners seen in both images, ascending id, with their board points.
// Returns "" when the view is usable, else why not (for RejectedView): the board not found in one image, fewer than
// min_common corners seen in both, or the common corners on one line of the board (no pose from them).
std::string charucoStereoView(const CharucoSpec& board, const CharucoDetection& left, const CharucoDetection& right,
                              size_t min_common, StereoView& view);

// calibrateStereo for a ChArUco board: each pair detected in both images, the views that are not usable rejected
// with the reason. Throws as calibrateStereo.
StereoCalibrationResult calibrateStereoCharuco(const std::vector<StereoImagePair>& pairs, const CharucoSpec& board,
                                               const CalibrationOptions& options = {});

}  // namespace ips::calib
