#include "ips/calib/stereo_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <unordered_map>

#include "ips/calib/figures.hpp"

namespace ips::calib {
namespace {

using Points2 = std::vector<cv::Point2d>;
using Points3 = std::vector<cv::Point3d>;

struct Detections {
  std::vector<std::string> names;
  std::vector<Points3> object;
  std::vector<Points2> left, right;

  Detections subset(const std::vector<size_t>& idx) const {
    Detections d;
    for (size_t i : idx) {
      d.names.push_back(names[i]);
      d.object.push_back(object[i]);
      d.left.push_back(left[i]);
      d.right.push_back(right[i]);
    }
    return d;
  }
  size_t size() const { return names.size(); }
};

// One model's fit: both cameras and the stereo geometry in OpenCV's types.
struct Fit {
  LensModel model;
  cv::Mat K1, D1, K2, D2, R, T;
  double rms = 0;
};

// The termination of every Levenberg-Marquardt fit: converged far below corner noise.
const cv::TermCriteria kCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-12);

Fit fitModel(LensModel model, const Detections& d, cv::Size size) {
  Fit f{model, {}, {}, {}, {}, {}, {}, 0};
  if (model == LensModel::kRadialTangential) {
    std::vector<cv::Mat> rv, tv;
    f.K1 = cv::Mat::eye(3, 3, CV_64F);
    f.K2 = cv::Mat::eye(3, 3, CV_64F);
    std::vector<std::vector<cv::Point3f>> obj;
    std::vector<std::vector<cv::Point2f>> l, r;
    for (size_t i = 0; i < d.size(); ++i) {
      obj.emplace_back(d.object[i].begin(), d.object[i].end());
      l.emplace_back(d.left[i].begin(), d.left[i].end());
      r.emplace_back(d.right[i].begin(), d.right[i].end());
    }
    cv::calibrateCamera(obj, l, size, f.K1, f.D1, rv, tv, 0, kCriteria);
    cv::calibrateCamera(obj, r, size, f.K2, f.D2, rv, tv, 0, kCriteria);
    cv::Mat E, F;
    f.rms = cv::stereoCalibrate(obj, l, r, f.K1, f.D1, f.K2, f.D2, size, f.R, f.T, E, F, cv::CALIB_USE_INTRINSIC_GUESS,
                                kCriteria);
  } else {
    std::vector<std::vector<cv::Vec3d>> obj;
    std::vector<std::vector<cv::Vec2d>> l, r;
    for (size_t i = 0; i < d.size(); ++i) {
      obj.emplace_back(d.object[i].begin(), d.object[i].end());
      l.emplace_back(d.left[i].begin(), d.left[i].end());
      r.emplace_back(d.right[i].begin(), d.right[i].end());
    }
    const int flags = cv::fisheye::CALIB_RECOMPUTE_EXTRINSIC | cv::fisheye::CALIB_FIX_SKEW;
    std::vector<cv::Vec3d> rv, tv;
    cv::Matx33d K1, K2;
    cv::Vec4d D1, D2;
    cv::fisheye::calibrate(obj, l, size, K1, D1, rv, tv, flags, kCriteria);
    cv::fisheye::calibrate(obj, r, size, K2, D2, rv, tv, flags, kCriteria);
    cv::Matx33d R;
    cv::Vec3d T;
    f.rms = cv::fisheye::stereoCalibrate(obj, l, r, K1, D1, K2, D2, size, R, T,
                                         flags | cv::fisheye::CALIB_USE_INTRINSIC_GUESS, kCriteria);
    f.K1 = cv::Mat(K1).clone();
    f.K2 = cv::Mat(K2).clone();
    f.D1 = cv::Mat(D1).clone();
    f.D2 = cv::Mat(D2).clone();
    f.R = cv::Mat(R).clone();
    f.T = cv::Mat(T).clone();
  }
  if (!std::isfinite(f.rms)) throw std::runtime_error("fit diverged");
  return f;
}

Points2 undistort(const Fit& f, const Points2& pts, bool right, const cv::Mat& R, const cv::Mat& P) {
  Points2 out;
  const cv::Mat& K = right ? f.K2 : f.K1;
  const cv::Mat& D = right ? f.D2 : f.D1;
  if (f.model == LensModel::kRadialTangential)
    cv::undistortPoints(pts, out, K, D, R, P);
  else
    cv::fisheye::undistortPoints(pts, out, K, D, R, P);
  return out;
}

// OpenCV stereo_calib's measure (see ModelFigures::epipolar_px): sum over corner pairs of both distances, and the
// number of pairs.
std::pair<double, size_t> epipolarSum(const Fit& f, const Points2& l, const Points2& r) {
  const Points2 ul = undistort(f, l, false, cv::Mat(), f.K1);
  const Points2 ur = undistort(f, r, true, cv::Mat(), f.K2);
  const cv::Mat t = f.T.reshape(1, 3);
  const cv::Mat tx = (cv::Mat_<double>(3, 3) << 0, -t.at<double>(2), t.at<double>(1), t.at<double>(2), 0,
                      -t.at<double>(0), -t.at<double>(1), t.at<double>(0), 0);
  const cv::Mat F = f.K2.inv().t() * tx * f.R * f.K1.inv();
  std::vector<cv::Vec3d> lines_r, lines_l;  // lines in the right image of left points, and vice versa
  cv::computeCorrespondEpilines(ul, 1, F, lines_r);
  cv::computeCorrespondEpilines(ur, 2, F, lines_l);
  double sum = 0;
  for (size_t j = 0; j < ul.size(); ++j) {
    sum += std::abs(ul[j].x * lines_l[j][0] + ul[j].y * lines_l[j][1] + lines_l[j][2]) +
           std::abs(ur[j].x * lines_r[j][0] + ur[j].y * lines_r[j][1] + lines_r[j][2]);
  }
  return {sum, ul.size()};
}

struct Rectification {
  cv::Mat R1, R2, P1, P2;
};

Rectification rectify(const Fit& f, cv::Size size) {
  Rectification r;
  cv::Mat Q;
  if (f.model == LensModel::kRadialTangential)
    cv::stereoRectify(f.K1, f.D1, f.K2, f.D2, size, f.R, f.T, r.R1, r.R2, r.P1, r.P2, Q, cv::CALIB_ZERO_DISPARITY, 0);
  else
    cv::fisheye::stereoRectify(f.K1, f.D1, f.K2, f.D2, size, f.R, f.T, r.R1, r.R2, r.P1, r.P2, Q,
                               cv::CALIB_ZERO_DISPARITY, size, 0.0, 1.0);
  return r;
}

// Sum of |y_left - y_right| after rectification, and the number of corner pairs.
std::pair<double, size_t> rowSum(const Fit& f, const Rectification& rect, const Points2& l, const Points2& r) {
  const Points2 rl = undistort(f, l, false, rect.R1, rect.P1);
  const Points2 rr = undistort(f, r, true, rect.R2, rect.P2);
  double sum = 0;
  for (size_t j = 0; j < rl.size(); ++j) sum += std::abs(rl[j].y - rr[j].y);
  return {sum, rl.size()};
}

// One camera's RMS on one view: the board pose fitted to the view (undistorted to normalised coordinates, PnP),
// the corners reprojected through the model.
double viewRms(const Fit& f, const Points3& obj, const Points2& pts, bool right) {
  const Points2 n = undistort(f, pts, right, cv::Mat(), cv::Mat());
  cv::Mat rvec, tvec;
  cv::solvePnP(obj, n, cv::Mat::eye(3, 3, CV_64F), cv::Mat(), rvec, tvec, false, cv::SOLVEPNP_ITERATIVE);
  const cv::Mat& K = right ? f.K2 : f.K1;
  const cv::Mat& D = right ? f.D2 : f.D1;
  Points2 proj;
  if (f.model == LensModel::kRadialTangential) {
    cv::projectPoints(obj, rvec, tvec, K, D, proj);
  } else {
    cv::Vec3d rv(rvec.at<double>(0), rvec.at<double>(1), rvec.at<double>(2));
    cv::Vec3d tv(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
    cv::fisheye::projectPoints(obj, proj, rv, tv, K, D);
  }
  double ss = 0;
  for (size_t j = 0; j < pts.size(); ++j) {
    const cv::Point2d e = proj[j] - pts[j];
    ss += e.dot(e);
  }
  return std::sqrt(ss / static_cast<double>(pts.size()));
}

CameraIntrinsics toIntrinsics(const cv::Mat& K, const cv::Mat& D, LensModel model, cv::Size size) {
  CameraIntrinsics c;
  c.width = size.width;
  c.height = size.height;
  cv::cv2eigen(K, c.K);
  c.model = model == LensModel::kRadialTangential ? DistortionModel::kRadialTangential : DistortionModel::kEquidistant;
  const cv::Mat d = D.reshape(1, 1);
  for (int i = 0; i < std::min(5, static_cast<int>(d.total())); ++i) c.distortion(i) = d.at<double>(i);
  return c;
}

ModelFigures scoreModel(LensModel model, const Detections& d, cv::Size size, Fit& fit_out) {
  ModelFigures m;
  m.model = model;
  try {
    fit_out = fitModel(model, d, size);
    m.rms_px = fit_out.rms;
    const Rectification rect = rectify(fit_out, size);
    double esum = 0, rsum = 0;
    size_t n = 0;
    for (size_t i = 0; i < d.size(); ++i) {
      const auto e = epipolarSum(fit_out, d.left[i], d.right[i]);
      esum += e.first;
      rsum += rowSum(fit_out, rect, d.left[i], d.right[i]).first;
      n += e.second;
    }
    m.epipolar_px = esum / n;
    m.rectified_row_px = rsum / n;
    // Leave one out: each view scored by the fit of all the others.
    double hsum = 0, hrsum = 0;
    size_t hn = 0;
    for (size_t i = 0; i < d.size(); ++i) {
      std::vector<size_t> keep;
      for (size_t j = 0; j < d.size(); ++j)
        if (j != i) keep.push_back(j);
      const Fit f = fitModel(model, d.subset(keep), size);
      const auto e = epipolarSum(f, d.left[i], d.right[i]);
      hsum += e.first;
      hrsum += rowSum(f, rectify(f, size), d.left[i], d.right[i]).first;
      hn += e.second;
    }
    m.heldout_epipolar_px = hsum / hn;
    m.heldout_rectified_row_px = hrsum / hn;
    m.ok = std::isfinite(m.heldout_epipolar_px);
    if (!m.ok) m.failure = "held-out epipolar error is not finite";
  } catch (const std::exception& e) {
    m.ok = false;
    m.failure = e.what();
  }
  return m;
}

}  // namespace

std::string lensModelName(LensModel model) {
  return model == LensModel::kRadialTangential ? "radial-tangential" : "equidistant";
}

LensModel lensModelFromName(const std::string& name) {
  for (LensModel model : {LensModel::kRadialTangential, LensModel::kFisheye})
    if (name == lensModelName(model)) return model;
  throw std::invalid_argument("unknown lens model '" + name + "' (radial-tangential or equidistant)");
}

bool detectChessboard(const cv::Mat& image, cv::Size inner_corners, std::vector<cv::Point2f>& corners) {
  cv::Mat gray;
  if (image.channels() == 3)
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  else
    gray = image;
  if (!cv::findChessboardCorners(gray, inner_corners, corners,
                                 cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE))
    return false;
  // The search window reaches half-way to the next corner at the board's smallest spacing seen in this view.
  double min_spacing = std::numeric_limits<double>::max();
  for (size_t i = 1; i < corners.size(); ++i)
    if (i % inner_corners.width != 0) min_spacing = std::min(min_spacing, cv::norm(corners[i] - corners[i - 1]));
  const int win = std::clamp(static_cast<int>(min_spacing / 2), 2, 11);
  cv::cornerSubPix(gray, corners, cv::Size(win, win), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 30, 0.01));
  return true;
}

namespace {

// Mean distance of the corners with the same id in both sets; infinite when they have none in common.
double meanShift(const std::vector<int>& ids_a, const std::vector<cv::Point2f>& a, const std::vector<int>& ids_b,
                 const std::vector<cv::Point2f>& b) {
  std::unordered_map<int, cv::Point2f> by_id;
  for (size_t i = 0; i < ids_b.size(); ++i) by_id.emplace(ids_b[i], b[i]);
  double sum = 0;
  size_t n = 0;
  for (size_t i = 0; i < ids_a.size(); ++i) {
    const auto it = by_id.find(ids_a[i]);
    if (it == by_id.end()) continue;
    sum += std::hypot(a[i].x - it->second.x, a[i].y - it->second.y);
    ++n;
  }
  return n == 0 ? INFINITY : sum / static_cast<double>(n);
}

}  // namespace

bool StillViewPicker::offer(const std::vector<cv::Point2f>& corners) {
  // A chessboard's corners are found all or none, in the same order: their index is their id.
  std::vector<int> ids(corners.size());
  for (size_t i = 0; i < ids.size(); ++i) ids[i] = static_cast<int>(i);
  return offer(ids, corners);
}

bool StillViewPicker::offer(const std::vector<int>& ids, const std::vector<cv::Point2f>& corners) {
  if (ids.size() != corners.size()) throw std::invalid_argument("StillViewPicker: ids and corners differ in number");
  const bool still = meanShift(ids, corners, previous_ids_, previous_) < still_px_;
  previous_ids_ = ids;
  previous_ = corners;
  if (!still || !(last_taken_.empty() || meanShift(ids, corners, last_taken_ids_, last_taken_) >= distinct_px_))
    return false;
  last_taken_ids_ = ids;
  last_taken_ = corners;
  return true;
}

StereoCalibrationResult calibrateStereo(const std::vector<StereoImagePair>& pairs, const ChessboardSpec& board,
                                        const CalibrationOptions& options) {
  if (pairs.empty()) throw std::runtime_error("no image pairs");
  StereoCalibrationResult result;  // collects the image size and the views rejected before the fit
  result.image_size = pairs.front().left.size();
  std::vector<std::string> names;
  std::vector<std::vector<cv::Point2f>> left, right;
  for (const auto& p : pairs) {
    if (p.left.empty() || p.right.empty()) {
      result.rejected.push_back({p.name, "image could not be read"});
      continue;
    }
    if (p.left.size() != result.image_size || p.right.size() != result.image_size)
      throw std::runtime_error(p.name + ": image size differs from the first pair's " +
                               std::to_string(result.image_size.width) + "x" +
                               std::to_string(result.image_size.height));
    std::vector<cv::Point2f> l, r;
    const bool found_l = detectChessboard(p.left, board.inner_corners, l);
    const bool found_r = detectChessboard(p.right, board.inner_corners, r);
    if (!found_l || !found_r) {
      result.rejected.push_back(
          {p.name, std::string("board not found in the ") + (!found_l && !found_r ? "left and right images"
                                                             : !found_l           ? "left image"
                                                                                  : "right image")});
      continue;
    }
    names.push_back(p.name);
    left.push_back(l);
    right.push_back(r);
  }
  return calibrateStereoFromCorners(names, left, right, board, result.image_size, options, result.rejected);
}

StereoCalibrationResult calibrateStereoFromCorners(const std::vector<std::string>& names,
                                                   const std::vector<std::vector<cv::Point2f>>& left,
                                                   const std::vector<std::vector<cv::Point2f>>& right,
                                                   const ChessboardSpec& board, cv::Size image_size,
                                                   const CalibrationOptions& options,
                                                   std::vector<RejectedView> rejected) {
  if (board.inner_corners.width < 2 || board.inner_corners.height < 2 || !(board.square_m > 0))
    throw std::runtime_error("board needs at least 2x2 inner corners and a positive square size");
  if (left.size() != names.size() || right.size() != names.size())
    throw std::invalid_argument("calibrateStereoFromCorners: names, left and right corners differ in number");
  // Every view carries the whole grid, row-major as findChessboardCorners orders the corners.
  std::vector<cv::Point3d> object;
  for (int y = 0; y < board.inner_corners.height; ++y)
    for (int x = 0; x < board.inner_corners.width; ++x)
      object.emplace_back(x * board.square_m, y * board.square_m, 0.0);
  std::vector<StereoView> views;
  for (size_t i = 0; i < names.size(); ++i) views.push_back({names[i], object, left[i], right[i]});
  return calibrateStereoFromViews(views, image_size, options, std::move(rejected));
}

StereoCalibrationResult calibrateStereoFromViews(const std::vector<StereoView>& views, cv::Size image_size,
                                                 const CalibrationOptions& options,
                                                 std::vector<RejectedView> rejected) {
  StereoCalibrationResult result;
  result.image_size = image_size;
  result.rejected = std::move(rejected);
  Detections all;
  for (const StereoView& v : views) {
    if (v.object.size() != v.left.size() || v.object.size() != v.right.size())
      throw std::invalid_argument("view " + v.name + ": board points, left and right corners differ in number");
    all.names.push_back(v.name);
    all.object.emplace_back(v.object.begin(), v.object.end());
    all.left.emplace_back(v.left.begin(), v.left.end());
    all.right.emplace_back(v.right.begin(), v.right.end());
  }
  if (all.size() < 3)
    throw std::runtime_error("the board was found in both images of only " + std::to_string(all.size()) +
                             " pairs; at least 3 are needed");

  // Outlier views: judged on a radial-tangential fit of all views (the model needs no initial guess), each
  // camera's per-view RMS against the median.
  Detections used = all;
  {
    const Fit f = fitModel(LensModel::kRadialTangential, all, result.image_size);
    std::vector<double> rms(all.size());
    for (size_t i = 0; i < all.size(); ++i)
      rms[i] = std::max(viewRms(f, all.object[i], all.left[i], false), viewRms(f, all.object[i], all.right[i], true));
    std::vector<double> sorted = rms;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double limit = std::max(options.outlier_rms_floor_px, options.outlier_rms_factor * sorted[sorted.size() / 2]);
    std::vector<size_t> keep;
    for (size_t i = 0; i < all.size(); ++i) {
      if (rms[i] > limit) {
        char buf[160];
        std::snprintf(buf, sizeof buf, "outlier view: RMS %.3f px above %.3f px (%.1f x the median view)", rms[i],
                      limit, options.outlier_rms_factor);
        result.rejected.push_back({all.names[i], buf});
      } else {
        keep.push_back(i);
      }
    }
    used = all.subset(keep);
    if (used.size() < 3) throw std::runtime_error("fewer than 3 views left after removing outlier views");
  }

  Fit best_fit;
  bool have = false;
  if (options.lens_models.empty()) throw std::invalid_argument("no lens model to fit");
  for (LensModel model : options.lens_models) {
    Fit fit;
    const ModelFigures m = scoreModel(model, used, result.image_size, fit);
    result.candidates.push_back(m);
    if (m.ok && (!have || m.heldout_epipolar_px < result.figures.heldout_epipolar_px)) {
      result.figures = m;
      result.model = model;
      best_fit = fit;
      have = true;
    }
  }
  if (!have) throw std::runtime_error("no lens model could be fitted: " + result.candidates.front().failure);

  for (size_t i = 0; i < used.size(); ++i) {
    ViewFigures v;
    v.name = used.names[i];
    v.rms_left_px = viewRms(best_fit, used.object[i], used.left[i], false);
    v.rms_right_px = viewRms(best_fit, used.object[i], used.right[i], true);
    const auto e = epipolarSum(best_fit, used.left[i], used.right[i]);
    v.epipolar_px = e.first / e.second;
    v.corners = used.object[i].size();
    result.views.push_back(v);
  }
  result.calib.cam0 = toIntrinsics(best_fit.K1, best_fit.D1, result.model, result.image_size);
  result.calib.cam1 = toIntrinsics(best_fit.K2, best_fit.D2, result.model, result.image_size);
  cv::cv2eigen(best_fit.R, result.calib.R_cam1_cam0);
  cv::Mat t = best_fit.T.reshape(1, 3);
  result.calib.t_cam1_cam0 = Eigen::Vector3d(t.at<double>(0), t.at<double>(1), t.at<double>(2));
  result.calib.source = "estimated";
  return result;
}

namespace {

// FileStorage escapes a single quote inside a double-quoted scalar as \', which YAML does not know (the project's
// reader refuses the file); OpenCV's exception texts quote function names that way.
std::string yamlQuotable(std::string text) {
  std::replace(text.begin(), text.end(), '\'', '"');
  while (!text.empty() && text.back() == '\n') text.pop_back();
  return text;
}

}  // namespace

void saveStereoCalibration(const std::string& path, const StereoCalibrationResult& result,
                           const std::string& previous) {
  // The figures go into the calibration's own YAML document (FileStorage::APPEND would start a second one).
  saveCalibration(path, result.calib, [&](cv::FileStorage& fs) {
    if (!previous.empty()) copyFigureBlocks(fs, previous, "calibration_figures");
    fs << "calibration_figures"
       << "{";
    fs << "date" << utcNow() << "lens_model" << lensModelName(result.model);
    fs << "rms_px" << result.figures.rms_px << "epipolar_px" << result.figures.epipolar_px;
    fs << "heldout_epipolar_px" << result.figures.heldout_epipolar_px;
    fs << "rectified_row_px" << result.figures.rectified_row_px;
    fs << "heldout_rectified_row_px" << result.figures.heldout_rectified_row_px;
    fs << "candidates"
       << "[";
    for (const auto& c : result.candidates) {
      fs << "{"
         << "lens_model" << lensModelName(c.model) << "fitted" << static_cast<int>(c.ok);
      if (c.ok)
        fs << "rms_px" << c.rms_px << "epipolar_px" << c.epipolar_px << "heldout_epipolar_px" << c.heldout_epipolar_px;
      else
        fs << "failure" << yamlQuotable(c.failure);
      fs << "}";
    }
    fs << "]"
       << "views"
       << "[";
    for (const auto& v : result.views)
      fs << "{"
         << "name" << v.name << "rms_left_px" << v.rms_left_px << "rms_right_px" << v.rms_right_px << "epipolar_px"
         << v.epipolar_px << "corners" << static_cast<int>(v.corners) << "}";
    fs << "]"
       << "rejected"
       << "[";
    for (const auto& r : result.rejected)
      fs << "{"
         << "name" << r.name << "reason" << r.reason << "}";
    fs << "]"
       << "}";
  });
}

cv::Mat drawRectifiedCheck(const StereoCalibration& calib, const cv::Mat& left, const cv::Mat& right,
                           int line_spacing_px) {
  const StereoRectification rect = computeRectification(calib, 0.0);
  cv::Mat r0, r1, side;
  rectifyPair(rect, left, right, r0, r1);
  cv::hconcat(r0, r1, side);
  if (side.channels() == 1) cv::cvtColor(side, side, cv::COLOR_GRAY2BGR);
  for (int y = line_spacing_px / 2; y < side.rows; y += line_spacing_px)
    cv::line(side, cv::Point(0, y), cv::Point(side.cols - 1, y), cv::Scalar(0, 255, 0), 1);
  return side;
}

}  // namespace ips::calib
