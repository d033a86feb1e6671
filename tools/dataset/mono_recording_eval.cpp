// Depth from one camera on a real recording (KITTI odometry, EuRoC): the left images of frame k and k + gap,
// polar-rectified for the recording's ground-truth relative pose and matched by E3D (MonoDepth, as the E3D process
// runs it), against E3D's stereo map of frame k in the same run. A real recording has no true depth; the stereo map
// (KITTI: 0.54 m baseline) is the reference, so the figure bounds both errors together: each point from one camera
// is projected into the stereo map of the same exposure, and its depth compared with the stereo depth there.
//   mono_recording_eval --data DIR --e3d-config config/e3d_recording.yaml [--sequence 06] [--gaps 1,2] [--every 5]
// The last line: "mono vs stereo: median depth difference D % over N points, within 5 %: W %" (the first gap).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "ips/args.hpp"
#include "ips/calibration.hpp"
#include "ips/config.hpp"
#include "ips/dataset/dataset.hpp"
#include "ips/e3d/mono_depth.hpp"
#include "ips/e3d/stereo_matcher.hpp"
#include "ips/e3d/vulkan_context.hpp"
#include "ips/pose_buffer.hpp"

namespace {

// Ground truth further apart than this is not interpolated between (EuRoC's is at 200 Hz, KITTI's per frame).
constexpr double kGroundTruthMaxGapS = 0.2;
// Points whose stereo and mono depth differ by less than this share agree.
constexpr double kAgreeShare = 0.05;

struct Comparison {
  std::vector<double> differences;  // |z_mono - z_stereo| / z_stereo
  int64_t points = 0;               // points from one camera, with a stereo depth or not
  double density_sum = 0;
  int maps = 0;
};

double median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  try {
    ips::Args args(argc, argv, "depth from one camera on a real recording, against E3D's stereo map of the same run");
    args.required("--data", "DIR", "KITTI odometry or EuRoC folder (with ground truth)")
        .required("--e3d-config", "E3D.yaml", "E3D configuration (sections sgm, process/output_scale, mono)")
        .option("--sequence", "NN", "KITTI sequence (default: the only one)")
        .option("--gaps", "G,G", "frame gaps between the two exposures", "1,2")
        .option("--every", "K", "a pair every K frames", "5");
    if (!args.parse()) return 0;
    ips::dataset::ReadOptions ro;
    if (args.has("--sequence")) ro.sequence = args.get("--sequence");
    const std::string dir = args.get("--data");
    const ips::dataset::Recording rec = ips::dataset::readRecording(ips::dataset::detectFormat(dir), dir, ro);
    if (rec.ground_truth.empty()) throw ips::ArgError(dir + ": the recording has no ground truth");
    const std::vector<int> gaps = ips::parseIntList(args.get("--gaps"), "--gaps", 1);
    const int every = static_cast<int>(args.getInt("--every"));
    if (every < 1) throw ips::ArgError("--every must be at least 1");

    ips::PoseBuffer truth(kGroundTruthMaxGapS, 1e9);
    for (const auto& g : rec.ground_truth) {
      ips::Pose p;
      p.utime = g.utime;
      p.T_world_body.linear() = g.orientation.toRotationMatrix();
      p.T_world_body.translation() = g.position;
      truth.add(p);
    }
    const auto cameraAt = [&](int64_t utime, Eigen::Isometry3d* T_world_cam) {
      ips::Pose p;
      if (truth.at(utime, &p) != ips::PoseBuffer::Lookup::kFound) return false;
      *T_world_cam = p.T_world_body * rec.calib.T_imu_cam0;
      return true;
    };

    const ips::Config cfg(args.get("--e3d-config"));
    const ips::e3d::SgmParams sgm = ips::e3d::SgmParams::fromConfig(cfg.has("sgm") ? cfg.section("sgm") : cfg);
    ips::e3d::MonoDepthParams mono_params =
        ips::e3d::MonoDepthParams::fromConfig(cfg.has("mono") ? cfg.section("mono") : cfg);
    mono_params.point_step = 1;  // every pixel is compared; the step only thins what goes on the bus
    const ips::StereoRectification rect =
        ips::scaledRectification(rec.calib, cfg.getDouble("process/output_scale", 1.0));
    const cv::Size raw(rec.calib.cam0.width, rec.calib.cam0.height);
    ips::e3d::VulkanContext ctx;
    ips::e3d::StereoMatcher stereo(ctx, rect.size, sgm);
    stereo.setRectification(rect, raw);
    ips::e3d::MonoDepth mono(ctx, rec.calib.cam0, sgm, mono_params);

    std::vector<Comparison> by_gap(gaps.size());
    const int max_gap = *std::max_element(gaps.begin(), gaps.end());
    for (size_t k = 0; k + max_gap < rec.frames.size(); k += every) {
      const ips::dataset::StereoFrame& fa = rec.frames[k];
      Eigen::Isometry3d W_a;
      if (!cameraAt(fa.utime, &W_a)) continue;
      const cv::Mat left_a = ips::dataset::loadImage(fa.left_path, raw.width, raw.height);
      const cv::Mat right_a = ips::dataset::loadImage(fa.right_path, raw.width, raw.height);
      const cv::Mat stereo_disparity = stereo.matchRaw(left_a, right_a).disparity;
      for (size_t gi = 0; gi < gaps.size(); ++gi) {
        const ips::dataset::StereoFrame& fb = rec.frames[k + gaps[gi]];
        Eigen::Isometry3d W_b;
        if (!cameraAt(fb.utime, &W_b)) continue;
        const cv::Mat left_b = ips::dataset::loadImage(fb.left_path, raw.width, raw.height);
        const ips::e3d::MonoDepthResult r = mono.compute(left_a, left_b, W_a.inverse() * W_b);
        if (!r.matched) continue;
        Comparison& c = by_gap[gi];
        const std::vector<double> here = ips::e3d::depthDifferences(r, rect, stereo_disparity);
        c.points += static_cast<int64_t>(r.points.size());
        c.density_sum += r.masked ? 100.0 * r.valid / r.masked : 0;
        ++c.maps;
        std::printf("frame %zu gap %d (%.2f m): %zu points, %zu with a stereo depth, median difference %.2f %%\n", k,
                    gaps[gi], r.baseline_m, r.points.size(), here.size(), 100 * median(here));
        c.differences.insert(c.differences.end(), here.begin(), here.end());
      }
    }
    for (size_t gi = 0; gi < gaps.size(); ++gi) {
      const Comparison& c = by_gap[gi];
      if (!c.maps) throw ips::ArgError("no pair with ground truth at both frames for gap " + std::to_string(gaps[gi]));
      const auto agree =
          std::count_if(c.differences.begin(), c.differences.end(), [](double x) { return x < kAgreeShare; });
      std::printf(
          "gap %d: %d maps, density %.1f %%, %lld points, %zu with a stereo depth: median depth difference "
          "%.2f %%, within 5 %%: %.1f %%\n",
          gaps[gi], c.maps, c.density_sum / c.maps, static_cast<long long>(c.points), c.differences.size(),
          100 * median(c.differences), 100.0 * agree / std::max<size_t>(1, c.differences.size()));
    }
    const Comparison& first = by_gap.front();
    const auto agree =
        std::count_if(first.differences.begin(), first.differences.end(), [](double x) { return x < kAgreeShare; });
    std::printf("mono vs stereo: median depth difference %.2f %% over %zu points, within 5 %%: %.1f %%\n",
                100 * median(first.differences), first.differences.size(),
                100.0 * agree / std::max<size_t>(1, first.differences.size()));
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mono_recording_eval: %s\n", e.what());
    return 1;
  }
}
