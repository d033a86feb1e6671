// Per-stage timing of the stereo tracker on ONE core (cv::setNumThreads(1)), on full-size 1360x1024 pairs.
// Run it under the build lock so other builds do not disturb the figures:
//   flock /tmp/ips-build.lock build/bin/tracker_bench [--repeat N] [--width 1360 --height 1024] [--params P]
// Input: the EuRoC V1_01_easy frames (752x480, raw) resized to the requested size with the calibration
// scaled accordingly, so the tracker does the full work of a camera of that size (rectification, corners,
// matching, motion). Two cases:
//   sequence: the 20 consecutive mav0 frames, constant-velocity prior (normal 20/30 Hz tracking);
//   moving:   the two moving_pairs 0.5 s apart (0.32 m, 15.6 deg) without prior (wide window + guided pass).
// And, when built with ips_sim: the first --sim_frames (40) pairs of the simulated walk (--scenario, default
// config/sim_walk.yaml's built-in defaults): true 1360x1024 raw distorted images of the seed's head, 8 Hz.
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <vector>

#include "ips/args.hpp"
#include "ips/data_dir.hpp"
#include "ips/image_file.hpp"
#ifdef IPS_HAVE_SIM
#include "ips/eval/tracker_on_sim.hpp"
#endif
#include "ips/tracker/euroc_calibration.hpp"
#include "ips/tracker/stereo_tracker.hpp"

using namespace ips::tracker;

namespace {

struct Stats {
  std::vector<double> rectify, detect, intra, inter, motion, total;
  void add(const StageTimes& t) {
    rectify.push_back(t.rectify);
    detect.push_back(t.detect);
    intra.push_back(t.intra);
    inter.push_back(t.inter);
    motion.push_back(t.motion);
    total.push_back(t.total);
  }
};

void printRow(const char* name, std::vector<double> v) {
  if (v.empty()) return;
  std::sort(v.begin(), v.end());
  double mean = 0;
  for (double x : v) mean += x;
  mean /= double(v.size());
  std::printf("  %-8s mean %7.2f  median %7.2f  max %7.2f ms\n", name, mean, v[v.size() / 2], v.back());
}

void printStats(const char* title, const Stats& s) {
  std::printf("%s (%zu pairs)\n", title, s.total.size());
  printRow("rectify", s.rectify);
  printRow("detect", s.detect);
  printRow("intra", s.intra);
  printRow("inter", s.inter);
  printRow("motion", s.motion);
  printRow("total", s.total);
}

cv::Mat loadResized(const std::string& path, cv::Size size) {
  cv::Mat img = ips::loadGrey(path), out;
  cv::resize(img, out, size, 0, 0, cv::INTER_LINEAR);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    ips::Args args(argc, argv, "per-stage timing of the stereo tracker on one core, on full-size pairs");
    args.option("--repeat", "N", "repetitions of each case", "3")
        .option("--width", "W", "image width the frames are resized to", "1360")
        .option("--height", "H", "image height", "1024")
        .option("--params", "TRACKER.yaml", "tracker parameters (default: built-in)")
        .option("--data", "DIR", "the shared data (euroc/V1_01_easy)", ips::dataDir())
        .option("--scenario", "SIM.yaml", "simulated walk, when built with the simulator (default: built-in)")
        .option("--sim_frames", "N", "pairs of the simulated walk", "40");
    if (!args.parse()) return 0;
    const int repeat = static_cast<int>(args.getInt("--repeat"));
    const cv::Size size(static_cast<int>(args.getInt("--width")), static_cast<int>(args.getInt("--height")));
    const std::string euroc = args.get("--data") + "/euroc/V1_01_easy";
    const TrackerParams params = args.has("--params") ? loadTrackerParams(args.get("--params")) : TrackerParams();
    cv::setNumThreads(1);

    ips::StereoCalibration calib =
        calibrationFromEuroc(euroc + "/mav0/cam0/sensor.yaml", euroc + "/mav0/cam1/sensor.yaml");
    const double sx = double(size.width) / calib.cam0.width, sy = double(size.height) / calib.cam0.height;
    for (ips::CameraIntrinsics* c : {&calib.cam0, &calib.cam1}) {
      c->K.row(0) *= sx;
      c->K.row(1) *= sy;
      // Pixel centres scale as (u + 0.5), not u.
      c->K(0, 2) += 0.5 * (sx - 1.0);
      c->K(1, 2) += 0.5 * (sy - 1.0);
      c->width = size.width;
      c->height = size.height;
    }
    std::printf("tracker_bench: %dx%d, one thread, %d repetitions\n", size.width, size.height, repeat);

    std::vector<std::string> stamps;
    {
      std::ifstream csv(euroc + "/mav0/cam0/data.csv");
      std::string line;
      while (std::getline(csv, line))
        if (!line.empty() && line[0] != '#') stamps.push_back(line.substr(0, line.find(',')));
    }
    std::vector<cv::Mat> lefts, rights;
    for (const auto& s : stamps) {
      lefts.push_back(loadResized(euroc + "/mav0/cam0/data/" + s + ".png", size));
      rights.push_back(loadResized(euroc + "/mav0/cam1/data/" + s + ".png", size));
    }
    Stats seq;
    int seq_valid = 0, seq_pairs = 0;
    double features = 0, intra = 0, inliers = 0;
    for (int r = 0; r < repeat; ++r) {
      StereoTracker tracker(calib, params);
      for (size_t i = 0; i < lefts.size(); ++i) {
        const int64_t utime = int64_t(i) * 50000;
        TrackResult res = tracker.process(utime, lefts[i], rights[i]);
        if (i == 0) continue;
        seq.add(res.times);
        ++seq_pairs;
        seq_valid += res.valid;
        features += res.num_features;
        intra += res.num_intra_matches;
        inliers += res.num_inliers;
      }
    }
    printStats("sequence, constant-velocity prior", seq);
    std::printf("  valid %d/%d, mean features %.0f, intra matches %.0f, inliers %.0f\n", seq_valid, seq_pairs,
                features / seq_pairs, intra / seq_pairs, inliers / seq_pairs);

    Stats mov;
    const std::string mp = euroc + "/moving_pairs/";
    const cv::Mat l0 = loadResized(mp + "1403715400262142976_left.png", size),
                  r0 = loadResized(mp + "1403715400262142976_right.png", size),
                  l1 = loadResized(mp + "1403715400762142976_left.png", size),
                  r1 = loadResized(mp + "1403715400762142976_right.png", size);
    int mov_valid = 0;
    for (int r = 0; r < repeat; ++r) {
      StereoTracker tracker(calib, params);
      tracker.process(0, l0, r0);
      TrackResult res = tracker.process(500000, l1, r1);
      mov.add(res.times);
      mov_valid += res.valid;
    }
    printStats("moving pair 0.5 s, no prior (wide window + guided pass)", mov);
    std::printf("  valid %d/%d\n", mov_valid, repeat);
#ifdef IPS_HAVE_SIM
    {
      const int sim_frames = static_cast<int>(args.getInt("--sim_frames"));
      const ips::sim::Scenario sc =
          args.has("--scenario") ? ips::sim::Scenario::load(args.get("--scenario")) : ips::sim::Scenario::defaults();
      const ips::sim::Rig rig(sc);
      std::vector<ips::sim::StereoFrame> frames;
      for (int k = 0; k < sim_frames; ++k) frames.push_back(rig.renderer.render(k));
      cv::setNumThreads(1);  // the renderer may have changed it
      Stats sim;
      int sim_valid = 0;
      double sim_features = 0, sim_inliers = 0;
      for (int r = 0; r < repeat; ++r) {
        StereoTracker tracker(rig.head.calibration, params);
        for (size_t i = 0; i < frames.size(); ++i) {
          const TrackResult res = tracker.process(frames[i].utime_stamp, frames[i].left, frames[i].right);
          if (i == 0) continue;
          sim.add(res.times);
          sim_valid += res.valid;
          sim_features += res.num_features;
          sim_inliers += res.num_inliers;
        }
      }
      const double n = double(sim.total.size());
      std::printf("simulated walk %dx%d, constant-velocity prior\n", sc.camera.width, sc.camera.height);
      printStats("  sim", sim);
      std::printf("  valid %d/%zu, mean features %.0f, inliers %.0f\n", sim_valid, sim.total.size(), sim_features / n,
                  sim_inliers / n);
    }
#endif
    return 0;
  } catch (const ips::ArgError& e) {
    std::fprintf(stderr, "%s\n", e.what());  // names the program and the option
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tracker_bench: %s\n", e.what());
    return 1;
  }
}
