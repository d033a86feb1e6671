#include "ips/calib/tilt_calibration.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <stdexcept>

#include "ips/rotation.hpp"

namespace ips::calib {
namespace {

constexpr double kDeg = M_PI / 180.0;

}  // namespace

Eigen::Vector2d tiltAngles(const Eigen::Vector3d& f) {
  return {std::atan2(f.x(), std::hypot(f.y(), f.z())), std::atan2(f.y(), std::hypot(f.x(), f.z()))};
}

std::optional<ChartView> chartPose(const cv::Mat& raw_image, const CameraIntrinsics& camera,
                                   const ChessboardSpec& board, int64_t utime) {
  std::vector<cv::Point2f> corners;
  if (!detectChessboard(raw_image, board.inner_corners, corners)) return std::nullopt;
  std::vector<cv::Point3f> object;
  for (int r = 0; r < board.inner_corners.height; ++r)
    for (int c = 0; c < board.inner_corners.width; ++c)
      object.emplace_back(static_cast<float>(c * board.square_m), static_cast<float>(r * board.square_m), 0.0f);
  // The pose on undistorted normalised coordinates (the lens model applied once), then checked in pixels.
  std::vector<cv::Point2f> normalised;
  const cv::Mat K = camera.cvK(), D = camera.cvDistortion();
  if (camera.model == DistortionModel::kEquidistant)
    cv::fisheye::undistortPoints(corners, normalised, K, D);
  else
    cv::undistortPoints(corners, normalised, K, D);
  cv::Mat rvec, tvec;
  const cv::Mat identity = cv::Mat::eye(3, 3, CV_64F);
  if (!cv::solvePnP(object, normalised, identity, cv::noArray(), rvec, tvec, false, cv::SOLVEPNP_IPPE))
    return std::nullopt;
  cv::solvePnPRefineLM(object, normalised, identity, cv::noArray(), rvec, tvec);
  std::vector<cv::Point2f> projected;
  if (camera.model == DistortionModel::kEquidistant)
    cv::fisheye::projectPoints(object, projected, rvec, tvec, K, D);
  else
    cv::projectPoints(object, rvec, tvec, K, D, projected);
  double sum_sq = 0;
  for (size_t i = 0; i < corners.size(); ++i) {
    const cv::Point2f d = projected[i] - corners[i];
    sum_sq += d.dot(d);
  }
  ChartView view;
  view.utime = utime;
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  cv::cv2eigen(R, view.R_cam_chart);
  view.t_cam_chart = Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  view.reprojection_px = std::sqrt(sum_sq / static_cast<double>(corners.size()));
  const Eigen::Vector3d middle(0.5 * (board.inner_corners.width - 1) * board.square_m,
                               0.5 * (board.inner_corners.height - 1) * board.square_m, 0);
  view.centre_in_camera = view.R_cam_chart * middle + view.t_cam_chart;
  return view;
}

TiltCalibrationResult calibrateTilt(const std::vector<ChartView>& views_in, const std::vector<TiltReading>& readings_in,
                                    const Eigen::Matrix3d& nominal, const TiltCalibrationConfig& config) {
  if (config.min_stations < 2 || config.min_readings < 1 || !(config.min_station_s > 0) || config.settle_s < 0)
    throw std::invalid_argument("tilt calibration: need min_stations >= 2, min_readings >= 1, min_station_s > 0");
  TiltCalibrationResult out;
  std::vector<ChartView> views = views_in;
  std::sort(views.begin(), views.end(), [](const ChartView& x, const ChartView& y) { return x.utime < y.utime; });
  std::vector<TiltReading> readings = readings_in;
  std::sort(readings.begin(), readings.end(),
            [](const TiltReading& x, const TiltReading& y) { return x.utime < y.utime; });
  // "Up" in camera 0 as the design has it: the board's corner order may start at either end (a turn of 180 deg
  // in its plane), and the design tells which one is up.
  const Eigen::Vector3d up_nominal = nominal.transpose() * Eigen::Vector3d::UnitZ();
  for (ChartView& v : views)
    if ((v.R_cam_chart * Eigen::Vector3d(0, -1, 0)).dot(up_nominal) < 0)
      v.R_cam_chart = v.R_cam_chart * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();

  // Stations: runs of views that keep their pose.
  const auto min_span = static_cast<int64_t>(config.min_station_s * 1e6);
  const auto settle = static_cast<int64_t>(config.settle_s * 1e6);
  for (size_t i = 0; i < views.size();) {
    size_t j = i;
    while (j + 1 < views.size() &&
           rotationAngleDeg(views[i].R_cam_chart, views[j + 1].R_cam_chart) <= config.station_max_turn_deg &&
           (views[j + 1].centre_in_camera - views[i].centre_in_camera).norm() <= config.station_max_shift_m)
      ++j;
    if (views[j].utime - views[i].utime < min_span) {
      ++i;
      continue;
    }
    TiltStation st;
    st.begin_utime = views[i].utime;
    st.end_utime = views[j].utime;
    st.views = static_cast<int>(j - i + 1);
    for (size_t k = i; k <= j; ++k) st.up_in_camera += views[k].R_cam_chart * Eigen::Vector3d(0, -1, 0);
    st.up_in_camera.normalize();
    // The sensor's readings once it has settled, until the head is lifted again.
    Eigen::Vector2d sum = Eigen::Vector2d::Zero(), sum_sq = Eigen::Vector2d::Zero();
    for (const TiltReading& r : readings) {
      if (r.utime < st.begin_utime + settle || r.utime > st.end_utime - settle / 2) continue;
      const Eigen::Vector2d a(r.angle_x, r.angle_y);
      sum += a;
      sum_sq += a.cwiseProduct(a);
      ++st.readings;
    }
    if (st.readings >= config.min_readings) {
      const Eigen::Vector2d mean = sum / st.readings;
      st.measured_deg = mean / kDeg;
      st.spread_deg =
          ((sum_sq / st.readings - mean.cwiseProduct(mean)).cwiseMax(0.0) * st.readings / std::max(1, st.readings - 1))
              .cwiseSqrt() /
          kDeg;
      out.stations.push_back(st);
    }
    i = j + 1;
  }
  if (static_cast<int>(out.stations.size()) < config.min_stations) {
    char reason[160];
    std::snprintf(reason, sizeof reason,
                  "%zu static positions with the chart in view and tilt readings, need %d (hold the head still for "
                  "%g s at each)",
                  out.stations.size(), config.min_stations, config.min_station_s);
    out.reason = reason;
    return out;
  }

  // Gauss-Newton on the turn (about the sensor's x, y and, when the stations tell it, its vertical), numeric
  // derivatives: three parameters, a few stations.
  const size_t n = out.stations.size();
  auto residuals = [&](const Eigen::Vector3d& q) {
    Eigen::VectorXd r(2 * n);
    const Eigen::Matrix3d R = expSO3(q) * nominal;
    for (size_t k = 0; k < n; ++k)
      r.segment<2>(2 * k) = out.stations[k].measured_deg * kDeg - tiltAngles(R * out.stations[k].up_in_camera);
    return r;
  };
  struct Fit {
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  };
  auto fit = [&](int params) {
    Fit f;
    Eigen::MatrixXd J(2 * n, params);
    for (int iteration = 0; iteration < 20; ++iteration) {
      const Eigen::VectorXd r = residuals(f.p);
      const double h = 1e-7;
      for (int j = 0; j < params; ++j) {
        const Eigen::Vector3d dp = h * Eigen::Vector3d::Unit(j);
        J.col(j) = (residuals(f.p + dp) - residuals(f.p - dp)) / (2 * h);
      }
      const Eigen::VectorXd step = -(J.transpose() * J).ldlt().solve(J.transpose() * r);
      f.p.head(params) += step;
      if (step.norm() < 1e-12) break;
    }
    const Eigen::VectorXd r = residuals(f.p);
    // min_stations >= 2 keeps more residuals than parameters.
    const double floor = config.min_reading_sigma_deg * kDeg;
    const double variance =
        std::max(floor * floor, r.squaredNorm() / static_cast<double>(std::max<Eigen::Index>(1, r.size() - params)));
    f.covariance.topLeftCorner(params, params) = variance * (J.transpose() * J).inverse();
    return f;
  };
  Fit best = fit(3);
  out.vertical_estimated = std::sqrt(std::max(0.0, best.covariance(2, 2))) / kDeg <= config.max_vertical_sigma_deg;
  if (!out.vertical_estimated) best = fit(2);  // level stations: the turn about the vertical stays as designed
  const Eigen::VectorXd r = residuals(best.p);
  for (size_t k = 0; k < n; ++k) out.stations[k].residual_deg = r.segment<2>(2 * k) / kDeg;
  out.residual_rms_deg = std::sqrt(r.squaredNorm() / static_cast<double>(r.size())) / kDeg;
  out.sigma_deg = best.covariance.diagonal().cwiseMax(0.0).cwiseSqrt() / kDeg;
  out.angles_deg = best.p / kDeg;
  out.R_tilt_cam0 = expSO3(best.p) * nominal;
  out.ok = best.p.allFinite() && best.covariance.allFinite();
  if (!out.ok) out.reason = "the fit did not converge: the stations' tilts are too alike";
  return out;
}

}  // namespace ips::calib
