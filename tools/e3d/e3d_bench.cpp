// e3d_bench: speed of E3D on the Vulkan device beside OpenCV StereoSGBM (MODE_HH, 8 paths, and MODE_SGBM_3WAY,
// its fastest) on the same real pair scaled to 640x480 with 128 disparities, in the same run.
//   e3d_bench [--scene DIR] [--size 640x480] [--frames 20] [--opencv-frames 8] [--no-opencv] [--device D]
//             [SGM options]
//   e3d_bench --list-devices   (one line per Vulkan device: what the layout is chosen by, or why it is unusable)
// Prints fps, million disparity evaluations per second (W*H*D*fps/1e6), the per-stage device profile and the
// ratios; the last line is machine-readable key=value pairs (fps=, ratio_hh=, ratio_3way=, ...).
// Run it under the build lock so that other jobs do not disturb the figures.
#include <chrono>
#include <iomanip>
#include <iostream>
#include <map>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "ips/data_dir.hpp"
#include "ips/e3d/sgm_options.hpp"
#include "ips/e3d/stereo_matcher.hpp"
#include "ips/eval/disparity.hpp"
#include "ips/image_file.hpp"
#include "ips/log.hpp"

using namespace ips::e3d;

namespace {

double seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double benchOpenCv(const cv::Mat& left, const cv::Mat& right, int num_disparities, int mode, int frames) {
  auto sgbm = cv::StereoSGBM::create(0, num_disparities, 5, 8 * 25, 32 * 25, 1, 0, 10, 0, 0, mode);
  cv::Mat d;
  sgbm->compute(left, right, d);  // warm-up
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < frames; ++i) sgbm->compute(left, right, d);
  return frames / seconds(t0);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    ips::Args args(argc, argv,
                   "speed of E3D on the Vulkan device beside OpenCV StereoSGBM (MODE_HH and MODE_SGBM_3WAY) on the "
                   "same pair,\nwith 128 disparities unless --num-disparities is given");
    args.option("--scene", "DIR", "a scene with left.png and right.png", ips::dataPath("stereo/motorcycle_q"))
        .option("--size", "WxH", "the pair is scaled to this size", "640x480")
        .option("--frames", "N", "E3D matches timed", "20")
        .option("--opencv-frames", "N", "OpenCV matches timed, per mode", "8")
        .flag("--no-opencv", "E3D alone")
        .option("--device", "D", "Vulkan device (default: env IPS_VK_DEVICE, else the first)")
        .flag("--list-devices",
              "list the Vulkan devices (index, name, type, subgroup size, storage-buffer limits) and exit");
    addSgmOptions(args);
    if (!args.parse()) return 0;
    if (args.getFlag("--list-devices")) {
      ips::setLogLevel(ips::LogLevel::Warn);
      // What E3D's layout is chosen by on each device (tools/e3d/device_check.sh runs the tests and the benchmark on
      // each usable one).
      for (const auto& d : VulkanContext::listDevices()) {
        std::cout << "device=" << d.index << " type=" << d.type;
        try {
          const VulkanContext ctx(std::to_string(d.index));
          std::cout << " usable=1 subgroup_size=" << ctx.subgroupSize()
                    << " max_storage_buffer_mib=" << ctx.maxStorageBufferRange() / 1048576
                    << " storage_buffers_per_stage=" << ctx.maxStorageBuffersPerStage()
                    << " row_layout=" << (ctx.supportsRowLayout() ? 1 : 0);
        } catch (const std::exception& e) {
          std::cout << " usable=0 why=\"" << e.what() << "\"";
        }
        std::cout << " name=\"" << d.name << "\"\n";
      }
      return 0;
    }
    const std::string scene = args.get("--scene");
    cv::Size size;
    if (std::sscanf(args.get("--size").c_str(), "%dx%d", &size.width, &size.height) != 2)
      throw std::invalid_argument("--size needs WxH");
    const int frames = static_cast<int>(args.getInt("--frames"));
    const int cv_frames = static_cast<int>(args.getInt("--opencv-frames"));
    if (frames < 1 || cv_frames < 1) throw std::invalid_argument("--frames and --opencv-frames must be >= 1");
    SgmParams params = sgmParamsFromArgs(args);
    if (!args.has("--num-disparities")) params.num_disparities = 128;

    cv::Mat left, right;
    cv::resize(ips::loadGrey(scene + "/left.png"), left, size, 0, 0, cv::INTER_AREA);
    cv::resize(ips::loadGrey(scene + "/right.png"), right, size, 0, 0, cv::INTER_AREA);
    const double evals = double(size.area()) * params.num_disparities / 1e6;

    VulkanContext ctx(args.get("--device"));
    StereoMatcher matcher(ctx, size, params);
    matcher.match(left, right);  // warm-up (pipeline compilation happens at construction)
    std::map<std::string, double> stage_ms;
    std::vector<std::string> order;
    double device_ms = 0;
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < frames; ++i) {
      MatchOutput out = matcher.match(left, right);
      device_ms += out.device_ms;
      for (const auto& s : out.stages) {
        if (!stage_ms.count(s.name)) order.push_back(s.name);
        stage_ms[s.name] += s.ms;
      }
    }
    const double fps = frames / seconds(t0);
    std::cout << std::fixed << std::setprecision(2);
    std::cout << "device: " << ctx.info().name << " (" << ctx.info().type << ")\n"
              << "pair: " << scene << " scaled to " << size.width << "x" << size.height << ", " << params.describe()
              << "\nlayout: " << matcher.layoutDescription() << "\n"
              << "E3D           " << std::setw(7) << fps << " fps  " << std::setw(8) << evals * fps
              << " Mde/s  (device " << device_ms / frames << " ms/frame, memory "
              << matcher.deviceMemoryBytes() / 1048576.0 << " MiB)\n";
    for (const auto& name : order)
      std::cout << "  " << std::left << std::setw(10) << name << std::right << std::setw(8) << stage_ms[name] / frames
                << " ms\n";
    double fps_hh = 0, fps_3way = 0;
    if (!args.getFlag("--no-opencv")) {
      fps_hh = benchOpenCv(left, right, params.num_disparities, cv::StereoSGBM::MODE_HH, cv_frames);
      fps_3way = benchOpenCv(left, right, params.num_disparities, cv::StereoSGBM::MODE_SGBM_3WAY, cv_frames);
      std::cout << "OpenCV HH     " << std::setw(7) << fps_hh << " fps  " << std::setw(8) << evals * fps_hh
                << " Mde/s  E3D/HH   " << fps / fps_hh << "\n"
                << "OpenCV 3WAY   " << std::setw(7) << fps_3way << " fps  " << std::setw(8) << evals * fps_3way
                << " Mde/s  E3D/3WAY " << fps / fps_3way << "\n";
    }
    std::cout << "width=" << size.width << " height=" << size.height << " disparities=" << params.num_disparities
              << " paths=" << params.paths << " fps=" << fps << " mdeps=" << evals * fps
              << " device_ms=" << device_ms / frames << " fps_hh=" << fps_hh << " fps_3way=" << fps_3way
              << " ratio_hh=" << (fps_hh > 0 ? fps / fps_hh : 0)
              << " ratio_3way=" << (fps_3way > 0 ? fps / fps_3way : 0)
              << " memory_mib=" << matcher.deviceMemoryBytes() / 1048576.0 << "\n";
    return 0;
  } catch (const ips::ArgError& e) {
    std::cerr << e.what() << "\n";  // names the program and the option
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "e3d_bench: " << e.what() << "\n";
    return 1;
  }
}
