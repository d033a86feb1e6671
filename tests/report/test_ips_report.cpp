// ips_report on recordings that went wrong (and on the map figures): a filter whose states stop before the input ends,
// a log truncated or full of garbage, an empty log, a 0x0 disparity map. The report must say so (status "failed", the
// reason under "failures", exit 4) instead of exiting 0 with figures over part of the run; nothing may crash.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <ips/disparity_map_t.hpp>
#include <ips/filter_state_t.hpp>
#include <ips/ground_truth_t.hpp>
#include <ips/health_t.hpp>
#include <ips/point_cloud_t.hpp>
#include <ips/tracker_delta_t.hpp>
#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "ips/calibration.hpp"
#include "ips/framework/log_writer.hpp"
#include "ips/mapper/voxel_map.hpp"
#include "ips/sim/scenario.hpp"
#include "ips/sim/world.hpp"
#include "ips/test_support/sample_messages.hpp"

namespace fs = std::filesystem;

namespace {

// The run's recording, as the logger writes it.
class Recording {
 public:
  explicit Recording(const std::string& path) : log_(path) {}
  template <class Msg>
  void add(const std::string& channel, int64_t utime, const Msg& m) {
    log_.write(channel, utime, m);
  }

 private:
  ips::fw::LogWriter log_;
};

ips::ground_truth_t pose(int64_t utime, double x) {
  ips::ground_truth_t g{};
  g.utime = utime;
  g.position[0] = x;
  g.orientation[0] = 1;
  return g;
}

ips::filter_state_t state(int64_t utime, double x) {
  ips::filter_state_t s{};
  s.utime = utime;
  s.position[0] = x;
  s.orientation[0] = 1;
  s.up[2] = 1;
  s.cov_dim = 0;
  return s;
}

// A walk along x at 1 m/s for 10 s: ground truth at 10 Hz, EKF states at 10 Hz until `states_until_us`, both
// until `played_until_us`.
// A run's recording: the input's truth to `played_until_us`, the filter's states to `states_until_us`, and, to
// `recorded_until_us`, what the processes go on publishing after the input (a marker of the recorder running).
void writeRun(const std::string& path, int64_t states_until_us, int64_t played_until_us = 11'000'000,
              int64_t recorded_until_us = 0) {
  Recording r(path);
  for (int64_t t = 1'000'000; t <= played_until_us; t += 100'000) {
    const double x = (t - 1'000'000) * 1e-6;
    r.add("GT_POSE", t, pose(t, x));
    if (t <= states_until_us) r.add("FILTER_STATE", t, state(t, x));
  }
  for (int64_t t = played_until_us + 1'000'000; t <= recorded_until_us; t += 1'000'000) {
    ips::health_t h{};
    h.utime = t;
    h.process = "tracker";
    h.host = "test";
    r.add("HEALTH_TRACKER", t, h);
  }
}

struct Result {
  int exit_code = -1;
  std::string report;  // report.json, empty if none
};

Result runReport(const std::string& log, const std::string& name, const std::string& more_args = "") {
  const fs::path out = fs::path(testing::TempDir()) / ("ips_report_" + std::to_string(getpid()) + "_" + name);
  fs::remove_all(out);
  fs::create_directories(out);
  const std::string cmd = std::string(IPS_REPORT) + " --log " + log + " --out " + out.string() + " " + more_args +
                          " > /dev/null 2>" + (out / "err").string();
  const int status = std::system(cmd.c_str());
  Result r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(out / "report.json");
  std::stringstream ss;
  ss << in.rdbuf();
  r.report = ss.str();
  return r;
}

std::string tempLog(const std::string& name) {
  return (fs::path(testing::TempDir()) / (std::to_string(getpid()) + "_" + name + ".lcmlog")).string();
}

TEST(IpsReport, CompleteRunIsOk) {
  const std::string log = tempLog("complete");
  writeRun(log, 11'000'000);
  const Result r = runReport(log, "complete");
  EXPECT_EQ(r.exit_code, 0) << r.report;
  EXPECT_NE(r.report.find("\"status\": \"ok\""), std::string::npos) << r.report;
}

// The report names the calibration the processes ran on, from the file's source; unspecified without one.
TEST(IpsReport, NamesTheCalibrationTheProcessesRanOn) {
  const std::string log = tempLog("calibration");
  writeRun(log, 11'000'000);
  EXPECT_NE(runReport(log, "no_calib").report.find("\"calibration_source\": \"unspecified\""), std::string::npos);
  ips::StereoCalibration truth;
  truth.cam0.width = truth.cam1.width = 64;
  truth.cam0.height = truth.cam1.height = 48;
  truth.t_cam1_cam0 = Eigen::Vector3d(-0.2, 0, 0);
  truth.source = "true";
  ips::StereoCalibration told = truth;
  told.source = "perturbed";
  const std::string truth_file = tempLog("truth") + ".calib.yaml", told_file = tempLog("told") + ".calib.yaml";
  ips::saveCalibration(truth_file, truth);
  ips::saveCalibration(told_file, told);
  const Result r = runReport(log, "calib", "--calib " + truth_file + " --process-calib " + told_file);
  EXPECT_EQ(r.exit_code, 0) << r.report;
  EXPECT_NE(r.report.find("\"calibration_source\": \"perturbed\""), std::string::npos) << r.report;
  EXPECT_NE(runReport(log, "true_calib", "--calib " + truth_file).report.find("\"calibration_source\": \"true\""),
            std::string::npos);
  EXPECT_NE(r.report.find("\"calibration_figures\": {}"), std::string::npos) << r.report;
  // An estimated calibration brings the tools' figures along (their numbers and words; lists left out).
  ips::StereoCalibration estimated = truth;
  estimated.source = "estimated";
  const std::string estimated_file = tempLog("estimated") + ".calib.yaml";
  ips::saveCalibration(estimated_file, estimated, [](cv::FileStorage& fs) {
    fs << "calibration_figures"
       << "{"
       << "rms_px" << 0.0424 << "lens_model"
       << "radial-tangential"
       << "views"
       << "["
       << "{"
       << "name"
       << "a"
       << "}"
       << "]"
       << "}";
    fs << "tilt_figures"
       << "{"
       << "stations" << 8 << "}";
  });
  const Result e = runReport(log, "estimated", "--calib " + truth_file + " --process-calib " + estimated_file);
  EXPECT_NE(e.report.find("\"calibration_source\": \"estimated\""), std::string::npos) << e.report;
  EXPECT_EQ(nlohmann::json::parse(e.report)["calibration_figures"],
            nlohmann::json::parse(R"({"calibration_figures": {"rms_px": 0.0424, "lens_model": "radial-tangential"},
                                      "tilt_figures": {"stations": 8}})"))
      << e.report;
}

TEST(IpsReport, StatesStoppingBeforeTheEndFailTheRun) {
  // The filter died at 6 s of a 10 s run: its last estimate must not pass for the run's end error.
  const std::string log = tempLog("stopped");
  writeRun(log, 6'000'000);
  const Result r = runReport(log, "stopped");
  EXPECT_EQ(r.exit_code, 4);
  EXPECT_NE(r.report.find("\"status\": \"failed\""), std::string::npos) << r.report;
  EXPECT_NE(r.report.find("FILTER_STATE: states stop"), std::string::npos) << r.report;
}

ips::health_t health(int64_t utime, const std::string& process,
                     const std::vector<std::pair<std::string, int64_t>>& counters) {
  return ips::test_support::healthWithCounters(utime, process, counters);
}

TEST(IpsReport, AnInputPlayedOnlyInPartFailsTheRunAndNamesWhoCutIt) {
  // The player's deputy was killed at 6 s: the recording is consistent in itself (states to the end of what
  // was played) but covers part of the input; the other processes go on reporting, and the recorder records them.
  const std::string input = tempLog("input"), partial = tempLog("partial"), whole = tempLog("whole");
  writeRun(input, 11'000'000);
  writeRun(partial, 6'000'000, 6'000'000, 11'000'000);
  writeRun(whole, 11'000'000);
  Result r = runReport(partial, "partial", "--images " + input + " --pictures 0");
  EXPECT_EQ(r.exit_code, 4);
  EXPECT_NE(r.report.find("the player stopped early"), std::string::npos) << r.report;
  r = runReport(whole, "whole", "--images " + input + " --pictures 0");
  EXPECT_EQ(r.exit_code, 0) << r.report;
  // The recorder's disk filled at 6 s: every channel ends at once, the player's account of its end is not in it.
  const std::string cut = tempLog("cut");
  {
    Recording rec(cut);
    for (int64_t t = 1'000'000; t <= 6'000'000; t += 100'000) {
      rec.add("GT_POSE", t, pose(t, (t - 1'000'000) * 1e-6));
      rec.add("FILTER_STATE", t, state(t, (t - 1'000'000) * 1e-6));
      if (t % 1'000'000 == 0) {
        rec.add("HEALTH_TRACKER", t, health(t, "tracker", {}));
        rec.add("HEALTH_LOG_PLAYER", t,
                health(t, "log_player", {{"events_played", t / 100'000}, {"played_to_end", 0}}));
      }
    }
  }
  r = runReport(cut, "cut", "--images " + input + " --pictures 0");
  EXPECT_EQ(r.exit_code, 4);
  EXPECT_NE(r.report.find("every channel at once: the recorder stopped (disk full, or killed), not the player"),
            std::string::npos)
      << r.report;
  EXPECT_EQ(r.report.find("the player stopped early"), std::string::npos) << r.report;
  EXPECT_EQ(r.report.find("says it did not play its log to the end"), std::string::npos) << r.report;
  r = runReport(cut, "cut_without_input");
  EXPECT_EQ(r.exit_code, 4);
  EXPECT_NE(r.report.find("before the player's account of the end of its log"), std::string::npos) << r.report;
}

// A complete run that lost IMU samples on the way, fused too few of the tracker's deltas, lost states on the way to
// its recorder and whose position sigma jumped: "disturbed" (exit 0), each disturbance named; a player whose last
// account does not say it reached the end of its log fails the run.
TEST(IpsReport, DisturbancesAreNamedAndAnUnfinishedPlayerFailsTheRun) {
  const std::string log = tempLog("disturbed");
  {
    Recording r(log);
    for (int64_t t = 1'000'000; t <= 11'000'000; t += 100'000) {
      const double x = (t - 1'000'000) * 1e-6;
      r.add("GT_POSE", t, pose(t, x));
      ips::filter_state_t s = state(t, x);
      s.cov_dim = 3;
      const double sigma = t < 6'000'000 ? 0.02 : 0.2;  // a reset at 6 s: 2 cm -> 20 cm at once
      s.covariance.assign(3, std::vector<double>(3, 0.0));
      for (int i = 0; i < 3; ++i) s.covariance[i][i] = sigma * sigma / 3;
      r.add("FILTER_STATE", t, s);
    }
    // 50 valid deltas of which the filter fused 40 (10 too late); it published 120 states, the recording holds 101.
    for (int64_t t = 1'100'000; t <= 6'000'000; t += 100'000) {
      ips::tracker_delta_t d{};
      d.utime = t;
      d.utime_prev = t - 100'000;
      d.seq = t / 100'000;
      d.valid = true;
      d.rotation[0] = d.far_rotation[0] = 1;
      for (int i = 0; i < 6; ++i) d.covariance[i * 7] = 1e-6;
      r.add("TRACKER_DELTA", t, d);
    }
    r.add("HEALTH_FILTER", 11'000'000,
          health(11'000'000, "filter",
                 {{"imu_seq_gap", 37},
                  {"image_accepted", 50},
                  {"tracker_accepted", 40},
                  {"tracker_too_late", 10},
                  {"published_FILTER_STATE", 120}}));
    // 40 pairs lost on the bus before the tracker, beside 100 received, and 3 it fell behind on; e3d skipping pairs
    // is no disturbance.
    r.add("HEALTH_TRACKER", 11'000'000, health(11'000'000, "tracker", {{"stereo_seq_gap", 40}, {"stale_pair", 3}}));
    r.add("HEALTH_E3D", 11'000'000, health(11'000'000, "e3d", {{"stereo_seq_gap", 40}}));
  }
  Result r = runReport(log, "disturbed");
  EXPECT_EQ(r.exit_code, 0) << r.report;
  EXPECT_NE(r.report.find("\"status\": \"disturbed\""), std::string::npos) << r.report;
  EXPECT_NE(r.report.find("filter: 37 IMU samples lost on the way (imu_seq_gap)"), std::string::npos) << r.report;
  EXPECT_NE(r.report.find("tracker: 40 pairs lost on the way (stereo_seq_gap)"), std::string::npos) << r.report;
  EXPECT_EQ(r.report.find("e3d: 40 pairs lost"), std::string::npos) << r.report;
  EXPECT_NE(r.report.find("tracker: dropped 3 of 100 pairs it fell behind on (stale_pair)"), std::string::npos)
      << r.report;
  EXPECT_NE(r.report.find("filter: fused 40 of 50 valid tracker deltas (10 too late)"), std::string::npos) << r.report;
  EXPECT_NE(r.report.find("FILTER_STATE: the recording holds 101 of the 120 states filter published"),
            std::string::npos)
      << r.report;
  EXPECT_NE(r.report.find("FILTER_STATE: position sigma rose from 0.020 to 0.200 m within a second, at t=5.0 s"),
            std::string::npos)
      << r.report;

  const std::string played = tempLog("played");
  {
    Recording rec(played);
    for (int64_t t = 1'000'000; t <= 11'000'000; t += 100'000) {
      rec.add("GT_POSE", t, pose(t, (t - 1'000'000) * 1e-6));
      rec.add("FILTER_STATE", t, state(t, (t - 1'000'000) * 1e-6));
    }
    rec.add("HEALTH_LOG_PLAYER", 11'000'000,
            health(11'000'000, "log_player", {{"events_played", 120}, {"played_to_end", 0}}));
    // The recorder goes on: the player stopped, not the recording.
    rec.add("HEALTH_TRACKER", 14'000'000, health(14'000'000, "tracker", {}));
  }
  r = runReport(played, "unfinished_player");
  EXPECT_EQ(r.exit_code, 4) << r.report;
  EXPECT_NE(r.report.find("says it did not play its log to the end"), std::string::npos) << r.report;
}

// A valid tracker delta from the pair 0.1 s before `utime`: `x` metres along x, no rotation; sigmas 1 mm, 0.1 mrad.
ips::tracker_delta_t step(int64_t utime, double x) {
  ips::tracker_delta_t d{};
  d.utime = utime;
  d.utime_prev = utime - 100'000;
  d.seq = utime / 100'000;
  d.valid = true;
  d.translation[0] = x;
  d.rotation[0] = 1;
  d.far_rotation[0] = 1;
  for (int i = 0; i < 3; ++i) d.covariance[i * 7] = 1e-6, d.covariance[(i + 3) * 7] = 1e-8;
  return d;
}

// The tracker's covariance and the filter's tilt judged against the truth: deltas 2 mm off (alternately ahead and
// behind) with a 1 mm sigma have a translation NEES of 4 and a lag-1 correlation of -1; exact rotations a rotation
// NEES of 0; a filter tilted 10 mrad about x has a tilt error of 10 mrad at its first and last state.
TEST(IpsReport, TheTrackersCovarianceAndTheFiltersTiltAreJudgedAgainstTheTruth) {
  const std::string log = tempLog("consistency");
  {
    Recording r(log);
    for (int64_t t = 1'000'000; t <= 11'000'000; t += 100'000) {
      const double x = (t - 1'000'000) * 1e-6;
      r.add("GT_POSE", t, pose(t, x));
      ips::filter_state_t s = state(t, x);
      s.orientation[0] = std::cos(0.005);
      s.orientation[1] = std::sin(0.005);
      r.add("FILTER_STATE", t, s);
      if (t != 1'000'000) r.add("TRACKER_DELTA", t, step(t, 0.1 + ((t / 100'000) % 2 ? 0.002 : -0.002)));
    }
  }
  const Result r = runReport(log, "consistency");
  ASSERT_FALSE(r.report.empty());
  const nlohmann::json j = nlohmann::json::parse(r.report);
  const nlohmann::json* tracker = nullptr;
  for (const auto& e : j.at("estimators"))
    if (e.at("name") == "tracker") tracker = &e;
  ASSERT_NE(tracker, nullptr) << r.report;
  EXPECT_NEAR(tracker->at("delta_nees_translation").get<double>(), 4.0, 1e-3) << r.report;
  EXPECT_NEAR(tracker->at("delta_nees_rotation").get<double>(), 0.0, 1e-6) << r.report;
  EXPECT_NEAR(tracker->at("delta_error_lag1_correlation").get<double>(), -1.0, 0.02) << r.report;
  const nlohmann::json& ekf = j.at("filters").at(0);
  EXPECT_NEAR(ekf.at("tilt_error_start_mrad").get<double>(), 10.0, 1e-3) << r.report;
  EXPECT_NEAR(ekf.at("tilt_error_end_mrad").get<double>(), 10.0, 1e-3) << r.report;
  EXPECT_EQ(r.report.find("the recording misses tracker deltas"), std::string::npos) << r.report;
}

// A filter in the start frame (output_frame start) whose start frame is pitched 10 mrad against the truth's level: its
// path since the start is right, and it says where the local vertical lies in its frame. Judged by its whole first pose
// it ends where the truth does, level; the same states claimed in the world frame end 1 % off, 10 mrad off level.
TEST(IpsReport, AFilterInTheStartFrameIsJudgedByItsWholeFirstPose) {
  const Eigen::Quaterniond tilt(Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitY()));
  for (const int8_t frame : {ips::filter_state_t::FRAME_START, ips::filter_state_t::FRAME_WORLD}) {
    const std::string name = frame == ips::filter_state_t::FRAME_START ? "start_frame" : "world_frame";
    const std::string log = tempLog(name);
    {
      Recording r(log);
      for (int64_t t = 1'000'000; t <= 11'000'000; t += 100'000) {
        const double x = (t - 1'000'000) * 1e-6;
        r.add("GT_POSE", t, pose(t, x));
        ips::filter_state_t s = state(t, 0);
        const Eigen::Vector3d p = tilt * Eigen::Vector3d(x, 0, 0);
        for (int k = 0; k < 3; ++k) s.position[k] = p[k];
        s.orientation[0] = tilt.w(), s.orientation[1] = tilt.x(), s.orientation[2] = tilt.y(),
        s.orientation[3] = tilt.z();
        s.frame = frame;
        const Eigen::Vector3d up = frame == ips::filter_state_t::FRAME_START ? tilt * Eigen::Vector3d::UnitZ()
                                                                             : Eigen::Vector3d::UnitZ().eval();
        for (int k = 0; k < 3; ++k) s.up[k] = up[k];
        r.add("FILTER_STATE", t, s);
      }
    }
    const Result r = runReport(log, name);
    ASSERT_FALSE(r.report.empty());
    const nlohmann::json j = nlohmann::json::parse(r.report);
    const nlohmann::json& ekf = j.at("filters").at(0);
    if (frame == ips::filter_state_t::FRAME_START) {
      EXPECT_LT(ekf.at("end_error_m").get<double>(), 1e-6) << r.report;
      EXPECT_LT(ekf.at("tilt_error_end_mrad").get<double>(), 1e-3) << r.report;
    } else {
      EXPECT_NEAR(ekf.at("end_error_m").get<double>(), 0.1, 1e-3) << r.report;
      EXPECT_NEAR(ekf.at("tilt_error_end_mrad").get<double>(), 10.0, 1e-3) << r.report;
    }
  }
}

// Deltas the recorder lost (its queue full beside a browser): the chain breaks where one is missing, and the run
// is "disturbed", the count named.
TEST(IpsReport, DeltasMissingFromTheRecordingAreNamed) {
  const std::string log = tempLog("lost_deltas");
  {
    Recording r(log);
    for (int64_t t = 1'000'000; t <= 11'000'000; t += 100'000) {
      const double x = (t - 1'000'000) * 1e-6;
      r.add("GT_POSE", t, pose(t, x));
      r.add("FILTER_STATE", t, state(t, x));
      // Two deltas lost on the way to the disk.
      if (t != 1'000'000 && t != 5'000'000 && t != 7'000'000) r.add("TRACKER_DELTA", t, step(t, 0.1));
    }
  }
  const Result r = runReport(log, "lost_deltas");
  EXPECT_EQ(r.exit_code, 0) << r.report;
  EXPECT_NE(r.report.find("\"status\": \"disturbed\""), std::string::npos) << r.report;
  EXPECT_NE(r.report.find("the recording misses tracker deltas: the chain breaks 2 times in 98"), std::string::npos)
      << r.report;
}

TEST(IpsReport, DamagedOrEmptyLogsFailTheRun) {
  const std::string log = tempLog("damaged");
  writeRun(log, 11'000'000);
  fs::resize_file(log, fs::file_size(log) - 7);  // the logger's disk filled mid-event
  Result r = runReport(log, "truncated");
  EXPECT_EQ(r.exit_code, 4);
  EXPECT_NE(r.report.find("damaged LCM log"), std::string::npos) << r.report;

  std::ofstream(log, std::ios::trunc) << "this is not an LCM log, just text that happens to be in the file";
  r = runReport(log, "garbage");
  EXPECT_EQ(r.exit_code, 4);
  EXPECT_NE(r.report.find("\"status\": \"failed\""), std::string::npos) << r.report;

  std::ofstream(log, std::ios::trunc).close();
  r = runReport(log, "empty");
  EXPECT_EQ(r.exit_code, 4);
  EXPECT_NE(r.report.find("holds none of a run"), std::string::npos) << r.report;

  r = runReport(tempLog("does_not_exist"), "missing");
  EXPECT_EQ(r.exit_code, 1);  // an error naming the file, no report
}

TEST(IpsReport, ARestartedRecorderFailsTheRun) {
  // lcm-logger -i after a restart: the recording comes in two parts, with a hole between them.
  const std::string a = tempLog("part.00"), b = tempLog("part.01");
  writeRun(a, 11'000'000);
  writeRun(b, 11'000'000);
  const Result r = runReport(a + "," + b, "parts");
  EXPECT_EQ(r.exit_code, 4);
  EXPECT_NE(r.report.find("the recorder restarted (2 parts)"), std::string::npos) << r.report;
}

// The main job's states at IMU rate on a recorder of their own (results_states.lcmlog) beside the navigation
// results': read together, one run; that recorder restarted fails the run as the first would.
TEST(IpsReport, TheStatesRecorderIsReadBesideTheResults) {
  const std::string results = tempLog("results"), states = tempLog("states.00"), again = tempLog("states.01");
  {
    Recording r(results);
    for (int64_t t = 1'100'000; t <= 11'000'000; t += 100'000) r.add("TRACKER_DELTA", t, step(t, 0.1));
  }
  writeRun(states, 11'000'000);
  writeRun(again, 11'000'000);
  Result r = runReport(results, "states_apart", "--states-log " + states);
  EXPECT_EQ(r.exit_code, 0) << r.report;
  ASSERT_FALSE(r.report.empty());
  const nlohmann::json j = nlohmann::json::parse(r.report);
  EXPECT_EQ(j.at("status"), "ok") << r.report;
  EXPECT_EQ(j.at("tracker_deltas"), 100) << r.report;
  EXPECT_EQ(j.at("filters").at(0).at("states"), 101) << r.report;
  r = runReport(results, "states_restarted", "--states-log " + states + "," + again);
  EXPECT_EQ(r.exit_code, 4);
  EXPECT_NE(r.report.find("the states' recorder restarted (2 parts)"), std::string::npos) << r.report;
}

TEST(IpsReport, EmptyDisparityMapIsCountedNotFatal) {
  const std::string log = tempLog("zero_map");
  writeRun(log, 11'000'000);
  {
    // Appended by a second writer: a 0x0 map, as a faulty e3d or a forged packet would publish.
    lcm::LogFile append(log, "a");
    ips::disparity_map_t d{};
    d.utime = 5'000'000;
    d.subpixel_scale = 16;
    std::vector<uint8_t> buf(static_cast<size_t>(d.getEncodedSize()));
    d.encode(buf.data(), 0, static_cast<int>(buf.size()));
    lcm::LogEvent e{};
    e.timestamp = 11'000'001;
    e.channel = "DISPARITY";
    e.datalen = static_cast<int32_t>(buf.size());
    e.data = buf.data();
    append.writeEvent(&e);
  }
  const Result r = runReport(log, "zero_map");
  EXPECT_EQ(r.exit_code, 0) << r.report;
  EXPECT_NE(r.report.find("\"bad_messages\": 1"), std::string::npos) << r.report;
}

}  // namespace

// The map figures: a map of points on the simulated world's surfaces (two thirds) and off them (a third, at
// least 10 cm from any surface), the filter's first pose on the truth's (so no alignment moves it), and the
// mapper's points of one wall seen early and again late 3 cm further: the report's keys say exactly that.
TEST(IpsReport, ScoresTheMapAgainstTheSimulatedWorld) {
  ips::sim::Scenario sc = ips::sim::Scenario::defaults();
  sc.seed = 1;
  const ips::sim::World world = ips::sim::World::build(sc.world, sc.seed);
  std::vector<Eigen::Vector3d> on, off;
  for (size_t q = 0; q < world.quads.size() && (on.size() < 100 || off.size() < 50); ++q) {
    const ips::sim::Quad& quad = world.quads[q];
    for (double f : {0.3, 0.6}) {
      const Eigen::Vector3d p = quad.origin + f * quad.size_s * quad.axis_s + 0.5 * quad.size_t * quad.axis_t;
      if (on.size() < 100) on.push_back(p);
      const Eigen::Vector3d away = p + 0.3 * quad.normal();
      if (off.size() < 50 && world.distanceToSurface(away) > 0.1) off.push_back(away);
    }
  }
  ASSERT_EQ(on.size(), 100u);
  ASSERT_EQ(off.size(), 50u);
  std::vector<Eigen::Vector3d> all = on;
  all.insert(all.end(), off.begin(), off.end());
  ips::mapper::VoxelMap map(1e-4, 1000000);  // voxels far smaller than the points' spacing: nothing fused
  map.insert(all, std::vector<uint8_t>(all.size(), 128), Eigen::Vector3d::Zero());
  ASSERT_EQ(map.size(), 150u);
  const std::string ply = (fs::path(testing::TempDir()) / (std::to_string(getpid()) + "_map.ply")).string();
  map.save(ply);

  const std::string log = tempLog("map");
  {
    Recording r(log);
    for (int64_t t = 1'000'000; t <= 11'000'000; t += 100'000) {
      const double x = (t - 1'000'000) * 1e-6;
      r.add("GT_POSE", t, pose(t, x));
      r.add("FILTER_STATE", t, state(t, x));
    }
    for (int64_t t : {2'000'000, 10'000'000}) {
      ips::point_cloud_t pc{};
      pc.utime = t;
      pc.frame = "world";
      for (int i = 0; i < 20; ++i)
        for (int j = 0; j < 20; ++j) pc.points.push_back({0.05f * i, t < 5'000'000 ? 3.0f : 3.03f, 0.05f * j});
      pc.num_points = static_cast<int32_t>(pc.points.size());
      pc.intensity.assign(pc.points.size(), 100);
      r.add("POINTS", t, pc);
    }
  }
  const Result r = runReport(log, "map", "--map " + ply + " --map-gt-poses " + ply + " --world-seed 1");
  ASSERT_EQ(r.exit_code, 0) << r.report;
  auto number = [&](const std::string& key) {
    const auto at = r.report.find("\"" + key + "\": ");
    EXPECT_NE(at, std::string::npos) << key << " missing in " << r.report;
    return at == std::string::npos ? NAN : std::stod(r.report.substr(at + key.size() + 4));
  };
  EXPECT_EQ(number("map_points"), 150);
  for (const std::string sfx : {"", "_gt_poses"}) {
    EXPECT_NEAR(number("map_median_surface_error_m" + sfx), 0.0, 1e-6) << sfx;
    EXPECT_GT(number("map_p90_surface_error_m" + sfx), 0.1) << sfx;
    EXPECT_NEAR(number("map_within_5cm_pct" + sfx), 100.0 * 100 / 150, 0.01) << sfx;
  }
  EXPECT_NEAR(number("map_consistency_median_m"), 0.03, 1e-4);
  EXPECT_NEAR(number("map_consistency_overlap_pct"), 100.0, 1e-6);
}
