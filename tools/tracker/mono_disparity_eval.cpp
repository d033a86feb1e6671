// Disparity from one camera (paper, section 6) on the simulated head: the left camera's images at frame k and k + g
// are rectified for their relative pose (polar rectification, ips/polar_rectification.hpp) and matched by the same
// SGM on Vulkan as the stereo pair; the map is scored against the simulator's truth beside E3D's stereo map of
// frame k, in the same run. The relative pose is the true one and, with --params, the tracker's own (its frame to
// frame motion chained over the g frames, IMU-aided as in the system), so the figure shows what a real pose costs.
//   mono_disparity_eval --e3d-config config/e3d_sim.yaml [--scenario config/sim_walk.yaml] [--gaps 1,2,4,8]
//                       [--every 80] [--duration S] [--params config/tracker.yaml] [--quiet 1]
// Per gap and pose: bad 2.0 (share of the masked pixels with a true disparity that are invalid or more than 2
// full-resolution px off, radially), density (valid share of the masked pixels), the share of the left image the
// mask keeps, and the median relative range error of the valid pixels.
// The last line: "mono: gap G bad2 B % density D % image I % (true pose)" for the gap with the lowest bad 2.0.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <opencv2/imgproc.hpp>

#include "ips/args.hpp"
#include "ips/eval/disparity.hpp"
#include "ips/eval/e3d_scorer.hpp"
#include "ips/eval/tracker_on_sim.hpp"
#include "ips/polar_rectification.hpp"
#include "ips/sim/mono_truth.hpp"
#include "ips/sim/rig.hpp"

using namespace ips;
using namespace ips::tracker;

namespace {

struct MonoScore {
  double bad2 = 0, density = 0, image_share = 0, range_err = 0;
  int maps = 0;
  void add(const MonoScore& s) {
    bad2 += s.bad2;
    density += s.density;
    image_share += s.image_share;
    range_err += s.range_err;
    ++maps;
  }
  MonoScore mean() const {
    MonoScore m = *this;
    if (maps) {
      m.bad2 /= maps;
      m.density /= maps;
      m.image_share /= maps;
      m.range_err /= maps;
    }
    return m;
  }
};

// Scores a polar disparity map (the matcher's CV_16S) inside P's mask.
MonoScore scoreMono(const PolarRectification& P, const cv::Mat& disparity, const cv::Mat& gt_disparity,
                    const cv::Mat& gt_range, cv::Size raw_size) {
  const cv::Mat d = eval::disparityPixels(disparity, e3d::kInvalidDisparity, e3d::kSubpixelScale);
  // Errors in raw-image pixels: one polar disparity step is P.dr of them.
  const eval::DisparityErrors e = eval::disparityErrors(d, gt_disparity, {eval::kBadDisparityPx}, P.valid, P.dr);
  std::vector<double> range_err;
  cv::Mat kept = cv::Mat::zeros(raw_size, CV_8U);
  for (int v = 0; v < d.rows; ++v)
    for (int u = 0; u < d.cols; ++u) {
      if (!P.valid.at<uint8_t>(v, u)) continue;
      const int x = static_cast<int>(std::lround(P.maps.map0x.at<float>(v, u)));
      const int y = static_cast<int>(std::lround(P.maps.map0y.at<float>(v, u)));
      if (x >= 0 && y >= 0 && x < raw_size.width && y < raw_size.height) kept.at<uint8_t>(y, x) = 1;
      const float dv = d.at<float>(v, u);
      if (!std::isfinite(gt_disparity.at<float>(v, u)) || !std::isfinite(dv)) continue;
      const Eigen::Vector3d X = P.triangulate(u, v, dv);
      const double range = (X - P.leftCentre()).norm();
      if (std::isfinite(range))
        range_err.push_back(std::abs(range - gt_range.at<float>(v, u)) / gt_range.at<float>(v, u));
    }
  MonoScore s;
  s.bad2 = e.badPct(0);
  s.density = e.densityPct();
  // The image share is of the pixels the masked polar pixels sample; the polar grid samples the outer image more
  // coarsely than one raw pixel, so it is counted on a grid of the polar steps' size.
  cv::Mat grown;
  const int step = std::max(1, static_cast<int>(std::ceil(P.dr)));
  cv::dilate(kept, grown, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * step + 1, 2 * step + 1)));
  s.image_share = 100.0 * cv::countNonZero(grown) / raw_size.area();
  if (!range_err.empty()) {
    std::nth_element(range_err.begin(), range_err.begin() + range_err.size() / 2, range_err.end());
    s.range_err = 100.0 * range_err[range_err.size() / 2];
  }
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    ips::Args args(argc, argv, "disparity from one camera on the simulated head, scored beside the stereo map");
    args.required("--e3d-config", "E3D.yaml", "E3D configuration, e.g. config/e3d_sim.yaml")
        .option("--scenario", "FILE.yaml", "scenario, e.g. config/sim_walk.yaml (default: built-in)")
        .option("--gaps", "G,G,..", "frame gaps between the two exposures", "1,2,4,8")
        .option("--every", "N", "scores every N-th frame", "80")
        .option("--duration", "SECONDS", "simulated time (default: the scenario's walk)")
        .option("--params", "TRACKER.yaml", "also with the tracker's own pose (its motion chained over the gap)")
        .option("--quiet", "0|1", "1: no line per frame, only the summaries", "0")
        .option("--vignetting-from", "CALIB.yaml",
                "the stereo map with the lenses' vignetting_gain of this calibration file (calibrate_vignetting's "
                "estimate) instead of the simulator's own")
        .flag("--no-flat-field",
              "the stereo map without the lenses' flat-field gain (vignetting_gain of a scenario with vignetting), "
              "as for a head whose vignetting is not calibrated");
    if (!args.parse()) return 0;
    const std::string scenario_path = args.get("--scenario");
    const sim::Scenario sc = scenario_path.empty() ? sim::Scenario::defaults() : sim::Scenario::load(scenario_path);
    const std::vector<int> gaps = parseIntList(args.get("--gaps"), "--gaps", 1);
    const int every = static_cast<int>(args.getInt("--every"));
    const bool quiet = args.get("--quiet") != "0";
    const sim::Rig rig(sc);
    const sim::SensorHead& head = rig.head;
    const double duration = args.has("--duration") ? args.getDouble("--duration") : rig.trajectory.duration();
    const sim::SceneRenderer scene(rig.world, sc.camera.near_m);
    const int64_t last_frame = static_cast<int64_t>(std::floor(duration * sc.camera.rate_hz));
    const int max_gap = *std::max_element(gaps.begin(), gaps.end());

    // The tracker's frame-to-frame motion (camera 0 now in camera 0 before), when asked for.
    std::map<int64_t, Eigen::Isometry3d> tracker_delta;
    if (args.has("--params")) {
      const TrackerParams params = loadTrackerParams(args.get("--params"));
      eval::runTrackerOnSimulation(scenario_path, duration, params, eval::SimPrior::Imu,
                                   [&](const eval::SimFrameError& e) {
                                     if (!e.result.valid) return;
                                     Eigen::Isometry3d d = Eigen::Isometry3d::Identity();
                                     d.linear() = e.result.rotation.toRotationMatrix();
                                     d.translation() = e.result.translation;
                                     tracker_delta[e.frame] = d;
                                   });
    }

    const Config e3d_cfg(args.get("--e3d-config"));
    const PolarRectificationParams polar_params =
        PolarRectificationParams::fromConfig(e3d_cfg.has("mono") ? e3d_cfg.section("mono") : e3d_cfg);
    const e3d::SgmParams sgm = e3d::SgmParams::fromConfig(e3d_cfg.has("sgm") ? e3d_cfg.section("sgm") : e3d_cfg);
    e3d::VulkanContext ctx;
    StereoCalibration stereo_calibration = head.calibration;
    if (args.has("--vignetting-from")) {
      const StereoCalibration estimated = loadCalibration(args.get("--vignetting-from"));
      stereo_calibration.cam0.vignetting_gain = estimated.cam0.vignetting_gain;
      stereo_calibration.cam1.vignetting_gain = estimated.cam1.vignetting_gain;
    }
    if (args.has("--no-flat-field"))
      stereo_calibration.cam0.vignetting_gain = stereo_calibration.cam1.vignetting_gain = Eigen::Vector3d::Zero();
    eval::E3dScorer stereo(stereo_calibration, args.get("--e3d-config"), &ctx);
    e3d::StereoMatcher mono(ctx, polar_params.size, sgm);
    const cv::Size raw_size(head.calibration.cam0.width, head.calibration.cam0.height);

    const auto cam_pose = [&](const sim::StereoFrame& f) {
      return head.cam0InWorld(rig.trajectory.pose((f.utime_true - sc.start_utime) * 1e-6));
    };
    double stereo_bad2 = 0, stereo_density = 0, stereo_depth_err = 0;
    int stereo_maps = 0;
    std::vector<double> mono_ms, stereo_ms, rectification_ms;
    std::map<int, MonoScore> by_gap_truth, by_gap_tracker;
    std::map<int, int> skipped;  // pose from the tracker missing over the gap
    for (int64_t k0 = every; k0 + max_gap <= last_frame; k0 += every) {
      const sim::StereoFrame fa = rig.renderer.render(k0, true);
      double depth_err = 0;
      const auto [bad2, density] = stereo.score(fa.left, fa.right, fa.gt_disparity, &depth_err);
      stereo_depth_err += depth_err;
      stereo_ms.push_back(stereo.lastMatchMs());
      stereo_bad2 += bad2;
      stereo_density += density;
      ++stereo_maps;
      const Eigen::Isometry3d W_a = cam_pose(fa);
      for (int g : gaps) {
        const sim::StereoFrame fb = rig.renderer.render(k0 + g);
        const Eigen::Isometry3d W_b = cam_pose(fb);
        std::vector<std::pair<std::string, Eigen::Isometry3d>> poses = {{"true", W_a.inverse() * W_b}};
        if (args.has("--params")) {
          Eigen::Isometry3d chained = Eigen::Isometry3d::Identity();
          bool whole = true;
          for (int64_t k = k0 + 1; k <= k0 + g && whole; ++k) {
            const auto it = tracker_delta.find(k);
            whole = it != tracker_delta.end();
            if (whole) chained = chained * it->second;
          }
          if (whole)
            poses.emplace_back("tracker", chained);
          else
            ++skipped[g];
        }
        for (const auto& [source, T_a_b] : poses) {
          const auto t0 = std::chrono::steady_clock::now();
          const PolarRectification P = polarRectification(head.calibration.cam0, T_a_b, polar_params);
          rectification_ms.push_back(
              std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
          mono.setRectification(P.maps, raw_size);
          const cv::Mat& left = P.left_is_b ? fb.left : fa.left;
          const cv::Mat& right = P.left_is_b ? fa.left : fb.left;
          const e3d::MatchOutput matched = mono.matchRaw(left, right);
          const cv::Mat& disparity = matched.disparity;
          mono_ms.push_back(matched.total_ms);
          cv::Mat gt, range;
          sim::polarDisparityTruth(P, scene, W_a, W_b, gt, range);
          const MonoScore s = scoreMono(P, disparity, gt, range, raw_size);
          (source == "true" ? by_gap_truth : by_gap_tracker)[g].add(s);
          if (!quiet)
            std::printf(
                "frame %lld gap %d (%s pose, baseline %.3f m, epipole %.0f %.0f): bad2 %.2f %% density %.2f %% "
                "image %.1f %% range error %.2f %% (stereo bad2 %.2f %% density %.2f %% depth error %.2f %%)\n",
                static_cast<long long>(k0), g, source.c_str(), T_a_b.translation().norm(), P.epipole.x(), P.epipole.y(),
                s.bad2, s.density, s.image_share, s.range_err, bad2, density, depth_err);
        }
      }
    }
    if (!stereo_maps) throw std::invalid_argument("no frame pairs: the run is shorter than --every plus the gaps");
    std::printf("stereo (E3D, frame k): bad2 %.2f %% density %.2f %% median depth error %.2f %% over %d maps\n",
                stereo_bad2 / stereo_maps, stereo_density / stereo_maps, stereo_depth_err / stereo_maps, stereo_maps);
    const auto median = [](std::vector<double> v) {
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      return v[v.size() / 2];
    };
    std::printf(
        "match time (median, upload to download): stereo %dx%d %.0f ms, one camera %dx%d %.0f ms (its maps "
        "on the CPU: %.0f ms)\n",
        stereo.size().width, stereo.size().height, median(stereo_ms), polar_params.size.width, polar_params.size.height,
        median(mono_ms), median(rectification_ms));
    int best_gap = gaps.front();
    for (int g : gaps) {
      for (const auto& [label, table] : {std::pair{"true", &by_gap_truth}, std::pair{"tracker", &by_gap_tracker}}) {
        if (!table->count(g)) continue;
        const MonoScore m = table->at(g).mean();
        std::printf(
            "gap %d (%s pose): bad2 %.2f %% density %.2f %% image %.1f %% median range error %.2f %% over %d "
            "maps\n",
            g, label, m.bad2, m.density, m.image_share, m.range_err, m.maps);
      }
      if (skipped.count(g)) std::printf("gap %d: %d pairs without the tracker's motion\n", g, skipped[g]);
      if (by_gap_truth[g].mean().bad2 < by_gap_truth[best_gap].mean().bad2) best_gap = g;
    }
    const MonoScore best = by_gap_truth[best_gap].mean();
    std::printf("mono: gap %d bad2 %.2f %% density %.2f %% image %.1f %% (true pose)\n", best_gap, best.bad2,
                best.density, best.image_share);
    return 0;
  } catch (const ips::ArgError& e) {
    std::cerr << e.what() << "\n";  // names the program and the option
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "mono_disparity_eval: " << e.what() << "\n";
    return 1;
  }
}
