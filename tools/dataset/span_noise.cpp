// span_noise: how large an estimate's, the ground truth's and the IMU's errors each are over spans of one to a few
// frame intervals, on a recording with IMU and ground truth (EuRoC, KITTI raw), by the three-cornered hat on second
// differences of the body's position (ips/eval/span_noise.hpp). It tells at which spans the IMU is better than the
// estimate (what a filter can take from it) and whether the truth is good enough at those spans to judge either.
//
//   span_noise --dataset DIR [--est trajectory_tracker.tum] [--spans 1,2,3,4,6,8] [--whole-recording]
//              [--keep-truth-steps]
//
// --est is camera 0's trajectory (ips_report's trajectory_tracker.tum, track_log's --out) over frames of DIR.
// Without it the spans are the truth's samples and the IMU is judged against the truth alone (their errors
// together), over the frames' span or, with --whole-recording, over all of an EuRoC recording's IMU and truth (a
// flight whose frames are only partly kept). Beside each span the data sheet's white noise alone (the head's
// accelerometer noise density): how far the IMU on this platform is from what the filters assume of it.
// One line per span; the last line: "spans=1,2,.. estimate_mm=.. imu_mm=.. truth_mm=.. truth_vs_imu_mm=..
// white_mm=.." (per axis, nan where the hat's variance is negative or there is no estimate).
#include "ips/eval/span_noise.hpp"

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "ips/args.hpp"
#include "ips/dataset/dataset.hpp"
#include "ips/framework/process.hpp"

int main(int argc, char** argv) {
  return ips::fw::guardedMain("span_noise", [&]() {
    ips::Args args(argc, argv,
                   "errors of an estimate, the ground truth and the IMU over short spans, none taken as the reference\n"
                   "(three-cornered hat on second differences of the body's position)");
    args.required("--dataset", "DIR", "the recording (EuRoC ASL or KITTI raw folder) with its IMU and ground truth")
        .option("--est", "FILE.tum",
                "camera 0's trajectory over the recording's frames (default: none, the IMU\n"
                "against the truth alone, at the truth's samples)",
                "")
        .option("--spans", "1,2,3",
                "half-widths of the second differences, in the estimate's samples (the truth's\n"
                "without one)",
                "1,2,3,4,6,8")
        .flag("--whole-recording", "EuRoC: the IMU and the truth of the whole recording, not only of its frames' span")
        .flag("--keep-truth-steps",
              "the ground truth's positions as recorded (default: its steps beyond 5 g over one\n"
              "sample are taken off the later positions, as ips_report does)");
    if (!args.parse()) return 0;
    const std::vector<int> spans = ips::parseIntList(args.get("--spans"), "--spans", 1);
    const std::string dir = args.get("--dataset");
    ips::dataset::ReadOptions options;
    options.whole_recording = args.getFlag("--whole-recording");
    const ips::dataset::Recording rec = ips::dataset::readRecording(ips::dataset::detectFormat(dir), dir, options);
    if (rec.imu.empty()) throw std::runtime_error(dir + ": the recording has no IMU");
    if (rec.ground_truth.empty()) throw std::runtime_error(dir + ": the recording has no ground truth");

    ips::eval::SpanNoiseInput in;
    for (const auto& g : rec.ground_truth) {
      ips::eval::TrajPoint p;
      p.t = g.utime * 1e-6;
      p.p = g.position;
      p.q = g.orientation;
      in.truth.push_back(p);
    }
    size_t steps = 0;
    if (!args.getFlag("--keep-truth-steps")) steps = ips::eval::removePositionSteps(in.truth).size();
    if (!args.get("--est").empty()) in.estimate = ips::eval::readTum(args.get("--est"));
    for (const auto& s : rec.imu) in.imu.push_back({s.utime, s.angular_rate, s.specific_force});
    in.T_imu_cam0 = rec.calib.T_imu_cam0;

    const std::vector<ips::eval::SpanNoise> result = ips::eval::spanNoise(in, spans);
    std::printf("%s: %zu truth step(s) removed; RMS per axis [mm] of second differences p(t+T) - 2 p(t) + p(t-T)\n",
                dir.c_str(), steps);
    // The data sheet's white accelerometer noise alone over each span: what the filters take the IMU to be.
    const double density = rec.calib.imu ? rec.calib.imu->accel_noise_density : NAN;
    std::printf("%6s %7s %7s | %10s %10s %10s | %8s %8s %8s | %8s | %26s | fitted accel bias [m/s^2], gravity error\n",
                "frames", "T [s]", "centres", "truth-est", "truth-imu", "est-imu", "truth", "estimate", "imu", "white",
                "truth-imu per world axis");
    std::string line_spans, line_est, line_imu, line_truth, line_truth_imu, line_white;
    auto num = [](double v) {
      char b[32];
      std::snprintf(b, sizeof b, "%.3f", v * 1e3);
      return std::string(b);
    };
    for (const auto& s : result) {
      const double white = ips::eval::imuWhiteNoiseSecondDifference(density, s.span_s);
      std::printf("%6d %7.3f %7zu | %10s %10s %10s | %8s %8s %8s | %8s | %8s %8s %8s | %.3f %.3f %.3f, %.3f\n",
                  s.span_frames, s.span_s, s.centres, num(s.truth_vs_estimate).c_str(), num(s.truth_vs_imu).c_str(),
                  num(s.estimate_vs_imu).c_str(), num(s.truth).c_str(), num(s.estimate).c_str(), num(s.imu).c_str(),
                  num(white).c_str(), num(s.truth_vs_imu_axes.x()).c_str(), num(s.truth_vs_imu_axes.y()).c_str(),
                  num(s.truth_vs_imu_axes.z()).c_str(), s.accel_bias.x(), s.accel_bias.y(), s.accel_bias.z(),
                  s.gravity_error);
      const std::string sep = line_spans.empty() ? "" : ",";
      line_spans += sep + std::to_string(s.span_frames);
      line_est += sep + num(s.estimate);
      line_imu += sep + num(s.imu);
      line_truth += sep + num(s.truth);
      line_truth_imu += sep + num(s.truth_vs_imu);
      line_white += sep + num(white);
    }
    std::printf("spans=%s estimate_mm=%s imu_mm=%s truth_mm=%s truth_vs_imu_mm=%s white_mm=%s\n", line_spans.c_str(),
                line_est.c_str(), line_imu.c_str(), line_truth.c_str(), line_truth_imu.c_str(), line_white.c_str());
    return 0;
  });
}
