#include "ips/calibration.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "ips/config.hpp"

namespace ips {

cv::Mat CameraIntrinsics::cvK() const {
  cv::Mat k;
  cv::eigen2cv(K, k);
  return k;
}

cv::Mat CameraIntrinsics::cvDistortion() const {
  cv::Mat d;
  cv::eigen2cv(distortion, d);
  d = d.reshape(1, 1);
  return model == DistortionModel::kEquidistant ? d.colRange(0, 4).clone() : d;
}

static const char* distortionModelName(DistortionModel m) {
  return m == DistortionModel::kEquidistant ? "equidistant" : "radtan";
}

namespace {

// A CV_32FC1 map at (x, y), bilinear in double, the position clamped into the map (at least 2x2).
float bilinearClamped(const cv::Mat& map, double x, double y) {
  x = std::clamp(x, 0.0, double(map.cols - 1));
  y = std::clamp(y, 0.0, double(map.rows - 1));
  const int x0 = std::min(static_cast<int>(x), map.cols - 2), y0 = std::min(static_cast<int>(y), map.rows - 2);
  const double a = x - x0, b = y - y0;
  const float* r0 = map.ptr<float>(y0);
  const float* r1 = map.ptr<float>(y0 + 1);
  return static_cast<float>((1 - b) * ((1 - a) * r0[x0] + a * r0[x0 + 1]) + b * ((1 - a) * r1[x0] + a * r1[x0 + 1]));
}

CameraIntrinsics loadCamera(const Config& cfg, const std::string& name) {
  CameraIntrinsics cam;
  cam.width = cfg.getInt(name + "/width");
  cam.height = cfg.getInt(name + "/height");
  if (cam.width <= 0 || cam.height <= 0)
    throw ConfigError(cfg.path() + ": key '" + name + "/width|height' must be positive");
  cam.K = cfg.getMatrix(name + "/K", 3, 3);
  const std::string model = cfg.getString(name + "/distortion_model", "radtan");
  if (model == "equidistant") {
    cam.model = DistortionModel::kEquidistant;
    cam.distortion.head<4>() = cfg.getMatrix(name + "/distortion", 1, 4).transpose();
  } else if (model == "radtan") {
    cam.distortion = cfg.getMatrix(name + "/distortion", 1, 5).transpose();
  } else {
    throw ConfigError(cfg.path() + ": key '" + name + "/distortion_model' is '" + model +
                      "', need radtan or equidistant");
  }
  cam.serial = cfg.getString(name + "/serial", "");
  if (cam.K(0, 0) <= 0 || cam.K(1, 1) <= 0)
    throw ConfigError(cfg.path() + ": key '" + name + "/K' has no positive focal length");
  return cam;
}

void writeCamera(cv::FileStorage& fs, const std::string& name, const CameraIntrinsics& cam) {
  fs << name << "{";
  fs << "width" << cam.width << "height" << cam.height;
  fs << "K" << cam.cvK();
  // Radial-tangential files stay as they were (no model key), so older readers still read them.
  if (cam.model != DistortionModel::kRadialTangential) fs << "distortion_model" << distortionModelName(cam.model);
  fs << "distortion" << cam.cvDistortion();
  fs << "serial" << cam.serial;
  fs << "}";
}

cv::Mat toCv(const Eigen::MatrixXd& m) {
  cv::Mat out;
  cv::eigen2cv(m, out);
  return out;
}

Eigen::Matrix3d orthonormalize(const Eigen::Matrix3d& r) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(r, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d out = svd.matrixU() * svd.matrixV().transpose();
  if (out.determinant() < 0) out = -out;
  return out;
}

}  // namespace

StereoCalibration loadCalibration(const std::string& path) {
  Config cfg(path);
  StereoCalibration c;
  c.cam0 = loadCamera(cfg, "cam0");
  c.cam1 = loadCamera(cfg, "cam1");
  Eigen::Matrix3d r = cfg.getMatrix("R_cam1_cam0", 3, 3);
  if ((r * r.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-4)
    throw ConfigError(path + ": key 'R_cam1_cam0' is not a rotation matrix");
  c.R_cam1_cam0 = orthonormalize(r);
  c.t_cam1_cam0 = cfg.getMatrix("t_cam1_cam0", 3, 1);
  if (c.t_cam1_cam0.norm() <= 0) throw ConfigError(path + ": key 't_cam1_cam0' must not be zero");
  if (cfg.has("T_imu_cam0")) {
    Eigen::Matrix4d t = cfg.getMatrix("T_imu_cam0", 4, 4);
    c.T_imu_cam0.linear() = orthonormalize(t.topLeftCorner<3, 3>());
    c.T_imu_cam0.translation() = t.topRightCorner<3, 1>();
  }
  if (cfg.has("R_tilt_cam0")) c.R_tilt_cam0 = orthonormalize(cfg.getMatrix("R_tilt_cam0", 3, 3));
  if (cfg.has("source")) c.source = cfg.getString("source");
  return c;
}

void saveCalibration(const std::string& path, const StereoCalibration& c,
                     const std::function<void(cv::FileStorage&)>& write_more) {
  cv::FileStorage fs(path, cv::FileStorage::WRITE | cv::FileStorage::FORMAT_YAML);
  if (!fs.isOpened()) throw ConfigError(path + ": cannot write calibration");
  fs.writeComment(
      "Stereo head calibration (ips). Camera frames: x right, y down, z forward. T_a_b maps points from b to a.\n"
      "distortion: OpenCV radial-tangential k1 k2 p1 p2 k3, or with distortion_model: equidistant the fisheye\n"
      "k1 k2 k3 k4. Lengths in metres.");
  writeCamera(fs, "cam0", c.cam0);
  writeCamera(fs, "cam1", c.cam1);
  fs << "R_cam1_cam0" << toCv(c.R_cam1_cam0);
  fs << "t_cam1_cam0" << toCv(c.t_cam1_cam0);
  fs << "T_imu_cam0" << toCv(c.T_imu_cam0.matrix());
  fs << "R_tilt_cam0" << toCv(c.R_tilt_cam0);
  if (!c.source.empty()) fs << "source" << c.source;
  if (write_more) write_more(fs);
}

StereoRectification computeRectification(const StereoCalibration& c, double alpha,
                                         const RightCameraCorrection& right_correction) {
  StereoRectification out;
  out.size = cv::Size(c.cam0.width, c.cam0.height);
  cv::Mat R1, R2, P1, P2, Q;
  if (c.cam0.model != c.cam1.model)
    throw std::invalid_argument("computeRectification: both cameras need the same distortion model");
  const bool fisheye = c.cam0.model == DistortionModel::kEquidistant;
  if (fisheye) {
    // cv::fisheye's balance plays the part of alpha (0: only valid pixels, 1: all source pixels).
    cv::fisheye::stereoRectify(c.cam0.cvK(), c.cam0.cvDistortion(), c.cam1.cvK(), c.cam1.cvDistortion(), out.size,
                               toCv(c.R_cam1_cam0), toCv(c.t_cam1_cam0), R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY,
                               out.size, alpha);
  } else {
    cv::stereoRectify(c.cam0.cvK(), c.cam0.cvDistortion(), c.cam1.cvK(), c.cam1.cvDistortion(), out.size,
                      toCv(c.R_cam1_cam0), toCv(c.t_cam1_cam0), R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY, alpha,
                      out.size);
  }
  out.f = P1.at<double>(0, 0);
  out.cx = P1.at<double>(0, 2);
  out.cy = P1.at<double>(1, 2);
  out.baseline = -P2.at<double>(0, 3) / P2.at<double>(0, 0);
  cv::cv2eigen(R1, out.R_rect0_cam0);
  cv::cv2eigen(R2, out.R_rect1_cam1);
  CameraIntrinsics cam1 = c.cam1;
  if (!right_correction.isZero()) {
    const Eigen::Vector3d w(right_correction.rotation.x(), 0.0, right_correction.rotation.z());
    if (w.norm() > 0)
      out.R_rect1_cam1 = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix() * out.R_rect1_cam1;
    R2 = toCv(out.R_rect1_cam1);
    cam1.K(0, 0) *= 1 + right_correction.focal_scale;
    cam1.K(1, 1) *= 1 + right_correction.focal_scale;
  }
  auto maps = [&](const CameraIntrinsics& cam, const cv::Mat& R, const cv::Mat& P, cv::Mat& mx, cv::Mat& my) {
    if (fisheye)
      cv::fisheye::initUndistortRectifyMap(cam.cvK(), cam.cvDistortion(), R, P, out.size, CV_32FC1, mx, my);
    else
      cv::initUndistortRectifyMap(cam.cvK(), cam.cvDistortion(), R, P, out.size, CV_32FC1, mx, my);
  };
  maps(c.cam0, R1, P1, out.map0x, out.map0y);
  maps(cam1, R2, P2, out.map1x, out.map1y);
  const double yaw = right_correction.rotation.y(), offset = right_correction.disparity_offset_px;
  if (yaw != 0 || offset != 0) {
    // The yaw's keystone in rows only and the disparity offset (RightCameraCorrection): right pixel (x, y) samples
    // where (x + offset, y - f u v wy) did, u and v at (x + offset, y); bilinear in double (cv::remap would quantise
    // the position to 1/32 px).
    cv::Mat moved_x(out.size, CV_32FC1), moved_y(out.size, CV_32FC1);
    for (int y = 0; y < out.size.height; ++y)
      for (int x = 0; x < out.size.width; ++x) {
        const double at_x = x + offset;
        const double u = (at_x - out.cx) / out.f, v = (y - out.cy) / out.f;
        const double at_y = y - out.f * u * v * yaw;
        moved_x.at<float>(y, x) = bilinearClamped(out.map1x, at_x, at_y);
        moved_y.at<float>(y, x) = bilinearClamped(out.map1y, at_x, at_y);
      }
    out.map1x = moved_x;
    out.map1y = moved_y;
  }
  return out;
}

StereoRectification scaledRectification(const StereoCalibration& calib, double scale,
                                        const RightCameraCorrection& right_correction) {
  if (!(scale > 0 && scale <= 1)) throw std::invalid_argument("scaledRectification: scale must be in (0, 1]");
  StereoRectification rect = computeRectification(calib, 0.0, right_correction);
  if (scale == 1.0) return rect;
  const cv::Size size(static_cast<int>(std::lround(rect.size.width * scale)),
                      static_cast<int>(std::lround(rect.size.height * scale)));
  // Rectified pixel (u', v') at the reduced scale is (u' + 0.5) / s - 0.5 at full scale.
  cv::Mat fx(size, CV_32FC1), fy(size, CV_32FC1);
  for (int v = 0; v < size.height; ++v)
    for (int u = 0; u < size.width; ++u) {
      fx.at<float>(v, u) = static_cast<float>((u + 0.5) / scale - 0.5);
      fy.at<float>(v, u) = static_cast<float>((v + 0.5) / scale - 0.5);
    }
  for (cv::Mat* map : {&rect.map0x, &rect.map0y, &rect.map1x, &rect.map1y}) {
    cv::Mat scaled;
    cv::remap(*map, scaled, fx, fy, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    *map = scaled;
  }
  rect.f *= scale;
  rect.cx = (rect.cx + 0.5) * scale - 0.5;
  rect.cy = (rect.cy + 0.5) * scale - 0.5;
  rect.size = size;
  return rect;
}

void rectifyPair(const StereoRectification& rect, const cv::Mat& raw0, const cv::Mat& raw1, cv::Mat& out0,
                 cv::Mat& out1) {
  cv::remap(raw0, out0, rect.map0x, rect.map0y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::remap(raw1, out1, rect.map1x, rect.map1y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
}

bool RightCorrectionSchedule::add(int64_t decided_utime, const RightCameraCorrection& correction) {
  if (!entries_.empty() && decided_utime <= entries_.back().first) return false;
  entries_.emplace_back(decided_utime, correction);
  return true;
}

RightCameraCorrection RightCorrectionSchedule::forPair(int64_t utime) const {
  RightCameraCorrection c;
  for (const auto& [decided, correction] : entries_)
    if (decided < utime) c = correction;
  return c;
}

void RightCorrectionSchedule::dropBefore(int64_t utime) {
  size_t keep_from = 0;
  for (size_t i = 0; i < entries_.size(); ++i)
    if (entries_[i].first < utime) keep_from = i;
  entries_.erase(entries_.begin(), entries_.begin() + static_cast<std::ptrdiff_t>(keep_from));
}

}  // namespace ips
