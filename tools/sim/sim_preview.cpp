// Writes one frame of a scenario as PNGs: raw left/right, rectified left/right and the ground-truth disparity
// (scaled for viewing), to look at the simulated world.
// Usage: sim_preview [--scenario FILE.yaml] [--seed N] [--time SECONDS] [--out PREFIX]
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "ips/args.hpp"
#include "ips/sim/rig.hpp"

int main(int argc, char** argv) {
  try {
    ips::Args args(
        argc, argv,
        "one frame of a scenario as PNGs: raw and rectified pair, ground-truth disparity (scaled for viewing)");
    args.option("--scenario", "FILE.yaml", "scenario (default: built-in)")
        .option("--seed", "N", "the scenario's seed instead of its own")
        .option("--time", "SECONDS", "time of the frame", "10")
        .option("--out", "PREFIX", "files PREFIX_left.png, PREFIX_right.png, ...", "sim_preview");
    if (!args.parse()) return 0;
    const std::string scenario_path = args.get("--scenario"), prefix = args.get("--out");
    const double time_s = args.getDouble("--time");
    const long long seed = args.has("--seed") ? args.getInt("--seed") : -1;
    ips::sim::Scenario sc =
        scenario_path.empty() ? ips::sim::Scenario::defaults() : ips::sim::Scenario::load(scenario_path);
    if (seed >= 0) sc.seed = static_cast<uint64_t>(seed);
    const ips::sim::Rig rig(sc);
    const int64_t k = std::llround(time_s * sc.camera.rate_hz);
    const ips::sim::StereoFrame f = rig.renderer.render(k, true);
    cv::Mat r0, r1, disp8;
    ips::rectifyPair(rig.renderer.rectification(), f.left, f.right, r0, r1);
    f.gt_disparity.convertTo(disp8, CV_8U, 1.0);
    cv::imwrite(prefix + "_left.png", f.left);
    cv::imwrite(prefix + "_right.png", f.right);
    cv::imwrite(prefix + "_rect_left.png", r0);
    cv::imwrite(prefix + "_rect_right.png", r1);
    cv::imwrite(prefix + "_gt_disparity.png", disp8);
    double mn, mx;
    cv::minMaxLoc(f.gt_disparity, &mn, &mx);
    std::cout << "frame " << k << " t=" << time_s << " s, " << rig.world.quads.size() << " quads, "
              << rig.world.photo_count << " photographs, disparity " << mn << ".." << mx << " px; wrote " << prefix
              << "_*.png\n";
  } catch (const ips::ArgError& e) {
    std::cerr << e.what() << "\n";  // names the program and the option
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "sim_preview: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
