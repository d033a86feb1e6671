#include "ips/tracker/euroc_calibration.hpp"

#include <fstream>
#include <regex>
#include <sstream>

#include "ips/config.hpp"

namespace ips::tracker {

namespace {

std::string stripComments(const std::string& text) {
  std::istringstream in(text);
  std::string line, out;
  while (std::getline(in, line)) {
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.erase(hash);
    if (line.rfind("%YAML", 0) == 0) continue;
    out += line + "\n";
  }
  return out;
}

// The numbers of the flow sequence "[a, b, ...]" that follows `key:` (at or after position `from`).
std::vector<double> numberList(const std::string& text, const std::string& path, const std::string& key,
                               size_t from = 0) {
  const std::regex re("(^|[\\s{,])" + key + "\\s*:\\s*\\[([^\\]]*)\\]");
  std::smatch m;
  std::string rest = text.substr(from);
  if (!std::regex_search(rest, m, re)) throw ConfigError(path + ": key '" + key + "' with a [ ... ] list not found");
  std::vector<double> values;
  std::string body = m[2].str();
  for (char& ch : body)
    if (ch == ',') ch = ' ';
  std::istringstream in(body);
  std::string tok;
  while (in >> tok) {
    try {
      size_t used = 0;
      values.push_back(std::stod(tok, &used));
      if (used != tok.size()) throw std::invalid_argument(tok);
    } catch (const std::exception&) {
      throw ConfigError(path + ": key '" + key + "' holds '" + tok + "', not a number");
    }
  }
  return values;
}

std::string scalar(const std::string& text, const std::string& key) {
  const std::regex re("(^|\\n)\\s*" + key + "\\s*:\\s*([^\\n]*)");
  std::smatch m;
  if (!std::regex_search(text, m, re)) return "";
  std::string v = m[2].str();
  while (!v.empty() && (v.back() == ' ' || v.back() == '\r' || v.back() == '\t')) v.pop_back();
  if (v.size() >= 2 && (v.front() == '"' || v.front() == '\'')) v = v.substr(1, v.size() - 2);
  return v;
}

}  // namespace

EurocCamera readEurocCamera(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw ConfigError(path + ": cannot open EuRoC sensor file");
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string text = stripComments(ss.str());

  EurocCamera cam;
  const std::string model = scalar(text, "camera_model");
  if (!model.empty() && model != "pinhole")
    throw ConfigError(path + ": key 'camera_model' is '" + model + "', need pinhole");
  const std::string dist = scalar(text, "distortion_model");
  if (!dist.empty() && dist != "radial-tangential" && dist != "radtan")
    throw ConfigError(path + ": key 'distortion_model' is '" + dist + "', need radial-tangential");

  const auto res = numberList(text, path, "resolution");
  if (res.size() != 2 || res[0] <= 0 || res[1] <= 0)
    throw ConfigError(path + ": key 'resolution' needs [width, height]");
  cam.width = int(res[0]);
  cam.height = int(res[1]);
  const auto in = numberList(text, path, "intrinsics");
  if (in.size() != 4 || in[0] <= 0 || in[1] <= 0) throw ConfigError(path + ": key 'intrinsics' needs [fu, fv, cu, cv]");
  cam.fu = in[0];
  cam.fv = in[1];
  cam.cu = in[2];
  cam.cv = in[3];
  cam.distortion = numberList(text, path, "distortion_coefficients");
  if (cam.distortion.size() != 4 && cam.distortion.size() != 5)
    throw ConfigError(path + ": key 'distortion_coefficients' needs k1 k2 p1 p2 [k3]");

  const size_t tbs = text.find("T_BS");
  if (tbs == std::string::npos) throw ConfigError(path + ": key 'T_BS' not found");
  const auto data = numberList(text, path, "data", tbs);
  if (data.size() != 16) throw ConfigError(path + ": key 'T_BS/data' needs 16 numbers");
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) cam.T_BS(r, c) = data[r * 4 + c];
  const Eigen::Matrix3d R = cam.T_BS.topLeftCorner<3, 3>();
  if ((R * R.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-3)
    throw ConfigError(path + ": key 'T_BS' is not a rigid transform");
  return cam;
}

StereoCalibration calibrationFromEuroc(const std::string& cam0_path, const std::string& cam1_path) {
  const EurocCamera c0 = readEurocCamera(cam0_path), c1 = readEurocCamera(cam1_path);
  auto intr = [](const EurocCamera& c, const std::string& serial) {
    CameraIntrinsics k;
    k.width = c.width;
    k.height = c.height;
    k.K << c.fu, 0, c.cu, 0, c.fv, c.cv, 0, 0, 1;
    for (size_t i = 0; i < c.distortion.size(); ++i) k.distortion(int(i)) = c.distortion[i];
    k.serial = serial;
    return k;
  };
  StereoCalibration calib;
  calib.cam0 = intr(c0, "euroc_cam0");
  calib.cam1 = intr(c1, "euroc_cam1");
  Eigen::Isometry3d T_B_c0, T_B_c1;
  T_B_c0.matrix() = c0.T_BS;
  T_B_c1.matrix() = c1.T_BS;
  // Orthonormalise: the files carry 12 digits, not exact rotations.
  auto ortho = [](Eigen::Isometry3d& T) {
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(T.linear(), Eigen::ComputeFullU | Eigen::ComputeFullV);
    T.linear() = svd.matrixU() * svd.matrixV().transpose();
  };
  ortho(T_B_c0);
  ortho(T_B_c1);
  const Eigen::Isometry3d T_c1_c0 = T_B_c1.inverse() * T_B_c0;
  calib.R_cam1_cam0 = T_c1_c0.linear();
  calib.t_cam1_cam0 = T_c1_c0.translation();
  calib.T_imu_cam0 = T_B_c0;
  return calib;
}

}  // namespace ips::tracker
