#include "ips/calibration.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "ips/config.hpp"
#include "ips/rotation.hpp"

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

namespace {

// tan^2 of the rays of the given pixels (CV_64FC2, N x 1), through the camera's distortion model.
std::vector<double> rayTan2(const CameraIntrinsics& cam, const cv::Mat& pixels) {
  cv::Mat normalised;
  if (cam.model == DistortionModel::kEquidistant)
    cv::fisheye::undistortPoints(pixels, normalised, cam.cvK(), cam.cvDistortion());
  else
    // 20 iterations: OpenCV's default 5 leave 0.05 px in the corners of a strongly distorted lens.
    cv::undistortPoints(pixels, normalised, cam.cvK(), cam.cvDistortion(), cv::noArray(), cv::noArray(),
                        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 1e-10));
  std::vector<double> tan2(normalised.total());
  for (size_t i = 0; i < tan2.size(); ++i) {
    const cv::Vec2d n = normalised.at<cv::Vec2d>(static_cast<int>(i));
    tan2[i] = n[0] * n[0] + n[1] * n[1];
  }
  return tan2;
}

}  // namespace

cv::Mat rayTan2Image(const CameraIntrinsics& cam) {
  const cv::Size size(cam.width, cam.height);
  cv::Mat pixels(static_cast<int>(size.area()), 1, CV_64FC2);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) pixels.at<cv::Vec2d>(y * size.width + x) = cv::Vec2d(x, y);
  const std::vector<double> tan2 = rayTan2(cam, pixels);
  cv::Mat out(size, CV_32FC1);
  for (size_t i = 0; i < tan2.size(); ++i) out.at<float>(static_cast<int>(i)) = static_cast<float>(tan2[i]);
  return out;
}

double widestRayTan2(const CameraIntrinsics& cam) {
  // The widest ray lies on the image's border (the angle grows outwards from the principal point).
  std::vector<cv::Vec2d> border;
  for (int x = 0; x < cam.width; ++x) border.insert(border.end(), {cv::Vec2d(x, 0), cv::Vec2d(x, cam.height - 1)});
  for (int y = 0; y < cam.height; ++y) border.insert(border.end(), {cv::Vec2d(0, y), cv::Vec2d(cam.width - 1, y)});
  const std::vector<double> tan2 = rayTan2(cam, cv::Mat(border, true));
  return *std::max_element(tan2.begin(), tan2.end());
}

double lowestFlatFieldGain(const CameraIntrinsics& cam, double widest_tan2) {
  double lowest = 1;  // G(0)
  for (int i = 1; i <= 100; ++i) lowest = std::min(lowest, cam.flatFieldGain(widest_tan2 * i / 100));
  return lowest;
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

cv::Mat toCv(const Eigen::MatrixXd& m) {
  cv::Mat out;
  cv::eigen2cv(m, out);
  return out;
}

CameraIntrinsics loadCamera(const Config& cfg, const std::string& name) {
  CameraIntrinsics cam;
  cam.width = cfg.getInt(name + "/width");
  cam.height = cfg.getInt(name + "/height");
  // 16384 px a side at most: a camera's, and what every process accepts (a corrupt file must not make one allocate
  // gigabytes of maps).
  if (cam.width <= 0 || cam.height <= 0 || cam.width > 16384 || cam.height > 16384)
    throw ConfigError(cfg.path() + ": key '" + name + "/width|height' must be in 1..16384, not " +
                      std::to_string(cam.width) + "x" + std::to_string(cam.height));
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
  if (cfg.has(name + "/vignetting_gain")) {
    cam.vignetting_gain = cfg.getMatrix(name + "/vignetting_gain", 1, 3).transpose();
    // The gain must stay positive over the field of view, else the flat field would turn greys negative.
    const double lowest = lowestFlatFieldGain(cam, widestRayTan2(cam));
    if (!cam.vignetting_gain.allFinite() || !(lowest > 0))
      throw ConfigError(cfg.path() + ": key '" + name + "/vignetting_gain' gives a gain of " + std::to_string(lowest) +
                        " in the image, need a positive one");
  }
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
  // Written only when there is one, so files without vignetting stay as they were.
  if (cam.hasVignetting()) fs << "vignetting_gain" << toCv(cam.vignetting_gain.transpose());
  fs << "}";
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
  if (cfg.has("imu")) {
    ImuDescription d;
    d.model = cfg.getString("imu/model", "");
    d.rate_hz = cfg.getDouble("imu/rate_hz");
    d.gyro_noise_density = cfg.getDouble("imu/gyro_noise_density");
    d.gyro_random_walk = cfg.getDouble("imu/gyro_random_walk");
    d.accel_noise_density = cfg.getDouble("imu/accel_noise_density");
    d.accel_random_walk = cfg.getDouble("imu/accel_random_walk");
    d.gyro_bias_sigma = cfg.getDouble("imu/gyro_bias_sigma");
    d.accel_bias_sigma = cfg.getDouble("imu/accel_bias_sigma");
    for (const auto& [key, v] : {std::pair{"rate_hz", d.rate_hz},
                                 {"gyro_noise_density", d.gyro_noise_density},
                                 {"accel_noise_density", d.accel_noise_density},
                                 {"gyro_bias_sigma", d.gyro_bias_sigma},
                                 {"accel_bias_sigma", d.accel_bias_sigma}})
      if (!(v > 0 && std::isfinite(v))) throw ConfigError(path + ": key 'imu/" + key + "' must be positive");
    for (const auto& [key, v] :
         {std::pair{"gyro_random_walk", d.gyro_random_walk}, {"accel_random_walk", d.accel_random_walk}})
      if (!(v >= 0 && std::isfinite(v))) throw ConfigError(path + ": key 'imu/" + key + "' must not be negative");
    c.imu = d;
  }
  if (cfg.has("tilt")) {
    TiltDescription d;
    d.model = cfg.getString("tilt/model", "");
    d.rate_hz = cfg.getDouble("tilt/rate_hz");
    d.accuracy = cfg.getDouble("tilt/accuracy");
    d.resolution = cfg.getDouble("tilt/resolution");
    for (const auto& [key, v] :
         {std::pair{"rate_hz", d.rate_hz}, {"accuracy", d.accuracy}, {"resolution", d.resolution}})
      if (!(v > 0 && std::isfinite(v))) throw ConfigError(path + ": key 'tilt/" + key + "' must be positive");
    c.tilt = d;
  }
  return c;
}

void saveCalibration(const std::string& path, const StereoCalibration& c,
                     const std::function<void(cv::FileStorage&)>& write_more) {
  cv::FileStorage fs(path, cv::FileStorage::WRITE | cv::FileStorage::FORMAT_YAML);
  if (!fs.isOpened()) throw ConfigError(path + ": cannot write calibration");
  fs.writeComment(
      "Stereo head calibration (ips). Camera frames: x right, y down, z forward. T_a_b maps points from b to a.\n"
      "distortion: OpenCV radial-tangential k1 k2 p1 p2 k3, or with distortion_model: equidistant the fisheye\n"
      "k1 k2 k3 k4. vignetting_gain (optional): g1 g2 g3 of the flat-field gain 1 + g1 t + g2 t^2 + g3 t^3,\n"
      "t = tan^2 of a ray's angle to the optical axis. Lengths in metres.");
  writeCamera(fs, "cam0", c.cam0);
  writeCamera(fs, "cam1", c.cam1);
  fs << "R_cam1_cam0" << toCv(c.R_cam1_cam0);
  fs << "t_cam1_cam0" << toCv(c.t_cam1_cam0);
  fs << "T_imu_cam0" << toCv(c.T_imu_cam0.matrix());
  fs << "R_tilt_cam0" << toCv(c.R_tilt_cam0);
  if (!c.source.empty()) fs << "source" << c.source;
  if (c.imu) {
    const ImuDescription& d = *c.imu;
    fs.writeComment(
        "The IMU (Kalibr's conventions): noise densities [rad/s/sqrt(Hz)], [m/s^2/sqrt(Hz)], bias random walks\n"
        "[rad/s^2/sqrt(Hz)], [m/s^3/sqrt(Hz)], turn-on bias sigmas [rad/s], [m/s^2] per axis.");
    fs << "imu"
       << "{";
    if (!d.model.empty()) fs << "model" << d.model;
    fs << "rate_hz" << d.rate_hz << "gyro_noise_density" << d.gyro_noise_density << "gyro_random_walk"
       << d.gyro_random_walk << "accel_noise_density" << d.accel_noise_density << "accel_random_walk"
       << d.accel_random_walk << "gyro_bias_sigma" << d.gyro_bias_sigma << "accel_bias_sigma" << d.accel_bias_sigma;
    fs << "}";
  }
  if (c.tilt) {
    const TiltDescription& d = *c.tilt;
    fs.writeComment("The tilt sensor: accuracy (its constant offset) and resolution per angle [rad].");
    fs << "tilt"
       << "{";
    if (!d.model.empty()) fs << "model" << d.model;
    fs << "rate_hz" << d.rate_hz << "accuracy" << d.accuracy << "resolution" << d.resolution;
    fs << "}";
  }
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
    if (w.norm() > 0) out.R_rect1_cam1 = expSO3(w) * out.R_rect1_cam1;
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
  if (c.cam0.hasVignetting() || c.cam1.hasVignetting()) {
    // The gain of the ray each rectified pixel sees, the ray turned from the rectified frame into the camera's (the
    // maps sample the raw pixel of that ray, so no undistortion is needed); the right camera's pixel moved as its
    // map was by the yaw's keystone and the disparity offset.
    const auto gains = [&](const CameraIntrinsics& cam, const Eigen::Matrix3d& R_rect_cam, double offset_px,
                           double yaw_rad) {
      cv::Mat gain(out.size, CV_32FC1);
      const Eigen::Matrix3d R_cam_rect = R_rect_cam.transpose();
      for (int y = 0; y < out.size.height; ++y)
        for (int x = 0; x < out.size.width; ++x) {
          const double u = (x + offset_px - out.cx) / out.f, v0 = (y - out.cy) / out.f;
          const double v = v0 - u * v0 * yaw_rad;
          const Eigen::Vector3d ray = R_cam_rect * Eigen::Vector3d(u, v, 1);
          const double tan2 = (ray.x() * ray.x() + ray.y() * ray.y()) / (ray.z() * ray.z());
          gain.at<float>(y, x) = static_cast<float>(cam.flatFieldGain(tan2));
        }
      return gain;
    };
    out.gain0 = gains(c.cam0, out.R_rect0_cam0, 0, 0);
    out.gain1 = gains(cam1, out.R_rect1_cam1, offset, yaw);
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
  for (cv::Mat* map : {&rect.map0x, &rect.map0y, &rect.map1x, &rect.map1y, &rect.gain0, &rect.gain1}) {
    if (map->empty()) continue;  // the gains, without vignetting
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

namespace {

// cv::remap of a grey image times the flat-field gain, in float as the device computes it (bilinear sample times
// gain, rounded half up).
void remapFlatField(const cv::Mat& raw, const cv::Mat& map_x, const cv::Mat& map_y, const cv::Mat& gain, cv::Mat& out) {
  cv::Mat raw_float, sampled;
  raw.convertTo(raw_float, CV_32F);
  cv::remap(raw_float, sampled, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
  out.create(sampled.size(), CV_8UC1);
  for (int i = 0; i < static_cast<int>(sampled.total()); ++i) {
    const float v = sampled.at<float>(i) * gain.at<float>(i);
    out.at<uint8_t>(i) = static_cast<uint8_t>(std::clamp(std::floor(v + 0.5f), 0.0f, 255.0f));
  }
}

}  // namespace

void rectifyPair(const StereoRectification& rect, const cv::Mat& raw0, const cv::Mat& raw1, cv::Mat& out0,
                 cv::Mat& out1) {
  if (rect.hasFlatField()) {
    remapFlatField(raw0, rect.map0x, rect.map0y, rect.gain0, out0);
    remapFlatField(raw1, rect.map1x, rect.map1y, rect.gain1, out1);
    return;
  }
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
