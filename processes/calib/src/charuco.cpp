#include "ips/calib/charuco.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <unordered_map>

#ifdef IPS_CALIB_HAVE_ARUCO
#include <opencv2/aruco/charuco.hpp>
#endif

namespace ips::calib {
namespace {

// OpenCV's predefined dictionaries in the order of cv::aruco::PREDEFINED_DICTIONARY_NAME (DICT_4X4_50 = 0, ...).
const char* const kDictionaryNames[] = {
    "DICT_4X4_50",        "DICT_4X4_100",        "DICT_4X4_250",       "DICT_4X4_1000",      "DICT_5X5_50",
    "DICT_5X5_100",       "DICT_5X5_250",        "DICT_5X5_1000",      "DICT_6X6_50",        "DICT_6X6_100",
    "DICT_6X6_250",       "DICT_6X6_1000",       "DICT_7X7_50",        "DICT_7X7_100",       "DICT_7X7_250",
    "DICT_7X7_1000",      "DICT_ARUCO_ORIGINAL", "DICT_APRILTAG_16h5", "DICT_APRILTAG_25h9", "DICT_APRILTAG_36h10",
    "DICT_APRILTAG_36h11"};

int dictionaryIndex(const std::string& name) {
  for (size_t i = 0; i < std::size(kDictionaryNames); ++i)
    if (name == kDictionaryNames[i]) return static_cast<int>(i);
  return -1;
}

[[noreturn]] void noAruco() {
  throw std::runtime_error(
      "ChArUco boards need OpenCV's aruco module (Debian: libopencv-contrib-dev); this build has none");
}

#ifdef IPS_CALIB_HAVE_ARUCO
cv::Ptr<cv::aruco::Dictionary> dictionaryOf(const CharucoSpec& board) {
  return cv::aruco::getPredefinedDictionary(
      static_cast<cv::aruco::PREDEFINED_DICTIONARY_NAME>(dictionaryIndex(board.dictionary)));
}

cv::Ptr<cv::aruco::CharucoBoard> boardOf(const CharucoSpec& board) {
  validateCharucoSpec(board);
  return cv::aruco::CharucoBoard::create(board.squares.width, board.squares.height, static_cast<float>(board.square_m),
                                         static_cast<float>(board.marker_m), dictionaryOf(board));
}
#endif

}  // namespace

bool charucoAvailable() {
#ifdef IPS_CALIB_HAVE_ARUCO
  return true;
#else
  return false;
#endif
}

std::vector<std::string> charucoDictionaryNames() {
  return std::vector<std::string>(std::begin(kDictionaryNames), std::end(kDictionaryNames));
}

void validateCharucoSpec(const CharucoSpec& board) {
  if (board.squares.width < 3 || board.squares.height < 3)
    throw std::invalid_argument("a ChArUco board needs at least 3x3 squares (2x2 inner corners)");
  if (!(board.square_m > 0) || !(board.marker_m > 0))
    throw std::invalid_argument("the ChArUco board's square and marker sizes must be positive");
  if (!(board.marker_m < board.square_m)) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "the ChArUco board's marker (%g m) must be smaller than its square (%g m)",
                  board.marker_m, board.square_m);
    throw std::invalid_argument(buf);
  }
  if (dictionaryIndex(board.dictionary) < 0) {
    std::string names;
    for (const char* n : kDictionaryNames) names += std::string(names.empty() ? "" : ", ") + n;
    throw std::invalid_argument("unknown ArUco dictionary '" + board.dictionary + "' (" + names + ")");
  }
#ifdef IPS_CALIB_HAVE_ARUCO
  const int markers = board.squares.width * board.squares.height / 2;
  const int codes = dictionaryOf(board)->bytesList.rows;
  if (markers > codes)
    throw std::invalid_argument("a " + std::to_string(board.squares.width) + "x" +
                                std::to_string(board.squares.height) + " ChArUco board has " + std::to_string(markers) +
                                " markers, " + board.dictionary + " only " + std::to_string(codes));
#endif
}

int charucoCornerCount(const CharucoSpec& board) { return (board.squares.width - 1) * (board.squares.height - 1); }

std::vector<cv::Point3d> charucoCornerPositions(const CharucoSpec& board) {
  // As CharucoBoard::chessboardCorners (row-major from the top-left inner corner, one square in from the edge),
  // written out so that it does not need the module.
  std::vector<cv::Point3d> p;
  for (int y = 1; y < board.squares.height; ++y)
    for (int x = 1; x < board.squares.width; ++x) p.emplace_back(x * board.square_m, y * board.square_m, 0.0);
  return p;
}

#ifdef IPS_CALIB_HAVE_ARUCO

cv::Mat drawCharucoSheet(const CharucoSpec& board, int px_per_square, int margin_px) {
  if (px_per_square < 8 || margin_px < 0)
    throw std::invalid_argument("a ChArUco sheet needs at least 8 px per square and a margin of 0 or more");
  cv::Mat sheet;
  boardOf(board)->draw(cv::Size(board.squares.width * px_per_square + 2 * margin_px,
                                board.squares.height * px_per_square + 2 * margin_px),
                       sheet, margin_px, 1);
  return sheet;
}

bool detectCharuco(const cv::Mat& image, const CharucoSpec& board, CharucoDetection& found) {
  found = {};
  const cv::Ptr<cv::aruco::CharucoBoard> b = boardOf(board);
  cv::Mat gray;
  if (image.channels() == 3)
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  else
    gray = image;
  std::vector<std::vector<cv::Point2f>> marker_corners;
  std::vector<int> marker_ids;
  cv::aruco::detectMarkers(gray, b->dictionary, marker_corners, marker_ids);
  if (marker_ids.empty()) return false;
  std::vector<cv::Point2f> corners;
  std::vector<int> ids;
  // No camera model: each corner placed by the homography of its neighbouring markers (minMarkers 2: both of them
  // seen), then refined by OpenCV with a coarse stopping rule (0.1 px).
  cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, gray, b, corners, ids, cv::noArray(), cv::noArray(),
                                       2);
  if (ids.empty()) return false;
  // Refined again to 0.01 px as detectChessboard does. The window stays inside the corner's four squares: the nearest
  // marker corner lies diagonally, d pixels away, its edges d / sqrt(2) from the corner along the rows and columns;
  // the gradient (3x3) and the corner's remaining error (under 0.5 px) take another 1.5 px. Markers' edges in the
  // window would pull the corner towards them.
  std::vector<cv::Point2f> all_marker_corners;
  for (const auto& m : marker_corners) all_marker_corners.insert(all_marker_corners.end(), m.begin(), m.end());
  for (auto& c : corners) {
    double d = std::numeric_limits<double>::max();
    for (const auto& m : all_marker_corners) d = std::min<double>(d, std::hypot(m.x - c.x, m.y - c.y));
    const int win = std::clamp(static_cast<int>(d / std::sqrt(2.0) - 1.5), 2, 11);
    std::vector<cv::Point2f> one{c};
    cv::cornerSubPix(gray, one, cv::Size(win, win), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 30, 0.01));
    c = one[0];
  }
  std::vector<size_t> order(ids.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return ids[a] < ids[b]; });
  for (size_t i : order) {
    found.ids.push_back(ids[i]);
    found.corners.push_back(corners[i]);
  }
  return true;
}

#else

cv::Mat drawCharucoSheet(const CharucoSpec&, int, int) { noAruco(); }
bool detectCharuco(const cv::Mat&, const CharucoSpec&, CharucoDetection&) { noAruco(); }

#endif

std::string charucoStereoView(const CharucoSpec& board, const CharucoDetection& left, const CharucoDetection& right,
                              size_t min_common, StereoView& view) {
  view.object.clear();
  view.left.clear();
  view.right.clear();
  if (left.ids.empty() || right.ids.empty())
    return std::string("board not found in the ") + (left.ids.empty() && right.ids.empty() ? "left and right images"
                                                     : left.ids.empty()                    ? "left image"
                                                                                           : "right image");
  const std::vector<cv::Point3d> positions = charucoCornerPositions(board);
  std::unordered_map<int, cv::Point2f> in_right;
  for (size_t i = 0; i < right.ids.size(); ++i) in_right.emplace(right.ids[i], right.corners[i]);
  for (size_t i = 0; i < left.ids.size(); ++i) {
    const int id = left.ids[i];
    const auto r = in_right.find(id);
    if (r == in_right.end() || id < 0 || id >= static_cast<int>(positions.size())) continue;
    view.object.push_back(positions[id]);
    view.left.push_back(left.corners[i]);
    view.right.push_back(r->second);
  }
  const size_t n = view.object.size();
  if (n < min_common)
    return std::to_string(n) + " corners seen in both images, at least " + std::to_string(min_common) + " needed";
  // On one line of the board (one row, one column): the smaller spread of the board points about their centroid is
  // zero; any two rows or columns give a quarter square squared.
  cv::Point2d mean(0, 0);
  for (const auto& p : view.object) mean += cv::Point2d(p.x, p.y) / static_cast<double>(n);
  double sxx = 0, syy = 0, sxy = 0;
  for (const auto& p : view.object) {
    sxx += (p.x - mean.x) * (p.x - mean.x) / n;
    syy += (p.y - mean.y) * (p.y - mean.y) / n;
    sxy += (p.x - mean.x) * (p.y - mean.y) / n;
  }
  const double smaller = 0.5 * (sxx + syy) - std::sqrt(0.25 * (sxx - syy) * (sxx - syy) + sxy * sxy);
  if (smaller < 0.01 * board.square_m * board.square_m) return "the corners seen in both images lie on one line";
  return "";
}

StereoCalibrationResult calibrateStereoCharuco(const std::vector<StereoImagePair>& pairs, const CharucoSpec& board,
                                               const CalibrationOptions& options) {
  if (!charucoAvailable()) noAruco();
  validateCharucoSpec(board);
  if (pairs.empty()) throw std::runtime_error("no image pairs");
  const cv::Size size = pairs.front().left.size();
  std::vector<StereoView> views;
  std::vector<RejectedView> rejected;
  for (const auto& p : pairs) {
    if (p.left.empty() || p.right.empty()) {
      rejected.push_back({p.name, "image could not be read"});
      continue;
    }
    if (p.left.size() != size || p.right.size() != size)
      throw std::runtime_error(p.name + ": image size differs from the first pair's " + std::to_string(size.width) +
                               "x" + std::to_string(size.height));
    CharucoDetection l, r;
    detectCharuco(p.left, board, l);
    detectCharuco(p.right, board, r);
    StereoView view;
    view.name = p.name;
    const std::string why = charucoStereoView(board, l, r, options.min_common_corners, view);
    if (!why.empty()) {
      rejected.push_back({p.name, why});
      continue;
    }
    views.push_back(std::move(view));
  }
  return calibrateStereoFromViews(views, size, options, std::move(rejected));
}

}  // namespace ips::calib
