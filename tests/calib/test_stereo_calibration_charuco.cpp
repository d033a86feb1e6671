// Stereo calibration from ChArUco boards against an analytic truth: OpenCV's drawing of the board (CharucoBoard::draw)
// rendered through a known stereo camera with strong radial-tangential distortion from many poses, some with the
// board partly outside the images (the views ChArUco is for), detected and calibrated by the library; calibrate_stereo
// on such pairs as image files and as an LCM log; its refusal of bad board options; the still-view picker's matching
// of corners by id.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <ips/stereo_pair_t.hpp>
#include <lcm/lcm-cpp.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <unordered_map>

#include "ips/calib/charuco.hpp"
#include "ips/calib/stereo_calibration.hpp"
#include "ips/calibration.hpp"
#include "ips/test_support/command_output.hpp"

namespace {

using ips::calib::CharucoDetection;
using ips::calib::CharucoSpec;
using ips::calib::StereoImagePair;
using ips::test_support::commandOutput;

// A 10x8 board of 5 cm squares, 3.5 cm markers (OpenCV's tutorial proportion is 0.5-0.6; 0.7 leaves the 6x6-bit
// markers more pixels at a distance), the default dictionary.
CharucoSpec testBoard() { return CharucoSpec{{10, 8}, 0.05, 0.03}; }

// The sheet the cameras see: OpenCV's drawing at kSheetPx per square with a white margin of half a square.
constexpr int kSheetPx = 160, kSheetMargin = 80;

struct Camera {
  cv::Matx33d K;
  cv::Vec<double, 5> D;
};

// Renders the plane board through a camera with distortion: for every sample point of the image (kSuper x kSuper per
// pixel), the ray through it (undistorted iteratively and checked by projecting it back), then per pose the point
// of the board the ray meets, looked up in the sheet; the samples averaged to pixels. Outside the sheet: grey.
class BoardRenderer {
 public:
  static constexpr int kSuper = 4;

  BoardRenderer(const Camera& cam, cv::Size size, const cv::Mat& sheet) : size_(size) {
    // The print slightly soft (Gaussian, 3 sheet pixels: 0.2-1 image pixels), as a lens renders it; the samples are
    // then closer than the blur, so that the pixels' values follow an edge's position smoothly instead of in steps of
    // one sample.
    cv::GaussianBlur(sheet, sheet_, cv::Size(0, 0), 3.0);
    const cv::Size big(size.width * kSuper, size.height * kSuper);
    std::vector<cv::Point2d> pixels, rays;
    pixels.reserve(big.area());
    for (int y = 0; y < big.height; ++y)
      for (int x = 0; x < big.width; ++x)
        pixels.emplace_back((x + 0.5) / kSuper - 0.5, (y + 0.5) / kSuper - 0.5);  // pixel centres at whole numbers
    cv::undistortPoints(pixels, rays, cam.K, cam.D, cv::noArray(), cv::noArray(),
                        cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-14));
    std::vector<cv::Point3d> rays3;
    rays3.reserve(rays.size());
    for (const auto& r : rays) rays3.emplace_back(r.x, r.y, 1.0);
    std::vector<cv::Point2d> back;
    cv::projectPoints(rays3, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cam.K, cam.D, back);
    rays_.create(big, CV_64FC2);
    for (int i = 0; i < big.area(); ++i) {
      const bool ok = cv::norm(back[i] - pixels[i]) < 1e-4;  // where the iteration did not converge: no ray
      rays_.at<cv::Vec2d>(i / big.width, i % big.width) = ok ? cv::Vec2d(rays[i].x, rays[i].y) : cv::Vec2d(NAN, NAN);
    }
  }

  // The board with its coordinates (metres, z = 0) in the camera frame: X_cam = R X_board + t.
  cv::Mat render(const cv::Matx33d& R, const cv::Vec3d& t, double square_m) const {
    // Camera point of board (X, Y, 0) is H (X, Y, 1), H = [r1 r2 t]; a ray (x, y, 1) meets the board at H^-1 (x, y, 1).
    const cv::Matx33d H(R(0, 0), R(0, 1), t[0], R(1, 0), R(1, 1), t[1], R(2, 0), R(2, 1), t[2]);
    const cv::Matx33d Hi = H.inv();
    cv::Mat map_x(rays_.size(), CV_32FC1), map_y(rays_.size(), CV_32FC1);
    const double scale = kSheetPx / square_m;
    for (int y = 0; y < rays_.rows; ++y) {
      for (int x = 0; x < rays_.cols; ++x) {
        const cv::Vec2d r = rays_.at<cv::Vec2d>(y, x);
        const cv::Vec3d b = Hi * cv::Vec3d(r[0], r[1], 1.0);
        float mx = -1e6f, my = -1e6f;
        if (std::isfinite(r[0]) && b[2] > 0) {  // in front of the camera
          mx = static_cast<float>(kSheetMargin - 0.5 + b[0] / b[2] * scale);
          my = static_cast<float>(kSheetMargin - 0.5 + b[1] / b[2] * scale);
        }
        map_x.at<float>(y, x) = mx;
        map_y.at<float>(y, x) = my;
      }
    }
    cv::Mat big, image;
    cv::remap(sheet_, big, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(110));
    cv::resize(big, image, size_, 0, 0, cv::INTER_AREA);
    return image;
  }

 private:
  cv::Size size_;
  cv::Mat sheet_, rays_;
};

// The known stereo camera of test_stereo_calibration's RecoversAKnownStereoCamera: 640x480, strong barrel distortion
// (k1 -0.28) with tangential terms, a 12 cm baseline and a small relative rotation.
const cv::Size kSize(640, 480);
const Camera kCam0{cv::Matx33d(500, 0, 322, 0, 501, 238, 0, 0, 1),
                   cv::Vec<double, 5>(-0.28, 0.09, 0.0005, -0.0003, -0.012)};
const Camera kCam1{cv::Matx33d(505, 0, 316, 0, 504, 243, 0, 0, 1),
                   cv::Vec<double, 5>(-0.27, 0.085, -0.0004, 0.0002, -0.01)};
const cv::Vec3d kRvecStereo(0.004, -0.006, 0.003), kTStereo(-0.12, 0.001, -0.002);

struct Pose {
  cv::Matx33d R;  // board to left camera
  cv::Vec3d t;
};

// Board corners (id order) projected into one camera; NaN where behind the camera.
std::vector<cv::Point2d> project(const Camera& cam, const Pose& p, const std::vector<cv::Point3d>& object) {
  cv::Vec3d rvec;
  cv::Rodrigues(p.R, rvec);
  std::vector<cv::Point2d> out;
  cv::projectPoints(object, rvec, p.t, cam.K, cam.D, out);
  return out;
}

Pose rightPose(const Pose& left) {
  cv::Matx33d Rs;
  cv::Rodrigues(kRvecStereo, Rs);
  return {Rs * left.R, Rs * left.t + kTStereo};
}

size_t insideBoth(const Pose& p, const std::vector<cv::Point3d>& object, int margin) {
  const auto l = project(kCam0, p, object), r = project(kCam1, rightPose(p), object);
  auto in = [&](const cv::Point2d& q) {
    return q.x >= margin && q.y >= margin && q.x <= kSize.width - 1 - margin && q.y <= kSize.height - 1 - margin;
  };
  size_t n = 0;
  for (size_t i = 0; i < object.size(); ++i) n += in(l[i]) && in(r[i]);
  return n;
}

// Poses in front of the left camera 0.45-0.9 m away, tilted up to about 30 deg about each board axis: `full` ones
// show every corner to both cameras, the others put the board's centre near an image corner or edge, so that 25-80 %
// of its corners are in both images (the distortion is largest there, and a chessboard would not be found).
std::vector<Pose> drawPoses(const CharucoSpec& board, size_t full, size_t partial, unsigned seed) {
  const auto object = ips::calib::charucoCornerPositions(board);
  const cv::Vec3d centre_on_board(board.squares.width * board.square_m / 2, board.squares.height * board.square_m / 2,
                                  0);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> angle(-0.5, 0.5), shift(-0.18, 0.18), depth(0.45, 0.9), unit(0, 1);
  std::vector<Pose> poses;
  size_t n_full = 0, n_partial = 0;
  while (n_full < full || n_partial < partial) {
    const bool want_full = n_full < full;
    cv::Matx33d R;
    // One draw per statement (the order of a constructor's arguments is unspecified): z, y, x.
    const double rz = angle(rng) * 0.5, ry = angle(rng), rx = angle(rng);
    cv::Rodrigues(cv::Vec3d(rx, ry, rz), R);
    const double z = depth(rng);
    const double cy = shift(rng) * 0.75, cx = shift(rng);
    cv::Vec3d centre(cx, cy, z);
    if (!want_full) {  // towards an image corner or edge: the board's centre near the image border
      const double u = unit(rng) < 0.5 ? unit(rng) * 0.15 : 0.85 + unit(rng) * 0.15;
      const double v = unit(rng);
      const bool swap = unit(rng) < 0.5;
      const double px = (swap ? v : u) * kSize.width, py = (swap ? u : v) * kSize.height;
      centre = cv::Vec3d((px - 322) / 500 * z, (py - 238) / 501 * z, z);
    }
    const Pose p{R, centre - R * centre_on_board};
    const size_t seen = insideBoth(p, object, 8);
    // Squares at least 24 px wide, so that the markers' 8 cells get 2 px or more.
    const double square_px = 500 * board.square_m / z * std::abs(R(2, 2));
    if (square_px < 24) continue;
    if (want_full && seen == object.size()) {
      poses.push_back(p);
      ++n_full;
    } else if (!want_full && seen >= object.size() / 4 && seen <= object.size() * 4 / 5) {
      poses.push_back(p);
      ++n_partial;
    }
  }
  return poses;
}

// Detected corners against the truth (the corners projected), by id: RMS and largest error.
std::pair<double, double> detectionError(const CharucoDetection& d, const std::vector<cv::Point2d>& truth) {
  double ss = 0, worst = 0;
  for (size_t i = 0; i < d.ids.size(); ++i) {
    const double e = cv::norm(cv::Point2d(d.corners[i]) - truth[d.ids[i]]);
    ss += e * e;
    worst = std::max(worst, e);
  }
  return {std::sqrt(ss / std::max<size_t>(1, d.ids.size())), worst};
}

TEST(StereoCalibrationCharuco, SheetCornersLieWhereTheBoardPutsThem) {
  if (!ips::calib::charucoAvailable()) GTEST_SKIP() << "built without OpenCV's aruco module";
  const CharucoSpec board = testBoard();
  const cv::Mat sheet = ips::calib::drawCharucoSheet(board, 40, 20);
  ASSERT_EQ(sheet.cols, 10 * 40 + 40);
  ASSERT_EQ(sheet.rows, 8 * 40 + 40);
  CharucoDetection d;
  ASSERT_TRUE(ips::calib::detectCharuco(sheet, board, d));
  EXPECT_EQ(d.ids.size(), static_cast<size_t>(ips::calib::charucoCornerCount(board)));
  EXPECT_TRUE(std::is_sorted(d.ids.begin(), d.ids.end()));
  const auto object = ips::calib::charucoCornerPositions(board);
  std::vector<cv::Point2d> truth;
  for (const auto& o : object) truth.emplace_back(20 - 0.5 + o.x / 0.05 * 40, 20 - 0.5 + o.y / 0.05 * 40);
  const auto [rms, worst] = detectionError(d, truth);
  EXPECT_LT(worst, 0.05) << "rms " << rms;
}

// Both cameras' renderers, built once (the rays of 2 x 4.9 million samples).
const std::pair<BoardRenderer, BoardRenderer>& renderers() {
  static const cv::Mat sheet = ips::calib::drawCharucoSheet(testBoard(), kSheetPx, kSheetMargin);
  static const std::pair<BoardRenderer, BoardRenderer> r{BoardRenderer(kCam0, kSize, sheet),
                                                         BoardRenderer(kCam1, kSize, sheet)};
  return r;
}

std::vector<StereoImagePair> renderPairs(const std::vector<Pose>& poses) {
  std::vector<StereoImagePair> pairs;
  for (size_t i = 0; i < poses.size(); ++i) {
    const Pose right = rightPose(poses[i]);
    pairs.push_back({"pose" + std::to_string(i), renderers().first.render(poses[i].R, poses[i].t, testBoard().square_m),
                     renderers().second.render(right.R, right.t, testBoard().square_m)});
  }
  return pairs;
}

// The worst focal length (relative) and principal point (px) of both cameras against the truth.
std::pair<double, double> intrinsicsError(const ips::StereoCalibration& c) {
  double worst_focal = 0, worst_principal = 0;
  for (const auto& [est, truth] : {std::pair{&c.cam0, &kCam0}, std::pair{&c.cam1, &kCam1}}) {
    for (int axis = 0; axis < 2; ++axis) {
      worst_focal = std::max(worst_focal, std::abs(est->K(axis, axis) / truth->K(axis, axis) - 1));
      worst_principal = std::max(worst_principal, std::abs(est->K(axis, 2) - truth->K(axis, 2)));
    }
  }
  return {worst_focal, worst_principal};
}

TEST(StereoCalibrationCharuco, RecoversAKnownStereoCameraFromPartialViews) {
  if (!ips::calib::charucoAvailable()) GTEST_SKIP() << "built without OpenCV's aruco module";
  const CharucoSpec board = testBoard();
  const auto object = ips::calib::charucoCornerPositions(board);
  const std::vector<Pose> poses = drawPoses(board, 12, 12, 15);
  const std::vector<StereoImagePair> pairs = renderPairs(poses);
  double ss = 0, worst = 0;
  size_t n = 0;
  for (size_t i = 0; i < poses.size(); ++i) {
    const Pose right = rightPose(poses[i]);
    // The detector against the truth, both images.
    for (const auto& [image, cam, pose] :
         {std::tuple{&pairs[i].left, &kCam0, &poses[i]}, std::tuple{&pairs[i].right, &kCam1, &right}}) {
      CharucoDetection d;
      ips::calib::detectCharuco(*image, board, d);
      const auto [rms, w] = detectionError(d, project(*cam, *pose, object));
      ss += rms * rms * d.ids.size();
      n += d.ids.size();
      worst = std::max(worst, w);
    }
  }
  const double detection_rms = std::sqrt(ss / n);
  std::printf("[ CHARUCO  ] %zu corners detected in %zu images: %.4f px RMS, %.4f px at most from the truth\n", n,
              2 * pairs.size(), detection_rms, worst);
  EXPECT_LT(detection_rms, 0.05);
  EXPECT_LT(worst, 0.3);

  ips::calib::CalibrationOptions options;
  options.lens_models = {ips::calib::LensModel::kRadialTangential};  // the truth's (the choice is tested elsewhere)
  const auto result = ips::calib::calibrateStereoCharuco(pairs, board, options);
  for (const auto& r : result.rejected) std::printf("[ CHARUCO  ] rejected %s: %s\n", r.name.c_str(), r.reason.c_str());
  size_t partial = 0;
  for (const auto& v : result.views) partial += v.corners < object.size();
  EXPECT_GE(result.views.size(), 20u);
  EXPECT_GE(partial, 8u) << "views with part of the board";

  const auto& c = result.calib;
  const auto [worst_focal, worst_principal] = intrinsicsError(c);
  cv::Matx33d Rs;
  cv::Rodrigues(kRvecStereo, Rs);
  Eigen::Matrix3d R_true;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) R_true(i, j) = Rs(i, j);
  const double rotation_deg = Eigen::AngleAxisd(c.R_cam1_cam0 * R_true.transpose()).angle() * 180 / M_PI;
  const double baseline_rel = c.baseline() / cv::norm(kTStereo) - 1;
  std::printf(
      "[ CHARUCO  ] %zu views (%zu partial), %zu rejected: rms %.4f px, epipolar %.4f px (held out %.4f); focal length "
      "%.4f %%, principal point %.3f px, relative rotation %.4f deg, baseline %.4f %% (worst of both cameras)\n",
      result.views.size(), partial, result.rejected.size(), result.figures.rms_px, result.figures.epipolar_px,
      result.figures.heldout_epipolar_px, 100 * worst_focal, worst_principal, rotation_deg, 100 * baseline_rel);
  EXPECT_LT(worst_focal, 1e-3);
  EXPECT_LT(worst_principal, 0.5);
  EXPECT_LT(rotation_deg, 0.05);
  EXPECT_LT(std::abs(baseline_rel), 1e-3);

  // The file as for a chessboard, each view with its number of corners; a model that could not be fitted (here one
  // made up, with OpenCV's message quoting a function name) keeps the file readable.
  auto with_failure = result;
  ips::calib::ModelFigures failed;
  failed.model = ips::calib::LensModel::kFisheye;
  failed.failure = "OpenCV(4.6.0) fisheye.cpp:1062: error: (-215:Assertion failed) in function 'stereoCalibrate'\n";
  with_failure.candidates.push_back(failed);
  const std::string file = testing::TempDir() + "charuco.calib.yaml";
  ips::calib::saveStereoCalibration(file, with_failure);
  EXPECT_EQ(ips::loadCalibration(file).source, "estimated");
  cv::FileStorage fs(file, cv::FileStorage::READ);
  const cv::FileNode views = fs["calibration_figures"]["views"];
  ASSERT_EQ(views.size(), result.views.size());
  EXPECT_EQ(static_cast<int>(views[0]["corners"]), static_cast<int>(result.views[0].corners));
  EXPECT_NE(static_cast<std::string>(fs["calibration_figures"]["candidates"][1]["failure"]).find("stereoCalibrate"),
            std::string::npos);
  std::remove(file.c_str());
}

// The tool on the same kind of pairs, fewer of them (4 with part of the board), once as image files matched by globs
// and once as the head's LCM log with each pose held for three images: the still-view picker must take each pose once,
// matching the corners by id. Ten views fix the camera less well than the library test's 24: the tolerance here is
// the tool's plumbing, not the method's accuracy.
class CharucoTool : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!ips::calib::charucoAvailable()) return;
    pairs_ = renderPairs(drawPoses(testBoard(), 6, 4, 7));
  }
  static inline std::vector<StereoImagePair> pairs_;

  static std::string boardOptions() {
    return " --charuco 10x8 --square 0.05 --marker 0.03 --lens-model radial-tangential";
  }

  // Runs the tool; checks its exit status, last line and file against the truth; returns what it printed.
  static std::string runAndCheck(const std::string& inputs, const std::string& out) {
    const std::string printed = commandOutput(std::string(CALIBRATE_STEREO) + inputs + boardOptions() + " --out " +
                                              out + " 2>&1; echo exit=$?");
    EXPECT_NE(printed.find("exit=0"), std::string::npos) << printed;
    const size_t last = printed.rfind("rms_px=");
    EXPECT_NE(last, std::string::npos) << printed;
    if (last != std::string::npos) {
      double rms = 0, epi = 0, held = 0;
      EXPECT_EQ(std::sscanf(printed.c_str() + last, "rms_px=%lf epipolar_px=%lf heldout_epipolar_px=%lf\nexit=", &rms,
                            &epi, &held),
                3)
          << printed;
      EXPECT_LT(rms, 0.1) << printed;
    }
    size_t partial = 0, views = 0;
    const size_t at = printed.find("views with part of the board ");
    EXPECT_NE(at, std::string::npos) << printed;
    if (at != std::string::npos)
      std::sscanf(printed.c_str() + at, "views with part of the board %zu of %zu", &partial, &views);
    EXPECT_GE(partial, 4u) << printed;
    EXPECT_GE(views, 9u) << printed;
    std::printf("[ TOOL     ] %s",
                printed
                    .substr(printed.find("pairs in the log") == std::string::npos ? printed.find("view ")
                                                                                  : printed.find("pairs in the log"))
                    .c_str());
    const ips::StereoCalibration est = ips::loadCalibration(out);
    EXPECT_EQ(est.source, "estimated");
    const auto [focal, principal] = intrinsicsError(est);
    EXPECT_LT(focal, 2e-3) << printed;
    EXPECT_LT(principal, 1.0) << printed;
    return printed;
  }
};

TEST_F(CharucoTool, CalibratesFromImageFiles) {
  if (!ips::calib::charucoAvailable()) GTEST_SKIP() << "built without OpenCV's aruco module";
  const std::string dir = testing::TempDir() + "charuco_tool_files";
  std::filesystem::create_directories(dir);
  for (size_t i = 0; i < pairs_.size(); ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "%02zu.png", i);
    ASSERT_TRUE(cv::imwrite(dir + "/left" + name, pairs_[i].left));
    ASSERT_TRUE(cv::imwrite(dir + "/right" + name, pairs_[i].right));
  }
  const std::string printed =
      runAndCheck(" --left '" + dir + "/left*.png' --right '" + dir + "/right*.png' --check-png " + dir + "/check.png",
                  dir + "/calib.yaml");
  EXPECT_TRUE(std::filesystem::exists(dir + "/check.png")) << printed;
  std::filesystem::remove_all(dir);
}

TEST_F(CharucoTool, CalibratesFromALogTakingEachPoseOnce) {
  if (!ips::calib::charucoAvailable()) GTEST_SKIP() << "built without OpenCV's aruco module";
  const std::string log_path = testing::TempDir() + "charuco_tool.lcmlog",
                    out = testing::TempDir() + "charuco_log.yaml";
  {
    lcm::LogFile log(log_path, "w");
    int64_t seq = 0;
    for (const auto& p : pairs_) {
      for (int still = 0; still < 3; ++still, ++seq) {  // 4 Hz, the board held for three images
        ips::stereo_pair_t m{};
        m.utime = 1'000'000 + seq * 250'000;
        m.seq = seq;
        m.width = kSize.width;
        m.height = kSize.height;
        m.stride = kSize.width;
        m.pixel_format = ips::stereo_pair_t::PIXEL_MONO8;
        m.data_size = kSize.area();
        m.left.assign(p.left.data, p.left.data + kSize.area());
        m.right.assign(p.right.data, p.right.data + kSize.area());
        std::vector<uint8_t> bytes(static_cast<size_t>(m.getEncodedSize()));
        m.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
        lcm::LogEvent e;
        e.timestamp = m.utime;
        e.channel = "STEREO";
        e.datalen = static_cast<int32_t>(bytes.size());
        e.data = bytes.data();
        log.writeEvent(&e);
      }
    }
  }
  const std::string printed = runAndCheck(" --log " + log_path, out);
  // One view per pose: the second image of each (the first still one); taken or rejected, never twice.
  size_t taken = 0;
  const size_t at = printed.find("views taken (board still, one per pose) ");
  ASSERT_NE(at, std::string::npos) << printed;
  std::sscanf(printed.c_str() + at, "views taken (board still, one per pose) %zu", &taken);
  size_t rejected = 0;
  for (size_t pos = printed.find("rejected utime"); pos != std::string::npos;
       pos = printed.find("rejected utime", pos + 1))
    ++rejected;
  EXPECT_EQ(taken + rejected, pairs_.size()) << printed;
  std::remove(log_path.c_str());
  std::remove(out.c_str());
}

// Bad board options: one line naming the option on standard error, exit status 2, nothing written.
TEST(StereoCalibrationCharuco, ToolRefusesBadBoardOptions) {
  const std::string out = testing::TempDir() + "never_written.yaml";
  const std::string tool = std::string(CALIBRATE_STEREO) + " --log /nonexistent.lcmlog --out " + out;
  const std::pair<std::string, std::string> cases[] = {
      {" --board 9x6 --charuco 10x7 --square 0.04 --marker 0.03", "not both"},
      {" --square 0.04", "give --board WxH (a chessboard) or --charuco WxH"},
      {" --charuco 10x7 --square 0.04", "--charuco needs --marker"},
      {" --charuco 10x7 --square 0.04 --marker 0.05", "must be smaller than its square"},
      {" --charuco 10x7 --square 0.04 --marker 0.03 --dictionary DICT_9X9_1", "unknown ArUco dictionary 'DICT_9X9_1'"},
      {" --charuco 10 --square 0.04 --marker 0.03", "expected squares per row and column"},
      {" --board 9x6 --square 0.04 --marker 0.03", "--marker is for --charuco"},
  };
  for (const auto& [options, expected] : cases) {
    const std::string printed = commandOutput(tool + options + " 2>&1 >/dev/null; echo exit=$?");
    EXPECT_NE(printed.find("calibrate_stereo: "), std::string::npos) << options << ": " << printed;
    EXPECT_NE(printed.find(expected), std::string::npos) << options << ": " << printed;
    EXPECT_NE(printed.find("\nexit=2\n"), std::string::npos) << options << ": " << printed;
    EXPECT_EQ(std::count(printed.begin(), printed.end(), '\n'), 2) << "one line, then the status: " << printed;
  }
  EXPECT_FALSE(std::filesystem::exists(out));
}

// ChArUco corners come and go between images (a marker read in one image, not the next): the picker compares the
// corners present in both by id.
TEST(StereoCalibrationCharuco, StillViewPickerMatchesCornersById) {
  ips::calib::StillViewPicker picker(0.5, 20.0);
  const std::vector<cv::Point2f> a{{100, 100}, {130, 100}, {160, 100}};
  EXPECT_FALSE(picker.offer({4, 5, 6}, a));  // nothing before: not known to be still
  // Corner 4 lost, corner 7 found; 5 and 6 where they were: still, and the first view.
  EXPECT_TRUE(picker.offer({5, 6, 7}, {{130.1f, 100}, {160, 100.1f}, {190, 100}}));
  EXPECT_FALSE(picker.offer({5, 6, 7}, {{130.1f, 100}, {160, 100.1f}, {190, 100}}));  // still, but not moved
  // Moved 40 px: not still; then still there: taken.
  EXPECT_FALSE(picker.offer({5, 6, 7}, {{170, 100}, {200, 100}, {230, 100}}));
  EXPECT_TRUE(picker.offer({6, 7}, {{200, 100}, {230, 100}}));
  // No corner in common with the previous image: moved.
  EXPECT_FALSE(picker.offer({1, 2}, {{200, 100}, {230, 100}}));
  // The chessboard form: all corners, the index their id.
  ips::calib::StillViewPicker chess;
  EXPECT_FALSE(chess.offer(a));
  EXPECT_TRUE(chess.offer(a));
}

}  // namespace
