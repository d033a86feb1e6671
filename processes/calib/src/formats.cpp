#include "ips/calib/formats.hpp"

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <map>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "ips/config.hpp"
#include "yaml_scan.hpp"

namespace ips::calib {

namespace {

// The files carry rotations to 10-12 digits, not exact ones.
Eigen::Matrix3d orthonormalized(const Eigen::Matrix3d& r) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(r, Eigen::ComputeFullU | Eigen::ComputeFullV);
  return svd.matrixU() * svd.matrixV().transpose();
}

Eigen::Isometry3d rigid(const Eigen::Matrix4d& m, const std::string& path, const std::string& key) {
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  if ((r * r.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-3 || r.determinant() <= 0 ||
      (m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9)
    throw ConfigError(path + ": key '" + key + "' is not a rigid transform");
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = orthonormalized(r);
  t.translation() = m.topRightCorner<3, 1>();
  return t;
}

void setStereo(StereoCalibration& c, const Eigen::Isometry3d& T_cam1_cam0) {
  c.R_cam1_cam0 = T_cam1_cam0.linear();
  c.t_cam1_cam0 = T_cam1_cam0.translation();
}

CameraIntrinsics pinhole(int width, int height, double fu, double fv, double cu, double cv, const std::string& path,
                         const std::string& key) {
  if (width <= 0 || height <= 0) throw ConfigError(path + ": key '" + key + "' needs a positive image size");
  if (!(fu > 0 && fv > 0)) throw ConfigError(path + ": key '" + key + "' needs positive focal lengths");
  CameraIntrinsics k;
  k.width = width;
  k.height = height;
  k.K << fu, 0, cu, 0, fv, cv, 0, 0, 1;
  return k;
}

// Radial-tangential k1 k2 p1 p2 [k3] or equidistant k1 k2 k3 k4 into `cam`.
void setDistortion(CameraIntrinsics& cam, DistortionModel model, const std::vector<double>& d, const std::string& path,
                   const std::string& key) {
  cam.model = model;
  const bool ok = model == DistortionModel::kEquidistant ? d.size() == 4 : (d.size() == 4 || d.size() == 5);
  if (!ok)
    throw ConfigError(path + ": key '" + key + "' needs " +
                      (model == DistortionModel::kEquidistant ? "k1 k2 k3 k4" : "k1 k2 p1 p2 [k3]"));
  cam.distortion.setZero();
  for (size_t i = 0; i < d.size(); ++i) cam.distortion(static_cast<int>(i)) = d[i];
}

}  // namespace

// ---- EuRoC -----------------------------------------------------------------------------------------------

EurocCamera readEurocCamera(const std::string& path) {
  const std::string text = yaml::load(path);
  EurocCamera cam;
  const std::string model = yaml::scalar(text, "camera_model");
  if (!model.empty() && model != "pinhole")
    throw ConfigError(path + ": key 'camera_model' is '" + model + "', need pinhole");
  const std::string dist = yaml::scalar(text, "distortion_model");
  if (!dist.empty() && dist != "radial-tangential" && dist != "radtan")
    throw ConfigError(path + ": key 'distortion_model' is '" + dist + "', need radial-tangential");
  const auto res = yaml::numberList(text, path, "resolution");
  if (res.size() != 2 || res[0] <= 0 || res[1] <= 0)
    throw ConfigError(path + ": key 'resolution' needs [width, height]");
  cam.width = static_cast<int>(res[0]);
  cam.height = static_cast<int>(res[1]);
  const auto in = yaml::numberList(text, path, "intrinsics");
  if (in.size() != 4 || in[0] <= 0 || in[1] <= 0) throw ConfigError(path + ": key 'intrinsics' needs [fu, fv, cu, cv]");
  cam.fu = in[0];
  cam.fv = in[1];
  cam.cu = in[2];
  cam.cv = in[3];
  cam.distortion = yaml::numberList(text, path, "distortion_coefficients");
  if (cam.distortion.size() != 4 && cam.distortion.size() != 5)
    throw ConfigError(path + ": key 'distortion_coefficients' needs k1 k2 p1 p2 [k3]");
  const size_t tbs = text.find("T_BS");
  if (tbs == std::string::npos) throw ConfigError(path + ": key 'T_BS' not found");
  const auto data = yaml::numberList(text, path, "data", tbs);
  if (data.size() != 16) throw ConfigError(path + ": key 'T_BS/data' needs 16 numbers");
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) cam.T_BS(r, c) = data[static_cast<size_t>(r * 4 + c)];
  rigid(cam.T_BS, path, "T_BS");
  return cam;
}

StereoCalibration readEuroc(const std::string& cam0_path, const std::string& cam1_path) {
  const EurocCamera c0 = readEurocCamera(cam0_path), c1 = readEurocCamera(cam1_path);
  auto intr = [](const EurocCamera& c, const std::string& path, const std::string& serial) {
    CameraIntrinsics k = pinhole(c.width, c.height, c.fu, c.fv, c.cu, c.cv, path, "intrinsics");
    setDistortion(k, DistortionModel::kRadialTangential, c.distortion, path, "distortion_coefficients");
    k.serial = serial;
    return k;
  };
  StereoCalibration calib;
  calib.cam0 = intr(c0, cam0_path, "euroc_cam0");
  calib.cam1 = intr(c1, cam1_path, "euroc_cam1");
  const Eigen::Isometry3d T_B_c0 = rigid(c0.T_BS, cam0_path, "T_BS"), T_B_c1 = rigid(c1.T_BS, cam1_path, "T_BS");
  setStereo(calib, T_B_c1.inverse() * T_B_c0);
  calib.T_imu_cam0 = T_B_c0;
  return calib;
}

ImuDescription readImuNoise(const std::string& path, double gyro_bias_sigma, double accel_bias_sigma) {
  const std::string text = yaml::load(path);
  const std::string kalibr = yaml::section(text, "imu0");
  const std::string& body = kalibr.empty() ? text : kalibr;
  const std::string prefix = kalibr.empty() ? "" : "imu0/";
  auto number = [&](const std::string& key) {
    const std::string v = yaml::scalar(body, key);
    if (v.empty()) throw ConfigError(path + ": key '" + prefix + key + "' not found");
    try {
      size_t used = 0;
      const double x = std::stod(v, &used);
      if (used == v.size() && std::isfinite(x)) return x;
    } catch (const std::exception&) {
    }
    throw ConfigError(path + ": key '" + prefix + key + "' is '" + v + "', not a number");
  };
  ImuDescription d;
  d.model = yaml::scalar(body, "comment");
  d.rate_hz = number(kalibr.empty() ? "rate_hz" : "update_rate");
  d.gyro_noise_density = number("gyroscope_noise_density");
  d.gyro_random_walk = number("gyroscope_random_walk");
  d.accel_noise_density = number("accelerometer_noise_density");
  d.accel_random_walk = number("accelerometer_random_walk");
  d.gyro_bias_sigma = gyro_bias_sigma;
  d.accel_bias_sigma = accel_bias_sigma;
  if (!(d.rate_hz > 0 && d.gyro_noise_density > 0 && d.accel_noise_density > 0 && d.gyro_random_walk >= 0 &&
        d.accel_random_walk >= 0 && gyro_bias_sigma > 0 && accel_bias_sigma > 0))
    throw ConfigError(path + ": the IMU's rate and noise densities must be positive, its random walks not negative");
  return d;
}

// ---- Kalibr ----------------------------------------------------------------------------------------------

namespace {

struct KalibrCamera {
  CameraIntrinsics intrinsics;
  bool has_imu = false;
  Eigen::Isometry3d T_imu_cam = Eigen::Isometry3d::Identity();
  bool has_prev = false;
  Eigen::Isometry3d T_cn_cnm1 = Eigen::Isometry3d::Identity();
};

KalibrCamera kalibrCamera(const std::string& text, const std::string& path, const std::string& name) {
  const std::string s = yaml::section(text, name);
  if (s.empty()) throw ConfigError(path + ": key '" + name + "' not found");
  const std::string model = yaml::scalar(s, "camera_model");
  if (model != "pinhole")
    throw ConfigError(path + ": key '" + name + "/camera_model' is '" + model + "', need pinhole");
  const auto in = yaml::numberList(s, path, "intrinsics", 0, name + "/intrinsics");
  if (in.size() != 4) throw ConfigError(path + ": key '" + name + "/intrinsics' needs [fu, fv, cu, cv]");
  const auto res = yaml::numberList(s, path, "resolution", 0, name + "/resolution");
  if (res.size() != 2) throw ConfigError(path + ": key '" + name + "/resolution' needs [width, height]");
  KalibrCamera cam;
  cam.intrinsics = pinhole(static_cast<int>(res[0]), static_cast<int>(res[1]), in[0], in[1], in[2], in[3], path,
                           name + "/intrinsics");
  const std::string dist = yaml::scalar(s, "distortion_model");
  DistortionModel m;
  if (dist == "radtan")
    m = DistortionModel::kRadialTangential;
  else if (dist == "equidistant")
    m = DistortionModel::kEquidistant;
  else
    throw ConfigError(path + ": key '" + name + "/distortion_model' is '" + dist + "', need radtan or equidistant");
  setDistortion(cam.intrinsics, m, yaml::numberList(s, path, "distortion_coeffs", 0, name + "/distortion_coeffs"), path,
                name + "/distortion_coeffs");
  Eigen::MatrixXd t;
  if (yaml::blockMatrix(s, path, "T_cam_imu", 4, 4, t)) {
    cam.has_imu = true;
    cam.T_imu_cam = rigid(t, path, name + "/T_cam_imu").inverse();
  } else if (yaml::blockMatrix(s, path, "T_imu_cam", 4, 4, t)) {
    cam.has_imu = true;
    cam.T_imu_cam = rigid(t, path, name + "/T_imu_cam");
  }
  if (yaml::blockMatrix(s, path, "T_cn_cnm1", 4, 4, t)) {
    cam.has_prev = true;
    cam.T_cn_cnm1 = rigid(t, path, name + "/T_cn_cnm1");
  }
  return cam;
}

}  // namespace

StereoCalibration readKalibr(const std::string& path) {
  const std::string text = yaml::load(path);
  const KalibrCamera c0 = kalibrCamera(text, path, "cam0"), c1 = kalibrCamera(text, path, "cam1");
  if (c0.intrinsics.model != c1.intrinsics.model)
    throw ConfigError(path + ": key 'cam1/distortion_model' differs from cam0's");
  StereoCalibration calib;
  calib.cam0 = c0.intrinsics;
  calib.cam1 = c1.intrinsics;
  calib.cam0.serial = "kalibr_cam0";
  calib.cam1.serial = "kalibr_cam1";
  if (c1.has_prev)
    setStereo(calib, c1.T_cn_cnm1);
  else if (c0.has_imu && c1.has_imu)
    setStereo(calib, c1.T_imu_cam.inverse() * c0.T_imu_cam);
  else
    throw ConfigError(path + ": key 'cam1/T_cn_cnm1' not found (nor T_cam_imu of both cameras)");
  if (c0.has_imu) calib.T_imu_cam0 = c0.T_imu_cam;
  if (calib.t_cam1_cam0.norm() <= 0) throw ConfigError(path + ": key 'cam1/T_cn_cnm1' has no baseline");
  return calib;
}

// ---- ROS camera_info ---------------------------------------------------------------------------------------

namespace {

struct RosCamera {
  CameraIntrinsics intrinsics;
  Eigen::Matrix3d R_rect_cam;
  Eigen::Matrix<double, 3, 4> P;
};

RosCamera rosCamera(const std::string& path) {
  const std::string text = yaml::load(path);
  RosCamera cam;
  const std::string w = yaml::scalar(text, "image_width"), h = yaml::scalar(text, "image_height");
  if (w.empty() || h.empty()) throw ConfigError(path + ": key 'image_width' / 'image_height' not found");
  int width = 0, height = 0;
  try {
    width = std::stoi(w);
    height = std::stoi(h);
  } catch (const std::exception&) {
    throw ConfigError(path + ": key 'image_width' / 'image_height' is not a number");
  }
  const auto k = yaml::dataOf(text, path, "camera_matrix", 9);
  cam.intrinsics = pinhole(width, height, k[0], k[4], k[2], k[5], path, "camera_matrix");
  cam.intrinsics.K(0, 1) = k[1];
  const std::string model = yaml::scalar(text, "distortion_model");
  DistortionModel m;
  if (model == "plumb_bob" || model == "rational_polynomial")
    m = DistortionModel::kRadialTangential;
  else if (model == "equidistant")
    m = DistortionModel::kEquidistant;
  else
    throw ConfigError(path + ": key 'distortion_model' is '" + model + "', need plumb_bob or equidistant");
  const size_t at = text.find("distortion_coefficients");
  if (at == std::string::npos) throw ConfigError(path + ": key 'distortion_coefficients' not found");
  auto d = yaml::numberList(text, path, "data", at);
  if (model == "rational_polynomial") {
    // k4..k6 of the rational model are not in the project's format: only all-zero ones convert exactly.
    for (size_t i = 5; i < d.size(); ++i)
      if (d[i] != 0) throw ConfigError(path + ": key 'distortion_coefficients' has rational terms k4..k6");
    d.resize(std::min<size_t>(d.size(), 5));
  }
  setDistortion(cam.intrinsics, m, d, path, "distortion_coefficients");
  const auto r = yaml::dataOf(text, path, "rectification_matrix", 9);
  for (int i = 0; i < 9; ++i) cam.R_rect_cam(i / 3, i % 3) = r[static_cast<size_t>(i)];
  if ((cam.R_rect_cam * cam.R_rect_cam.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-3)
    throw ConfigError(path + ": key 'rectification_matrix' is not a rotation");
  cam.R_rect_cam = orthonormalized(cam.R_rect_cam);
  const auto p = yaml::dataOf(text, path, "projection_matrix", 12);
  for (int i = 0; i < 12; ++i) cam.P(i / 4, i % 4) = p[static_cast<size_t>(i)];
  if (!(cam.P(0, 0) > 0)) throw ConfigError(path + ": key 'projection_matrix' needs a positive focal length");
  return cam;
}

void writeRosCamera(const std::string& path, const std::string& name, const CameraIntrinsics& cam, const cv::Mat& R,
                    const cv::Mat& P) {
  std::ofstream f(path);
  if (!f) throw ConfigError(path + ": cannot write");
  f << std::setprecision(17);
  auto list = [&](const cv::Mat& m) {
    f << "[";
    for (int i = 0; i < static_cast<int>(m.total()); ++i) f << (i ? ", " : "") << m.at<double>(i);
    f << "]";
  };
  const cv::Mat D = cam.cvDistortion();
  f << "image_width: " << cam.width << "\nimage_height: " << cam.height << "\ncamera_name: " << name << "\n";
  f << "camera_matrix:\n  rows: 3\n  cols: 3\n  data: ";
  list(cam.cvK());
  f << "\ndistortion_model: " << (cam.model == DistortionModel::kEquidistant ? "equidistant" : "plumb_bob") << "\n";
  f << "distortion_coefficients:\n  rows: 1\n  cols: " << D.total() << "\n  data: ";
  list(D);
  f << "\nrectification_matrix:\n  rows: 3\n  cols: 3\n  data: ";
  list(R);
  f << "\nprojection_matrix:\n  rows: 3\n  cols: 4\n  data: ";
  list(P);
  f << "\n";
}

}  // namespace

StereoCalibration readRosCameraInfo(const std::string& cam0_path, const std::string& cam1_path) {
  const RosCamera c0 = rosCamera(cam0_path), c1 = rosCamera(cam1_path);
  if (c0.intrinsics.model != c1.intrinsics.model)
    throw ConfigError(cam1_path + ": key 'distortion_model' differs from " + cam0_path + "'s");
  StereoCalibration calib;
  calib.cam0 = c0.intrinsics;
  calib.cam1 = c1.intrinsics;
  calib.cam0.serial = "ros_cam0";
  calib.cam1.serial = "ros_cam1";
  // Rectified frames differ by a translation only: X_rect1 = X_rect0 + (Tx / fx', Ty / fy', 0), where the right
  // camera's projection matrix holds Tx = -fx' * baseline in its last column.
  const Eigen::Vector3d t_rect(c1.P(0, 3) / c1.P(0, 0), c1.P(1, 3) / c1.P(1, 1), 0.0);
  if (t_rect.norm() <= 0) throw ConfigError(cam1_path + ": key 'projection_matrix' has no baseline (Tx = 0)");
  calib.R_cam1_cam0 = c1.R_rect_cam.transpose() * c0.R_rect_cam;
  calib.t_cam1_cam0 = c1.R_rect_cam.transpose() * t_rect;
  return calib;
}

void writeRosCameraInfo(const std::string& cam0_path, const std::string& cam1_path, const StereoCalibration& calib) {
  const StereoRectification rect = computeRectification(calib);
  cv::Mat R1, R2;
  cv::eigen2cv(rect.R_rect0_cam0, R1);
  cv::eigen2cv(rect.R_rect1_cam1, R2);
  cv::Mat P1 = (cv::Mat_<double>(3, 4) << rect.f, 0, rect.cx, 0, 0, rect.f, rect.cy, 0, 0, 0, 1, 0);
  cv::Mat P2 = P1.clone();
  P2.at<double>(0, 3) = -rect.f * rect.baseline;
  writeRosCamera(cam0_path, "cam0", calib.cam0, R1, P1);
  writeRosCamera(cam1_path, "cam1", calib.cam1, R2, P2);
}

// ---- OpenCV stereo_calib -------------------------------------------------------------------------------------

StereoCalibration readOpenCvStereo(const std::vector<std::string>& paths, cv::Size image_size, double units_per_metre) {
  if (paths.empty()) throw ConfigError("OpenCV stereo calibration: no file given");
  if (image_size.width <= 0 || image_size.height <= 0)
    throw ConfigError(paths[0] + ": the image size is not in OpenCV's stereo_calib files; give it");
  if (!(units_per_metre > 0)) throw ConfigError(paths[0] + ": units per metre must be positive");
  std::map<std::string, std::pair<cv::Mat, std::string>> found;  // key -> matrix, file
  for (const auto& path : paths) {
    cv::FileStorage fs;
    try {
      fs.open(path, cv::FileStorage::READ);
    } catch (const cv::Exception& e) {
      throw ConfigError(path + ": not an OpenCV YAML/XML file (" + e.msg + ")");
    }
    if (!fs.isOpened()) throw ConfigError(path + ": cannot open calibration file");
    for (const char* key : {"M1", "D1", "M2", "D2", "R", "T"}) {
      const cv::FileNode n = fs[key];
      if (n.empty()) continue;
      cv::Mat m;
      try {
        n >> m;
      } catch (const cv::Exception&) {
        throw ConfigError(path + ": key '" + key + "' is not a matrix");
      }
      if (m.empty()) throw ConfigError(path + ": key '" + key + "' is not a matrix");
      m.convertTo(m, CV_64F);
      found[key] = {m, path};
    }
  }
  auto get = [&](const std::string& key, int rows, int cols) {
    auto it = found.find(key);
    if (it == found.end()) throw ConfigError(paths[0] + ": key '" + key + "' not found");
    const cv::Mat& m = it->second.first;
    if (m.total() != static_cast<size_t>(rows * cols))
      throw ConfigError(it->second.second + ": key '" + key + "' needs " + std::to_string(rows) + "x" +
                        std::to_string(cols) + " values");
    return std::make_pair(m.reshape(1, rows), it->second.second);
  };
  auto camera = [&](const std::string& mk, const std::string& dk, const std::string& serial) {
    const auto [M, mpath] = get(mk, 3, 3);
    CameraIntrinsics k = pinhole(image_size.width, image_size.height, M.at<double>(0, 0), M.at<double>(1, 1),
                                 M.at<double>(0, 2), M.at<double>(1, 2), mpath, mk);
    k.K(0, 1) = M.at<double>(0, 1);
    auto it = found.find(dk);
    if (it == found.end()) throw ConfigError(paths[0] + ": key '" + dk + "' not found");
    const cv::Mat& D = it->second.first;
    std::vector<double> d(D.begin<double>(), D.end<double>());
    // stereo_calib uses CALIB_RATIONAL_MODEL and writes 8 coefficients (k1 k2 p1 p2 k3 k4 k5 k6); only all-zero
    // k4..k6 fit the project's radial-tangential model exactly.
    for (size_t i = 5; i < d.size(); ++i)
      if (d[i] != 0) throw ConfigError(it->second.second + ": key '" + dk + "' has rational terms k4..k6");
    if (d.size() > 5) d.resize(5);
    setDistortion(k, DistortionModel::kRadialTangential, d, it->second.second, dk);
    k.serial = serial;
    return k;
  };
  StereoCalibration calib;
  calib.cam0 = camera("M1", "D1", "opencv_cam0");
  calib.cam1 = camera("M2", "D2", "opencv_cam1");
  const auto [R, rpath] = get("R", 3, 3);
  const auto [T, tpath] = get("T", 3, 1);
  Eigen::Matrix3d r;
  cv::cv2eigen(R, r);
  if ((r * r.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-3)
    throw ConfigError(rpath + ": key 'R' is not a rotation");
  calib.R_cam1_cam0 = orthonormalized(r);
  cv::cv2eigen(T, calib.t_cam1_cam0);
  calib.t_cam1_cam0 /= units_per_metre;
  if (calib.t_cam1_cam0.norm() <= 0) throw ConfigError(tpath + ": key 'T' must not be zero");
  return calib;
}

void writeOpenCvStereo(const std::string& intrinsics_path, const std::string& extrinsics_path,
                       const StereoCalibration& calib) {
  if (calib.cam0.model != DistortionModel::kRadialTangential || calib.cam1.model != calib.cam0.model)
    throw ConfigError(intrinsics_path + ": OpenCV's stereo_calib format holds radial-tangential cameras only");
  cv::FileStorage in(intrinsics_path, cv::FileStorage::WRITE);
  if (!in.isOpened()) throw ConfigError(intrinsics_path + ": cannot write");
  in << "M1" << calib.cam0.cvK() << "D1" << calib.cam0.cvDistortion() << "M2" << calib.cam1.cvK() << "D2"
     << calib.cam1.cvDistortion();
  cv::FileStorage ex(extrinsics_path, cv::FileStorage::WRITE);
  if (!ex.isOpened()) throw ConfigError(extrinsics_path + ": cannot write");
  cv::Mat R, T;
  cv::eigen2cv(calib.R_cam1_cam0, R);
  cv::eigen2cv(calib.t_cam1_cam0, T);
  ex << "R" << R << "T" << T;
}

}  // namespace ips::calib
