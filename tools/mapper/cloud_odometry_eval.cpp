// Navigation aided by the dense cloud (paper section 6) on the simulated head: E3D's map (Vulkan; lavapipe without a
// GPU) of every n-th pair, placed as the mapper places it, aligned with the previous map by the mapper's
// CloudOdometry from a prior relative pose with a filter-like error, and compared with the true motion of camera 0.
//   cloud_odometry_eval [--scenario config/sim_walk.yaml] [--e3d-config config/e3d_sim.yaml]
//                       [--mapper-config config/mapper.yaml] [--every-nth 24] [--duration S] [--truth-disparity]
//                       [--prior-sigma-t 0.03] [--prior-sigma-r-deg 0.3] [--seed 1] [--csv FILE]
// --truth-disparity: the simulator's true disparity instead of E3D's (the alignment alone, no matching errors).
// The prior is the true relative pose with a random error of the given sigmas per axis, as the filter's drift over
// the maps' interval might be; the result must take it back to the truth.
// Last line: "cloud_odometry: valid V/N  translation rms T m (median Tm)  rotation rms R deg (median Rm)  prior T0 m R0
// deg nees E" (over the valid alignments; the prior's rms over the same ones).
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <opencv2/imgproc.hpp>
#include <random>

#include "ips/args.hpp"
#include "ips/calibration.hpp"
#include "ips/config.hpp"
#include "ips/e3d/sgm.hpp"
#include "ips/e3d/stereo_matcher.hpp"
#include "ips/e3d/vulkan_context.hpp"
#include "ips/mapper/cloud_odometry.hpp"
#include "ips/mapper/params.hpp"
#include "ips/mapper/stereo_points.hpp"
#include "ips/random_vector.hpp"
#include "ips/rotation.hpp"
#include "ips/sim/rig.hpp"

using namespace ips;

namespace {

// The measurement's error as the filter defines it: [t_est - t_true; Log(R_est R_true^T)].
Eigen::Matrix<double, 6, 1> errorOf(const Eigen::Isometry3d& est, const Eigen::Isometry3d& truth) {
  Eigen::Matrix<double, 6, 1> e;
  e << est.translation() - truth.translation(), logSO3(est.linear() * truth.linear().transpose());
  return e;
}

// E3D's int16 fixed-point disparity as the mapper receives it: pixels, NaN where invalid.
cv::Mat toPixels(const cv::Mat& fixed) {
  cv::Mat out(fixed.size(), CV_32F);
  for (int r = 0; r < fixed.rows; ++r)
    for (int c = 0; c < fixed.cols; ++c) {
      const int16_t v = fixed.at<int16_t>(r, c);
      out.at<float>(r, c) = v == e3d::kInvalidDisparity ? NAN : static_cast<float>(v) / e3d::kSubpixelScale;
    }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    Args args(argc, argv, "cloud_odometry_eval: E3D's maps aligned map to map against the simulator's truth");
    args.option("--scenario", "FILE", "simulated scenario", "config/sim_walk.yaml")
        .option("--e3d-config", "FILE", "E3D's settings (sgm, process/output_scale)", "config/e3d_sim.yaml")
        .option("--mapper-config", "FILE", "the mapper's settings (mapper, cloud_odometry)", "config/mapper.yaml")
        .option("--every-nth", "N", "a map every n-th pair, as E3D's process/every_nth", "24")
        .option("--duration", "S", "seconds of the scenario (default: all of it)")
        .flag("--truth-disparity", "the simulator's true disparity instead of E3D's")
        .option("--prior-sigma-t", "M", "error of the prior relative pose per axis [m]", "0.03")
        .option("--prior-sigma-r-deg", "DEG", "error of the prior relative rotation per axis [deg]", "0.3")
        .option("--seed", "N", "seed of the prior's errors", "1")
        .option("--csv", "FILE", "one line per map pair");
    if (!args.parse()) return 0;
    const sim::Scenario sc = sim::Scenario::load(args.get("--scenario"));
    const sim::Rig rig(sc);
    const double duration = args.has("--duration") ? args.getDouble("--duration") : rig.trajectory.duration();
    const int every_nth = static_cast<int>(args.getInt("--every-nth"));
    if (every_nth < 1) throw ArgError("--every-nth must be at least 1");
    const bool truth_disparity = args.getFlag("--truth-disparity");
    const double prior_t = args.getDouble("--prior-sigma-t");
    const double prior_r = args.getDouble("--prior-sigma-r-deg") * M_PI / 180;

    const Config mapper_cfg(args.get("--mapper-config"));
    const mapper::MapperParams mp = mapper::loadMapperParams(mapper_cfg);
    mapper::CloudOdometry odometry(mapper::CloudOdometryParams::fromConfig(mapper_cfg));
    const StereoCalibration& calib = rig.head.calibration;
    mapper::HeadGeometry geometry;
    geometry.R_rect0_cam0 = computeRectification(calib).R_rect0_cam0;
    geometry.T_body_cam0 = calib.T_imu_cam0;

    const Config e3d_cfg(args.get("--e3d-config"));
    const double scale = e3d_cfg.getDouble("process/output_scale", 1.0);
    const StereoRectification rect = truth_disparity ? computeRectification(calib) : scaledRectification(calib, scale);
    std::unique_ptr<e3d::VulkanContext> ctx;
    std::unique_ptr<e3d::StereoMatcher> matcher;
    if (!truth_disparity) {
      ctx = std::make_unique<e3d::VulkanContext>();
      matcher = std::make_unique<e3d::StereoMatcher>(
          *ctx, rect.size, e3d::SgmParams::fromConfig(e3d_cfg.has("sgm") ? e3d_cfg.section("sgm") : e3d_cfg));
      matcher->setRectification(rect, cv::Size(calib.cam0.width, calib.cam0.height));
    }

    std::mt19937 rng(static_cast<unsigned>(args.getInt("--seed")));
    std::normal_distribution<double> normal(0.0, 1.0);
    auto draw = [&](double s) -> Eigen::Vector3d { return s * ips::drawVector3([&] { return normal(rng); }); };
    std::ofstream csv;
    if (args.has("--csv")) {
      csv.open(args.get("--csv"));
      csv << "utime_prev,utime,valid,reason,points,overlap,rmse_m,err_t_m,err_r_deg,prior_err_t_m,prior_err_r_deg,"
             "sigma_t_max_m,nees\n";
    }

    const int64_t last = static_cast<int64_t>(std::floor(duration * sc.camera.rate_hz));
    Eigen::Isometry3d prev_true = Eigen::Isometry3d::Identity(), prev_placed = Eigen::Isometry3d::Identity();
    int pairs = 0, valid = 0;
    std::vector<double> errs_t, errs_r;
    double sum_t2 = 0, sum_r2 = 0, sum_prior_t2 = 0, sum_prior_r2 = 0, sum_nees = 0;
    for (int64_t k = 0; k <= last; k += every_nth) {
      const sim::StereoFrame f = rig.renderer.render(k, truth_disparity);
      const Eigen::Isometry3d T_world_body = rig.trajectory.pose((f.utime_true - sc.start_utime) * 1e-6);
      const Eigen::Isometry3d cam_true = rig.head.cam0InWorld(T_world_body);
      mapper::DisparityImage image;
      // The grey image rectified as the mapper does, for the points' texture (MapperParams::alignment_min_grey_spread).
      if (truth_disparity) {
        cv::remap(f.left, image.grey, rect.map0x, rect.map0y, cv::INTER_LINEAR);
        image.disparity = f.gt_disparity;
      } else {
        image.disparity = toPixels(matcher->matchRaw(f.left, f.right, &image.grey).disparity);
      }
      image.focal_px = rect.f, image.cx = rect.cx, image.cy = rect.cy, image.baseline_m = rect.baseline;
      // The map is placed with a pose whose change since the previous map has the prior's error, as the filter's.
      Eigen::Isometry3d placed = cam_true;
      if (k > 0) {
        Eigen::Isometry3d noisy_delta = prev_true.inverse() * cam_true;
        noisy_delta.linear() = expSO3(draw(prior_r)) * noisy_delta.linear();
        noisy_delta.translation() += draw(prior_t);
        placed = prev_placed * noisy_delta;
      }
      const Eigen::Isometry3d placed_body = placed * calib.T_imu_cam0.inverse();
      mapper::PointSet set = mapper::triangulate(image, geometry, placed_body, mp, true);
      const mapper::CloudDelta d =
          odometry.add(f.utime_stamp, set.alignment_points, placed, mp.disparity_sigma_px / (rect.f * rect.baseline));
      if (k > 0) {
        ++pairs;
        const Eigen::Isometry3d truth = prev_true.inverse() * cam_true;
        const Eigen::Matrix<double, 6, 1> e = errorOf(d.T_prev_now, truth), e0 = errorOf(d.prior, truth);
        const double nees = d.valid ? e.dot(d.covariance.ldlt().solve(e)) : NAN;
        if (d.valid) {
          ++valid;
          errs_t.push_back(e.head<3>().norm());
          errs_r.push_back(e.tail<3>().norm() * 180 / M_PI);
          sum_t2 += e.head<3>().squaredNorm();
          sum_r2 += e.tail<3>().squaredNorm();
          sum_prior_t2 += e0.head<3>().squaredNorm();
          sum_prior_r2 += e0.tail<3>().squaredNorm();
          sum_nees += nees;
        }
        const double sigma_t_max =
            std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(d.covariance.topLeftCorner<3, 3>())
                          .eigenvalues()
                          .maxCoeff());
        std::printf(
            "%6.1f s  %-24s points %6d overlap %.2f rmse %.4f m  err %.4f m %.3f deg  prior %.4f m %.3f deg  "
            "sigma_t max %.3f m  nees %.1f\n",
            (f.utime_true - sc.start_utime) * 1e-6, d.valid ? "valid" : d.reason.c_str(), d.points, d.overlap, d.rmse_m,
            e.head<3>().norm(), e.tail<3>().norm() * 180 / M_PI, e0.head<3>().norm(), e0.tail<3>().norm() * 180 / M_PI,
            sigma_t_max, nees);
        if (csv.is_open())
          csv << d.utime_prev << ',' << d.utime << ',' << d.valid << ',' << (d.valid ? "" : d.reason) << ',' << d.points
              << ',' << d.overlap << ',' << d.rmse_m << ',' << e.head<3>().norm() << ','
              << e.tail<3>().norm() * 180 / M_PI << ',' << e0.head<3>().norm() << ','
              << e0.tail<3>().norm() * 180 / M_PI << ',' << sigma_t_max << ',' << nees << '\n';
      }
      prev_true = cam_true;
      prev_placed = placed;
    }
    const double n = std::max(1, valid);
    auto median = [](std::vector<double> v) {
      if (v.empty()) return std::nan("");
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      return v[v.size() / 2];
    };
    std::printf(
        "cloud_odometry: valid %d/%d  translation rms %.4f m (median %.4f)  rotation rms %.3f deg (median "
        "%.3f)  prior %.4f m %.3f deg  nees %.2f\n",
        valid, pairs, std::sqrt(sum_t2 / n), median(errs_t), std::sqrt(sum_r2 / n) * 180 / M_PI, median(errs_r),
        std::sqrt(sum_prior_t2 / n), std::sqrt(sum_prior_r2 / n) * 180 / M_PI, sum_nees / n);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "cloud_odometry_eval: " << e.what() << "\n";
    return 1;
  }
}
