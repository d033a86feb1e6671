#include "ips/polar_rectification.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <vector>

namespace ips {
namespace {

// Border points of the raw image per side: its outline in the pinhole image (distortion bends the sides).
constexpr int kOutlinePointsPerSide = 32;
// Motion this close to perpendicular to the optical axis puts the epipole at "infinity": it is placed this far
// (as a fraction of the focal length's reciprocal) so that the geometry stays finite; the rows are then parallel.
constexpr double kMinAxialFraction = 1e-6;

Eigen::Vector2d project(const Eigen::Matrix3d& K, const Eigen::Vector3d& X) {
  const Eigen::Vector3d p = K * (X / X.z());
  return p.head<2>();
}

// Raw pixel positions of rays (camera frame) through the camera's lens; (-1, -1) for rays not in front of it.
void projectRays(const CameraIntrinsics& cam, const std::vector<cv::Point3d>& rays, std::vector<cv::Point2d>& out) {
  std::vector<cv::Point3d> front;
  std::vector<size_t> index;
  front.reserve(rays.size());
  index.reserve(rays.size());
  for (size_t i = 0; i < rays.size(); ++i)
    if (rays[i].z > 0) {
      front.push_back(rays[i]);
      index.push_back(i);
    }
  std::vector<cv::Point2d> projected;
  if (!front.empty()) {
    const cv::Mat zero = cv::Mat::zeros(3, 1, CV_64F);
    if (cam.model == DistortionModel::kEquidistant)
      cv::fisheye::projectPoints(front, projected, zero, zero, cam.cvK(), cam.cvDistortion());
    else
      cv::projectPoints(front, zero, zero, cam.cvK(), cam.cvDistortion(), projected);
  }
  out.assign(rays.size(), cv::Point2d(-1, -1));
  for (size_t j = 0; j < index.size(); ++j) out[index[j]] = projected[j];
}

// The raw image's outline in the ideal pinhole image of K.
std::vector<cv::Point2f> viewOutline(const CameraIntrinsics& cam) {
  std::vector<cv::Point2f> border;
  const float w = static_cast<float>(cam.width - 1), h = static_cast<float>(cam.height - 1);
  for (int i = 0; i < kOutlinePointsPerSide; ++i) {
    const float s = static_cast<float>(i) / kOutlinePointsPerSide;
    border.emplace_back(s * w, 0.f);
    border.emplace_back(w, s * h);
    border.emplace_back((1 - s) * w, h);
    border.emplace_back(0.f, (1 - s) * h);
  }
  // Order along the outline: top, right, bottom, left.
  std::vector<cv::Point2f> ordered;
  for (int side = 0; side < 4; ++side)
    for (int i = 0; i < kOutlinePointsPerSide; ++i) ordered.push_back(border[static_cast<size_t>(i) * 4 + side]);
  std::vector<cv::Point2f> ideal;
  if (cam.model == DistortionModel::kEquidistant)
    cv::fisheye::undistortPoints(ordered, ideal, cam.cvK(), cam.cvDistortion(), cv::noArray(), cam.cvK());
  else
    cv::undistortPoints(ordered, ideal, cam.cvK(), cam.cvDistortion(), cv::noArray(), cam.cvK());
  return ideal;
}

}  // namespace

PolarRectificationParams PolarRectificationParams::fromConfig(const Config& section) {
  PolarRectificationParams p;
  p.size.width = section.getInt("width", p.size.width);
  p.size.height = section.getInt("height", p.size.height);
  p.min_epipole_angle_deg = section.getDouble("min_epipole_angle_deg", p.min_epipole_angle_deg);
  if (p.size.width <= 0 || p.size.height <= 0) throw ConfigError("polar rectification: width and height must be > 0");
  if (!(p.min_epipole_angle_deg >= 0 && p.min_epipole_angle_deg < 90))
    throw ConfigError("polar rectification: min_epipole_angle_deg must be in [0, 90)");
  return p;
}

Eigen::Vector3d PolarRectification::ray(double u, double v) const {
  const double theta = theta0 + (v + 0.5) * dtheta;
  const double r = r0 + u * dr;
  const Eigen::Vector3d p(epipole.x() + r * std::cos(theta), epipole.y() + r * std::sin(theta), 1.0);
  return K.triangularView<Eigen::Upper>().solve(p);  // K is upper triangular: no inverse per pixel
}

double PolarRectification::disparityOf(const Eigen::Vector3d& X_a) const {
  const Eigen::Vector3d in_left = X_a - leftCentre(), in_right = X_a - rightCentre();
  if (in_left.z() <= 0 || in_right.z() <= 0) return std::numeric_limits<double>::quiet_NaN();
  return ((project(K, in_left) - epipole).norm() - (project(K, in_right) - epipole).norm()) / dr;
}

Eigen::Vector3d PolarRectification::triangulate(double u, double v, double d) const {
  if (!(d > 0)) return Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  const Eigen::Vector3d o1 = leftCentre(), o2 = rightCentre();
  const Eigen::Vector3d d1 = ray(u, v), d2 = ray(u - d, v);
  // Closest points o1 + s d1 and o2 + t d2 of the two rays; their midpoint.
  const Eigen::Vector3d w = o1 - o2;
  const double a = d1.dot(d1), b = d1.dot(d2), c = d2.dot(d2), dd = d1.dot(w), e = d2.dot(w);
  const double den = a * c - b * b;
  if (std::abs(den) < 1e-15) return Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  const double s = (b * e - c * dd) / den, t = (a * e - b * dd) / den;
  return 0.5 * ((o1 + s * d1) + (o2 + t * d2));
}

PolarRectification polarRectification(const CameraIntrinsics& camera, const Eigen::Isometry3d& T_a_b,
                                      const PolarRectificationParams& params) {
  if (params.size.width <= 0 || params.size.height <= 0) throw std::invalid_argument("polarRectification: empty size");
  PolarRectification out;
  out.K = camera.K;
  out.R_a_b = T_a_b.linear();
  out.c_b = T_a_b.translation();
  const double baseline = out.c_b.norm();
  if (!(baseline > 0)) throw std::invalid_argument("polarRectification: the two exposures share one centre");
  // The epipole: the image of the line through both centres (c and -c project to the same point).
  Eigen::Vector3d c = out.c_b;
  const double min_axial = baseline * kMinAxialFraction;
  if (std::abs(c.z()) < min_axial) c.z() = c.z() < 0 ? -min_axial : min_axial;
  out.epipole = project(out.K, c);
  // Ahead along the axis, points of b appear farther from the epipole (it is b's focus of expansion).
  out.left_is_b = out.c_b.z() >= 0;

  // Angle and distance ranges from the view's outline as seen from the epipole.
  const std::vector<cv::Point2f> outline = viewOutline(camera);
  const cv::Point2f e(static_cast<float>(out.epipole.x()), static_cast<float>(out.epipole.y()));
  const bool far_epipole = out.epipole.norm() > 1e6;  // beyond float precision for the polygon test
  const double inside = far_epipole ? -1.0 : cv::pointPolygonTest(outline, e, true);
  double r_lo = 0, r_hi = 0;
  for (const cv::Point2f& q : outline) r_hi = std::max(r_hi, std::hypot(q.x - out.epipole.x(), q.y - out.epipole.y()));
  double theta_lo = -M_PI, theta_hi = M_PI;
  if (inside < 0) {
    r_lo = std::numeric_limits<double>::max();
    for (const cv::Point2f& q : outline)
      r_lo = std::min(r_lo, std::hypot(q.x - out.epipole.x(), q.y - out.epipole.y()));
    // Outside a (nearly) convex outline the vertices' angles span less than pi around the direction to its centre.
    cv::Point2d centre(0, 0);
    for (const cv::Point2f& q : outline) centre += cv::Point2d(q.x, q.y);
    centre *= 1.0 / outline.size();
    const double mid = std::atan2(centre.y - out.epipole.y(), centre.x - out.epipole.x());
    theta_lo = std::numeric_limits<double>::max();
    theta_hi = -theta_lo;
    for (const cv::Point2f& q : outline) {
      const double a = std::remainder(std::atan2(q.y - out.epipole.y(), q.x - out.epipole.x()) - mid, 2 * M_PI);
      theta_lo = std::min(theta_lo, a);
      theta_hi = std::max(theta_hi, a);
    }
    theta_lo += mid;
    theta_hi += mid;
  }
  const double focal = 0.5 * (camera.K(0, 0) + camera.K(1, 1));
  const double min_angle = params.min_epipole_angle_deg * M_PI / 180;
  r_lo = std::max(r_lo, focal * std::tan(min_angle));
  if (!(r_hi > r_lo)) throw std::invalid_argument("polarRectification: the view lies within the epipole's mask");
  const cv::Size size = params.size;
  out.r0 = r_lo;
  out.dr = (r_hi - r_lo) / size.width;
  out.theta0 = theta_lo;
  out.dtheta = (theta_hi - theta_lo) / size.height;

  // Rays of all polar pixels in a's orientation, in b's, and where each lands in its raw image.
  const size_t n = static_cast<size_t>(size.area());
  std::vector<cv::Point3d> rays_a(n), rays_b(n);
  const Eigen::Matrix3d R_b_a = out.R_a_b.transpose();
  const Eigen::Vector3d motion = out.c_b / baseline;
  const double cos_min = std::cos(min_angle);
  std::vector<uint8_t> wide(n);
  for (int v = 0; v < size.height; ++v)
    for (int u = 0; u < size.width; ++u) {
      const size_t i = static_cast<size_t>(v) * size.width + u;
      const Eigen::Vector3d ra = out.ray(u, v), rb = R_b_a * ra;
      rays_a[i] = cv::Point3d(ra.x(), ra.y(), ra.z());
      rays_b[i] = cv::Point3d(rb.x(), rb.y(), rb.z());
      wide[i] = std::abs(ra.normalized().dot(motion)) <= cos_min;
    }
  std::vector<cv::Point2d> raw_a, raw_b;
  projectRays(camera, rays_a, raw_a);
  projectRays(camera, rays_b, raw_b);
  StereoRectification& m = out.maps;
  m.size = size;
  m.map0x.create(size, CV_32FC1);
  m.map0y.create(size, CV_32FC1);
  m.map1x.create(size, CV_32FC1);
  m.map1y.create(size, CV_32FC1);
  out.valid.create(size, CV_8UC1);
  const auto in_image = [&](const cv::Point2d& p) {
    return p.x >= 0 && p.y >= 0 && p.x <= camera.width - 1 && p.y <= camera.height - 1;
  };
  for (int v = 0; v < size.height; ++v)
    for (int u = 0; u < size.width; ++u) {
      const size_t i = static_cast<size_t>(v) * size.width + u;
      const cv::Point2d& left = out.left_is_b ? raw_b[i] : raw_a[i];
      const cv::Point2d& right = out.left_is_b ? raw_a[i] : raw_b[i];
      m.map0x.at<float>(v, u) = in_image(left) ? static_cast<float>(left.x) : -1.f;
      m.map0y.at<float>(v, u) = in_image(left) ? static_cast<float>(left.y) : -1.f;
      m.map1x.at<float>(v, u) = in_image(right) ? static_cast<float>(right.x) : -1.f;
      m.map1y.at<float>(v, u) = in_image(right) ? static_cast<float>(right.y) : -1.f;
      out.valid.at<uint8_t>(v, u) = (wide[i] && in_image(left) && in_image(right)) ? 255 : 0;
    }
  return out;
}

}  // namespace ips
