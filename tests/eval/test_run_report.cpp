// The run report's sections called as functions on recordings and runs whose figures are known by construction: a
// filter 1 % long over a 10 m walk, a tracker chain of exact increments with one missing, a recorder restarted, a
// state stream that stops early, a process that lost IMU samples. (tests/report runs the ips_report program itself on
// damaged recordings.)
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <ips/ground_truth_t.hpp>
#include <ips/imu_sample_t.hpp>

#include "ips/eval/run_report.hpp"
#include "ips/framework/log_writer.hpp"
#include "ips/test_support/sample_messages.hpp"

namespace {

namespace ev = ips::eval;

// A walk along x at 1 m/s from t = 1 s, poses every 0.1 s for 10 s.
ev::Trajectory walk() {
  ev::Trajectory gt;
  for (int i = 0; i <= 100; ++i) {
    ev::TrajPoint p;
    p.t = 1.0 + 0.1 * i;
    p.p = Eigen::Vector3d(0.1 * i, 0, 0);
    gt.push_back(p);
  }
  return gt;
}

// A filter's state at `utime` at x along the x axis, level, its position sigma `sigma` per axis.
ips::filter_state_t state(int64_t utime, double x, double sigma) {
  ips::filter_state_t s{};
  s.utime = utime;
  s.position[0] = x;
  s.orientation[0] = 1;
  s.up[2] = 1;
  s.cov_dim = 3;
  s.covariance.assign(3, std::vector<double>(3, 0.0));
  for (int i = 0; i < 3; ++i) s.covariance[i][i] = sigma * sigma;
  return s;
}

ips::tracker_delta_t delta(int64_t utime, int64_t utime_prev, double x) {
  ips::tracker_delta_t d{};
  d.utime = utime;
  d.utime_prev = utime_prev;
  d.seq = utime / 100'000;
  d.valid = true;
  d.translation[0] = x;
  d.rotation[0] = d.far_rotation[0] = 1;
  for (int i = 0; i < 6; ++i) d.covariance[i * 7] = 1e-6;
  return d;
}

ips::health_t health(const std::string& process, const std::vector<std::pair<std::string, int64_t>>& counters) {
  return ips::test_support::healthWithCounters(11'000'000, process, counters);
}

std::string tempLog(const std::string& name) {
  return (std::filesystem::path(testing::TempDir()) / ("run_report_" + std::to_string(getpid()) + "_" + name)).string();
}

}  // namespace

TEST(RunReport, FiguresKeepSixDigitsAndWholeNumbersStayWhole) {
  EXPECT_EQ(ev::figure(0.00391712345).dump(), "0.00391712");
  EXPECT_EQ(ev::figure(2.0).dump(), "2");
  EXPECT_EQ(ev::figure(1403636579.763).dump(), "1403640000");
  EXPECT_TRUE(ev::figure(NAN).is_null());
  EXPECT_TRUE(ev::figure(INFINITY).is_null());
}

// The main recorder and a states' recorder restarted once: every channel read, in order, and the restart named.
TEST(RunReport, ReadsEveryRecorderAndNamesARestart) {
  const std::string results = tempLog("results.lcmlog"), states0 = tempLog("states.00"), states1 = tempLog("states.01");
  {
    ips::fw::LogWriter log(results);
    for (int64_t t = 1'100'000; t <= 2'000'000; t += 100'000) log.write("TRACKER_DELTA", t, delta(t, t - 100'000, 0.1));
    log.write("TRACKER_DELTA", 1'500'000, delta(1'500'000, 1'400'000, 0.1));  // a repeat: not counted again
    log.write("HEALTH_FILTER", 2'000'000, health("filter", {{"imu_seq_gap", 7}}));
  }
  for (const auto& [path, from] : {std::pair{states0, 1'000'000}, std::pair{states1, 1'600'000}}) {
    ips::fw::LogWriter log(path);
    for (int64_t t = from; t < from + 600'000; t += 100'000) {
      ips::ground_truth_t g{};
      g.utime = t;
      g.orientation[0] = 1;
      log.write("GT_POSE", t, g);
      log.write("FILTER_STATE", t, state(t, 0, 0.01));
    }
  }
  const ev::RunLog log = ev::readRunLog({{results}, {states0, states1}, {}}, {"FILTER_STATE", "FILTER_STATE_UKF"});
  EXPECT_EQ(log.deltas, 10);
  EXPECT_EQ(log.bad_messages, 1);
  ASSERT_EQ(log.runs.size(), 2u);
  EXPECT_EQ(log.runs[0].states.size(), 12u);
  EXPECT_TRUE(log.runs[1].states.empty());
  EXPECT_EQ(log.gt.size(), 12u);
  ASSERT_EQ(log.failures.size(), 1u);
  EXPECT_NE(log.failures[0].find("the states' recorder restarted (2 parts)"), std::string::npos) << log.failures[0];
  const std::vector<std::string> d = ev::disturbances(log);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0], "filter: 7 IMU samples lost on the way (imu_seq_gap)");
}

// States that stop 3 s before the input ends, and a player that says it did not reach the end of its log.
TEST(RunReport, StatesStoppingEarlyAndAnUnfinishedPlayerAreIncomplete) {
  ev::RunLog log;
  log.gt = walk();
  log.events = 200;
  log.last_input_log_us = log.last_log_us = 11'000'000;
  log.runs.push_back({"FILTER_STATE", 0, {}});
  for (int i = 0; i <= 70; ++i) log.runs[0].states.push_back(state(1'000'000 + 100'000 * i, 0.1 * i, 0.01));
  EXPECT_TRUE(ev::completenessFailures(log, "run", std::nullopt).size() == 1);
  log.procs["log_player"].last = health("log_player", {{"events_played", 80}, {"played_to_end", 0}});
  const std::vector<std::string> f = ev::completenessFailures(log, "run", 11'000'000);
  ASSERT_EQ(f.size(), 2u);
  EXPECT_NE(f[0].find("FILTER_STATE: states stop 3.0"), std::string::npos) << f[0];
  EXPECT_NE(f[1].find("before the player's account of the end of its log"), std::string::npos) << f[1];
  EXPECT_EQ(ev::runStatus(f, {}), "failed");
  EXPECT_EQ(ev::runStatus({}, {"a gap"}), "disturbed");
  EXPECT_EQ(ev::runStatus({}, {}), "ok");
}

// A filter that measures every metre as 1.01 m: after its first pose is put on the truth it ends 0.1 m off after
// 10 m (1 %); the SE(3)-aligned RMSE of a line stretched by 1 % is 1 % of the positions' spread about their mean
// (0.1 m * sqrt((101^2 - 1) / 12) = 2.9155 m); its sigma of 0.1 m gives a NEES of |e|^2 / 0.01.
TEST(RunReport, AFilterOnePercentLongIsOnePercentOff) {
  ev::RunLog log;
  log.gt = walk();
  log.runs.push_back({"FILTER_STATE", ips::filter_state_t::FILTER_EKF, {}});
  for (int i = 0; i <= 100; ++i) log.runs[0].states.push_back(state(1'000'000 + 100'000 * i, 0.101 * i, 0.1));
  const ev::FiltersSection s = ev::filtersSection(log, std::nullopt, std::nullopt, 1.0, 50);
  const ev::Json& f = s.json["filters"][0];
  EXPECT_EQ(f["filter"], "ekf");
  EXPECT_EQ(f["states"], 101);
  EXPECT_NEAR(f["end_error_m"].get<double>(), 0.1, 1e-6);
  EXPECT_NEAR(f["end_error_pct"].get<double>(), 1.0, 1e-4);
  EXPECT_NEAR(f["ate_rmse_m"].get<double>(), 0.029155, 2e-5);
  EXPECT_NEAR(f["tilt_error_start_mrad"].get<double>(), 0.0, 1e-9);
  // NEES = (0.001 i)^2 / 0.01 = 1e-4 i^2: inside [0.2158, 9.3484] for i = 47..305, so i = 47..100 of 101 states.
  EXPECT_NEAR(f["nees_position_in_95_band_pct"].get<double>(), 100.0 * 54 / 101, 1e-3);
  EXPECT_EQ(s.json["end_error_pct"], f["end_error_pct"]);
  ASSERT_EQ(s.results.size(), 1u);
  EXPECT_EQ(s.results[0].errors.t.size(), ev::subsample(101, 50).size());  // the page's samples
  EXPECT_NEAR(s.results[0].aligned.back().p.x(), 10.1, 1e-9);
}

// A filter whose heading drifts 0.5 mrad per state from the truth's while it claims 10 mrad (1 sigma) about the
// vertical (3 sigma 30.25 mrad): the error is inside it for states 0..60 of 0..100, and 50 mrad at the end.
TEST(RunReport, HeadingErrorIsJudgedAgainstItsOwnThreeSigma) {
  ev::RunLog log;
  log.gt = walk();
  log.runs.push_back({"FILTER_STATE", ips::filter_state_t::FILTER_EKF, {}});
  for (int i = 0; i <= 100; ++i) {
    ips::filter_state_t s = state(1'000'000 + 100'000 * i, 0.1 * i, 0.1);
    const Eigen::Quaterniond q(Eigen::AngleAxisd(0.0005 * i, Eigen::Vector3d::UnitZ()));
    s.orientation[0] = q.w(), s.orientation[3] = q.z();
    s.cov_dim = 21;
    s.covariance.assign(21, std::vector<double>(21, 0.0));
    for (int k = 0; k < 21; ++k) s.covariance[k][k] = k == 20 ? std::pow(0.03025 / 3, 2) : 0.01;
    log.runs[0].states.push_back(s);
  }
  const ev::FiltersSection s = ev::filtersSection(log, std::nullopt, std::nullopt, 1.0, 50);
  const ev::Json& f = s.json["filters"][0];
  EXPECT_NEAR(f["heading_error_max_deg"].get<double>(), 0.05 * 180 / M_PI, 1e-4);
  EXPECT_NEAR(f["heading_within_3sigma_pct"].get<double>(), 100.0 * 61 / 101, 1e-3);
}

// The filter's calibration estimates at its last state, each as "<name>_<unit>" and "<name>_sigma_<unit>": one
// dimension a number, more an array; the lever arm beside the truth's.
TEST(RunReport, CalibrationEstimatesAreNamedByTheirUnits) {
  ev::RunLog log;
  log.gt = walk();
  log.runs.push_back({"FILTER_STATE", ips::filter_state_t::FILTER_EKF, {}});
  for (int i = 0; i <= 100; ++i) log.runs[0].states.push_back(state(1'000'000 + 100'000 * i, 0.1 * i, 0.1));
  ips::filter_state_t& last = log.runs[0].states.back();
  last.calibration = {{"lever_arm", "m", 3, {0.11, 0.2, -0.05}, {0.01, 0.02, 0.03}},
                      {"delta_scale", "", 1, {0.004}, {0.001}},
                      {"delta_rotation_drift", "rad_per_m", 3, {1e-5, 0, 0}, {1e-5, 1e-5, 1e-5}}};
  last.num_calibration = 3;
  ips::StereoCalibration truth;
  truth.T_imu_cam0.translation() = Eigen::Vector3d(0.1, 0.2, -0.05);
  const ev::FiltersSection s = ev::filtersSection(log, truth, std::nullopt, 1.0, 50);
  const ev::Json& f = s.json["filters"][0];
  EXPECT_EQ(f["lever_arm_m"], ev::Json::array({0.11, 0.2, -0.05}));
  EXPECT_EQ(f["lever_arm_sigma_m"], ev::Json::array({0.01, 0.02, 0.03}));
  EXPECT_NEAR(f["lever_arm_error_m"][0].get<double>(), 0.01, 1e-9);
  EXPECT_EQ(f["lever_arm_error_m"][2].get<double>(), 0.0);
  EXPECT_EQ(f["delta_scale"], 0.004);
  EXPECT_EQ(f["delta_scale_sigma"], 0.001);
  EXPECT_EQ(f["delta_rotation_drift_rad_per_m"][0], 1e-5);
  EXPECT_EQ(f["delta_rotation_drift_sigma_rad_per_m"].size(), 3u);
  EXPECT_FALSE(f.contains("tilt_offset_rad"));
}

// The tracker's increments chained on camera 0 (here the body): exact ones follow the truth; one whose reference
// pair the recording lacks breaks the chain, which the section names.
TEST(RunReport, TrackerIncrementsAreChainedAndABreakIsNamed) {
  ev::RunLog log;
  log.gt = walk();
  for (int64_t t = 1'100'000; t <= 11'000'000; t += 100'000) log.delta_msgs.push_back(delta(t, t - 100'000, 0.1));
  ev::EstimatorsSection s = ev::estimatorsSection(log, Eigen::Isometry3d::Identity(), {1, 2});
  EXPECT_TRUE(s.warnings.empty());
  const ev::Json& tracker = s.json["estimators"][0];
  EXPECT_EQ(tracker["name"], "tracker");
  EXPECT_EQ(tracker["poses"], 101);
  EXPECT_LT(tracker["ate_rmse_m"].get<double>(), 1e-9);
  EXPECT_LT(tracker["end_error_m"].get<double>(), 1e-9);
  EXPECT_EQ(s.json["rpe_lengths_m"], ev::Json::array({1, 2}));

  log.delta_msgs.erase(log.delta_msgs.begin() + 50);  // the recorder lost one
  s = ev::estimatorsSection(log, Eigen::Isometry3d::Identity(), {1, 2});
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("the chain breaks 1 times in 99"), std::string::npos) << s.warnings[0];
}

// A disturbed run's counters and states, each just over or under the line at which the report names it: a filter
// that fused 80 of 100 valid deltas is named, one that fused 95 is not; a tracker that dropped 3 of its 100 pairs
// stale is named, its 4 pairs lost on the bus (under 5 %) are not; a recording without 2 of the states a filter
// published, and a position sigma that rose fivefold within a second, are named with the time.
TEST(RunReport, DisturbancesNameUnfusedDeltasStalePairsMissingStatesAndJumps) {
  ev::RunLog log;
  log.deltas = log.deltas_valid = 100;
  log.procs["filter"].last = health(
      "filter",
      {{"image_accepted", 50}, {"tracker_accepted", 80}, {"tracker_too_late", 15}, {"published_FILTER_STATE", 12}});
  log.procs["filter_ukf"].last =
      health("filter_ukf", {{"image_accepted", 50}, {"tracker_accepted", 95}, {"published_FILTER_STATE_UKF", 21}});
  log.procs["tracker"].last = health("tracker", {{"stale_pair", 3}, {"stereo_seq_gap", 4}});
  log.runs.push_back({"FILTER_STATE", 0, {}});
  for (int i = 0; i < 10; ++i) log.runs[0].states.push_back(state(1'000'000 + 100'000 * i, 0.1 * i, 0.01));
  log.runs.push_back({"FILTER_STATE_UKF", 0, {}});
  for (int i = 0; i <= 20; ++i)
    log.runs[1].states.push_back(state(1'000'000 + 100'000 * i, 0.1 * i, i < 10 ? 0.01 : 0.05));
  const std::vector<std::string> d = ev::disturbances(log);
  const std::vector<std::string> expected = {
      "filter: fused 80 of 100 valid tracker deltas (15 too late)",
      "tracker: dropped 3 of 100 pairs it fell behind on (stale_pair)",
      "FILTER_STATE: the recording holds 10 of the 12 states filter published",
      "FILTER_STATE_UKF: position sigma rose from 0.017 to 0.087 m within a second, at t=1.0 s of its states"};
  EXPECT_EQ(d, expected);
  EXPECT_EQ(ev::runStatus({}, d), "disturbed");
}

// The input log gives its truth's end and its valid IMU samples in time order; on the walk at constant speed the
// tracker's, the IMU's and the truth's second differences are all zero, and without an IMU the section is null.
TEST(RunReport, InputLogsImuGivesTheSpanNoise) {
  const std::string input = tempLog("input.lcmlog");
  {
    ips::fw::LogWriter log(input);
    for (int64_t t = 1'000'000; t <= 11'000'000; t += 5'000) {
      ips::imu_sample_t s{};
      s.utime = t;
      s.seq = t / 5'000;
      s.specific_force[2] = 9.81;  // level, no acceleration
      log.write("IMU", t, s);
      if (t == 2'000'000) log.write("IMU", t, s);  // a repeat: left out
      if ((t - 1'000'000) % 100'000 == 0) {
        ips::ground_truth_t g{};
        g.utime = t;
        g.orientation[0] = 1;
        log.write("GT_POSE", t, g);
      }
    }
    ips::imu_sample_t bad{};
    bad.utime = 11'005'000;
    bad.specific_force[0] = NAN;
    log.write("IMU", bad.utime, bad);
  }
  std::vector<std::string> failures;
  const ev::InputLog in = ev::readInputLog(input, failures);
  EXPECT_TRUE(failures.empty());
  EXPECT_EQ(in.truth_end_us, 11'000'000);
  ASSERT_EQ(in.imu.size(), 2001u);
  EXPECT_EQ(in.imu.back().utime, 11'000'000);

  ev::RunLog log;
  log.gt = walk();
  ips::StereoCalibration calib;
  calib.imu = ips::ImuDescription{};
  calib.imu->accel_noise_density = 2e-3;
  const ev::Json with_imu = ev::spanNoiseSection(log, in.imu, walk(), calib)["span_noise"];
  ASSERT_EQ(with_imu.size(), 4u);
  EXPECT_EQ(with_imu[0]["frames"], 1);
  EXPECT_EQ(with_imu[0]["centres"], 99);
  for (const auto& s : with_imu) {
    EXPECT_LT(s["tracker_vs_imu_mm"].get<double>(), 1e-6) << s.dump();
    EXPECT_LT(s["truth_vs_imu_mm"].get<double>(), 1e-6);
  }
  EXPECT_NEAR(with_imu[0]["imu_white_noise_mm"].get<double>(), 2e-3 * std::sqrt(2 * 0.1 * 0.1 * 0.1 / 3) * 1e3, 1e-6);
  EXPECT_TRUE(ev::spanNoiseSection(log, {}, walk(), calib)["span_noise"].is_null());
  std::filesystem::remove(input);
}
