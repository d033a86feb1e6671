// Benchmark: the time to generate a scenario (default: the 2-minute walk at 8 Hz) with everything the batch
// mode computes except writing the log: both images of every pair, IMU and tilt samples, ground-truth poses.
// Run it alone (under the build lock) so the figures are not disturbed:
//   flock /tmp/ips-build.lock build/bin/sim_bench [--scenario FILE.yaml] [--duration SECONDS]
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <string>

#include "ips/args.hpp"
#include "ips/sim/rig.hpp"

int main(int argc, char** argv) {
  using Clock = std::chrono::steady_clock;
  auto seconds = [](Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); };
  try {
    ips::Args args(argc, argv, "the time to generate a scenario, without writing it");
    args.option("--scenario", "FILE.yaml", "scenario (default: the built-in 2-minute walk)")
        .option("--duration", "SECONDS", "simulated time (default: the scenario's trajectory)");
    if (!args.parse()) return 0;
    const std::string scenario_path = args.get("--scenario");
    double duration = args.has("--duration") ? args.getDouble("--duration") : -1;
    const auto t0 = Clock::now();
    const ips::sim::Scenario sc =
        scenario_path.empty() ? ips::sim::Scenario::defaults() : ips::sim::Scenario::load(scenario_path);
    const ips::sim::Rig rig(sc);
    const ips::sim::Trajectory& traj = rig.trajectory;
    const auto t1 = Clock::now();
    if (duration < 0) duration = traj.duration();
    const int64_t frames = static_cast<int64_t>(std::floor(duration * sc.camera.rate_hz)) + 1;
    ips::sim::ImuSimulator imu(sc.imu, traj, sc.start_utime, sc.seed);
    ips::sim::TiltSimulator tilt(sc.tilt, traj, rig.head.R_tilt_imu, sc.start_utime, sc.gravity, sc.seed);
    double render_s = 0, worst = 0, sensors_s = 0;
    uint64_t checksum = 0;
    const int64_t end_utime = sc.start_utime + static_cast<int64_t>(duration * 1e6);
    for (int64_t k = 0; k < frames; ++k) {
      const auto a = Clock::now();
      const ips::sim::StereoFrame f = rig.renderer.render(k);
      const auto b = Clock::now();
      render_s += seconds(a, b);
      worst = std::max(worst, seconds(a, b));
      checksum += static_cast<uint64_t>(cv::sum(f.left)[0]);
    }
    const auto c = Clock::now();
    int64_t imu_n = 0, tilt_n = 0;
    while (true) {
      const ips::sim::ImuMeasurement m = imu.next();
      if (m.utime_true > end_utime) break;
      (void)traj.state((m.utime_true - sc.start_utime) * 1e-6);  // ground truth at the sample
      ++imu_n;
    }
    while (tilt.next().utime_true <= end_utime) ++tilt_n;
    sensors_s = seconds(c, Clock::now());
    const double total = seconds(t0, Clock::now());
    std::cout << "scenario '" << sc.name << "': " << duration << " s simulated, " << frames << " stereo pairs "
              << sc.camera.width << "x" << sc.camera.height << " at " << sc.camera.rate_hz << " Hz, " << imu_n
              << " IMU, " << tilt_n << " tilt samples, " << rig.world.quads.size() << " quads\n";
    std::cout << "setup (world, textures, lens maps, rectification): " << seconds(t0, t1) << " s\n";
    std::cout << "rendering: " << render_s << " s = " << 1000 * render_s / frames << " ms per pair (worst "
              << 1000 * worst << " ms; real time at " << sc.camera.rate_hz << " Hz allows " << 1000 / sc.camera.rate_hz
              << " ms)\n";
    std::cout << "IMU + tilt + ground truth: " << sensors_s << " s\n";
    std::cout << "total generation: " << total << " s for " << duration << " s simulated = " << duration / total
              << " x real time (checksum " << checksum << ")\n";
  } catch (const ips::ArgError& e) {
    std::cerr << e.what() << "\n";  // names the program and the option
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "sim_bench: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
