#pragma once
// Shared by the tracker tests: a textured plane seen by a stereo pair (images by plane homographies of a
// real image), and the EuRoC ground truth of the moving pairs.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>

#include "ips/calibration.hpp"
#include "ips/shared_data_test.hpp"
#include "ips/tracker/motion.hpp"

namespace ips::tracker::test {

inline std::string dataDir() { return ips::dataDir(); }

// A plane n^T X = d in the reference camera (camera 0 at time 0) whose texture is `texture` as that camera
// sees it. Renders any camera posed by X_ref = R * X_cam + t.
struct TexturedPlane {
  cv::Mat texture;  // 8-bit grey, the reference view
  Eigen::Matrix3d K;
  Eigen::Vector3d n{0, 0, 1};
  double d = 3.0;
  int border = cv::BORDER_REFLECT;  // BORDER_CONSTANT: the plane ends where its texture ends (an object)

  cv::Mat render(const Eigen::Matrix3d& R, const Eigen::Vector3d& t) const {
    const Eigen::Vector3d n_c = R.transpose() * n;
    const double d_c = d - n.dot(t);
    const Eigen::Matrix3d H = K * (R + t * n_c.transpose() / d_c) * K.inverse();  // camera pixel -> reference pixel
    cv::Mat h(3, 3, CV_64F);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) h.at<double>(r, c) = H(r, c);
    cv::Mat out;
    cv::warpPerspective(texture, out, h, texture.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, border);
    return out;
  }
};

// An ideal rectified head: same K, no distortion, camera 1 `baseline` to the right.
inline StereoCalibration idealCalibration(const Eigen::Matrix3d& K, int w, int h, double baseline) {
  StereoCalibration c;
  c.cam0.width = c.cam1.width = w;
  c.cam0.height = c.cam1.height = h;
  c.cam0.K = c.cam1.K = K;
  c.t_cam1_cam0 = Eigen::Vector3d(-baseline, 0, 0);
  return c;
}

// A real image as plane texture, grey, resized to w x h.
inline cv::Mat realTexture(int w, int h) {
  cv::Mat img = cv::imread(dataDir() + "/stereo/teddy/left.png", cv::IMREAD_GRAYSCALE), out;
  cv::resize(img, out, cv::Size(w, h), 0, 0, cv::INTER_CUBIC);
  return out;
}

// EuRoC moving pairs: ground-truth body poses (T_world_body) per source and time stamp [ns as string].
inline std::map<std::string, std::map<std::string, Eigen::Isometry3d>> eurocPoses() {
  std::map<std::string, std::map<std::string, Eigen::Isometry3d>> out;
  std::ifstream f(dataDir() + "/euroc/V1_01_easy/moving_pairs/poses_gt.csv");
  std::string line;
  while (std::getline(f, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::stringstream ss(line);
    std::string src, stamp, v;
    std::getline(ss, src, ',');
    std::getline(ss, stamp, ',');
    double x[7];
    for (double& xi : x) {
      std::getline(ss, v, ',');
      xi = std::stod(v);
    }
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = Eigen::Vector3d(x[0], x[1], x[2]);
    T.linear() = Eigen::Quaterniond(x[3], x[4], x[5], x[6]).normalized().toRotationMatrix();
    out[src][stamp] = T;
  }
  return out;
}

}  // namespace ips::tracker::test
