// The report page in a real browser: ips_report on the recordings of a short run whose content is known (a walk
// on a circle with ground truth, both filters with their covariance, tracker increments, health, three disparity
// maps with ground truth and their stereo pairs), then report.html loaded in headless Chromium. The page writes
// what it drew into #report-state; the test checks it against what the recordings hold: every chart drawn, every
// trajectory with all its poses, the disparity examples with their colour bars, the 3D cloud with the depth the
// disparity gives (f * B / d), and no console error. The screenshots (tools/report/render_pictures.sh) stay in
// the build tree (tests/report/report_page_screenshots/).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <ips/disparity_map_t.hpp>
#include <ips/filter_state_t.hpp>
#include <ips/ground_truth_t.hpp>
#include <ips/health_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <ips/tracker_delta_t.hpp>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>

#include "ips/calibration.hpp"
#include "ips/framework/log_writer.hpp"

namespace fs = std::filesystem;

namespace {

// The run: 12 s on a circle of 2 m radius, ground truth and filter states at 50 Hz, tracker at 10 Hz, health at
// 1 Hz, a disparity map with its ground truth at 3, 6 and 9 s.
constexpr int64_t kStartUs = 1'000'000, kEndUs = 13'000'000;
constexpr int64_t kStatePeriodUs = 20'000, kPairPeriodUs = 100'000;
constexpr int kWidth = 64, kHeight = 48;
constexpr double kFocalPx = 60, kBaselineM = 0.2;
constexpr double kDisparityPx = 8;  // everywhere, but for the invalid block
constexpr int kInvalidCols = 10;    // the left columns have no E3D disparity (as at a real map's border)
constexpr int kStateCount = static_cast<int>((kEndUs - kStartUs) / kStatePeriodUs) + 1;
constexpr int kDeltaCount = static_cast<int>((kEndUs - kStartUs) / kPairPeriodUs);
constexpr double kDriftMps = 0.02, kPositionSigmaM = 0.1;

Eigen::Isometry3d truthPose(int64_t utime) {
  const double t = (utime - kStartUs) * 1e-6, w = 2 * M_PI / 12.0, r = 2.0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(r * std::sin(w * t), r - r * std::cos(w * t), 1.5);
  T.linear() = Eigen::AngleAxisd(w * t, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

void toArrays(const Eigen::Isometry3d& T, double* p, double* q) {
  const Eigen::Quaterniond qq(T.linear());
  for (int i = 0; i < 3; ++i) p[i] = T.translation()[i];
  q[0] = qq.w(), q[1] = qq.x(), q[2] = qq.y(), q[3] = qq.z();
}

ips::disparity_map_t disparityMap(int64_t utime, int64_t seq, bool truth) {
  ips::disparity_map_t d{};
  d.utime = utime;
  d.seq = seq;
  d.width = kWidth;
  d.height = kHeight;
  d.subpixel_scale = 16;
  d.min_disparity = 0;
  d.num_disparities = 32;
  d.invalid_value = -1;
  d.focal_px = kFocalPx;
  d.cx = kWidth / 2.0;
  d.cy = kHeight / 2.0;
  d.baseline_m = kBaselineM;
  d.data.assign(kHeight, std::vector<int16_t>(kWidth, static_cast<int16_t>(kDisparityPx * 16)));
  if (!truth)
    for (auto& row : d.data) std::fill(row.begin(), row.begin() + kInvalidCols, d.invalid_value);
  d.confidence_size = 0;
  return d;
}

ips::stereo_pair_t stereoPair(int64_t utime, int64_t seq) {
  ips::stereo_pair_t p{};
  p.utime = utime;
  p.seq = seq;
  p.width = kWidth;
  p.height = kHeight;
  p.stride = kWidth;
  p.pixel_format = ips::stereo_pair_t::PIXEL_MONO8;
  p.data_size = kWidth * kHeight;
  p.left.resize(p.data_size);
  for (int i = 0; i < p.data_size; ++i) p.left[i] = static_cast<uint8_t>((i * 7) % 251);
  p.right = p.left;
  return p;
}

ips::StereoCalibration calibration() {
  ips::StereoCalibration c;
  for (auto* cam : {&c.cam0, &c.cam1}) {
    cam->width = kWidth;
    cam->height = kHeight;
    cam->K << kFocalPx, 0, kWidth / 2.0, 0, kFocalPx, kHeight / 2.0, 0, 0, 1;
  }
  c.t_cam1_cam0 = Eigen::Vector3d(-kBaselineM, 0, 0);
  c.source = "true";
  return c;
}

// Writes the run's recording and its input log (the stereo pairs) into `dir`.
void writeRun(const fs::path& dir) {
  ips::fw::LogWriter results((dir / "results.lcmlog").string());
  ips::fw::LogWriter input((dir / "walk.lcmlog").string());
  for (int64_t t = kStartUs; t <= kEndUs; t += kStatePeriodUs) {
    const Eigen::Isometry3d T = truthPose(t);
    ips::ground_truth_t g{};
    g.utime = t;
    toArrays(T, g.position, g.orientation);
    results.write("GT_POSE", t, g);
    // Both filters drift along x, with a covariance that claims 10 cm (position) and 1 deg (attitude) sigma.
    for (const auto& [channel, type] :
         {std::pair<std::string, int8_t>{"FILTER_STATE", int8_t{ips::filter_state_t::FILTER_EKF}},
          {"FILTER_STATE_UKF", int8_t{ips::filter_state_t::FILTER_UKF}}}) {
      ips::filter_state_t s{};
      s.utime = t;
      s.filter_type = type;
      s.up[2] = 1;
      toArrays(T, s.position, s.orientation);
      s.position[0] += kDriftMps * (t - kStartUs) * 1e-6;
      s.cov_dim = 21;
      s.covariance.assign(21, std::vector<double>(21, 0.0));
      for (int i = 0; i < 21; ++i)
        s.covariance[i][i] = i < 3 ? kPositionSigmaM * kPositionSigmaM : i >= 18 ? std::pow(M_PI / 180, 2) : 0.1;
      s.num_sensors = 0;
      results.write(channel, t, s);
    }
  }
  for (int k = 1; k <= kDeltaCount; ++k) {
    const int64_t t = kStartUs + k * kPairPeriodUs, prev = t - kPairPeriodUs;
    const Eigen::Isometry3d T_prev_now = truthPose(prev).inverse() * truthPose(t);  // camera 0 = body here
    ips::tracker_delta_t d{};
    d.utime = t;
    d.utime_prev = prev;
    d.seq = k;
    d.valid = true;
    const Eigen::Quaterniond q(T_prev_now.linear());
    for (int i = 0; i < 3; ++i) d.translation[i] = T_prev_now.translation()[i];
    d.rotation[0] = q.w(), d.rotation[1] = q.x(), d.rotation[2] = q.y(), d.rotation[3] = q.z();
    for (int i = 0; i < 6; ++i) d.covariance[i * 6 + i] = 1e-4;
    d.num_inter_matches = 200 + k % 30;
    d.num_inliers = 150 + k % 20;
    results.write("TRACKER_DELTA", t, d);
  }
  for (int64_t t = kStartUs + 1'000'000; t <= kEndUs; t += 1'000'000) {
    ips::health_t h{};
    h.utime = t;
    h.process = "tracker";
    h.host = "test";
    h.input_rate_hz = 10;
    h.output_rate_hz = 10;
    h.latency_ms = 12.5;
    h.received = (t - kStartUs) / kPairPeriodUs;
    h.published = h.received;
    h.num_counters = 0;
    results.write("HEALTH_TRACKER", t, h);
  }
  for (int64_t seq : {30, 60, 90}) {
    const int64_t t = kStartUs + seq * kPairPeriodUs;
    results.write("DISPARITY", t, disparityMap(t, seq, false));
    results.write("GT_DISPARITY", t, disparityMap(t, seq, true));
    input.write("STEREO", t, stereoPair(t, seq));
  }
}

std::string run(const std::string& cmd) {
  std::string out;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return out;
  char buf[65536];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  pclose(p);
  return out;
}

// The attributes of #report-state in the DOM headless Chromium ends with.
std::map<std::string, std::string> pageState(const fs::path& page) {
  const std::string dom = run(
      std::string(IPS_CHROMIUM) +
      " --headless=new --no-sandbox --user-data-dir=" + (page.parent_path() / "chromium-profile").string() +
      " --enable-unsafe-swiftshader --virtual-time-budget=20000 --dump-dom 'file://" + page.string() + "' 2>/dev/null");
  std::map<std::string, std::string> state;
  std::smatch div;
  if (!std::regex_search(dom, div, std::regex("<div id=\"report-state\"([^>]*)>"))) return state;
  const std::string attrs = div[1];
  const std::regex attr("(data-[a-z0-9-]+)=\"([^\"]*)\"");
  for (auto it = std::sregex_iterator(attrs.begin(), attrs.end(), attr); it != std::sregex_iterator(); ++it) {
    std::string v = (*it)[2];
    v = std::regex_replace(v, std::regex("&quot;"), "\"");
    v = std::regex_replace(v, std::regex("&amp;"), "&");
    state[(*it)[1]] = v;
  }
  return state;
}

// Width and height of a PNG file (its IHDR), or {0, 0}.
std::pair<int, int> pngSize(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char h[24] = {};
  in.read(reinterpret_cast<char*>(h), sizeof h);
  if (!in || h[1] != 'P' || h[2] != 'N' || h[3] != 'G') return {0, 0};
  auto be = [&](int at) { return (h[at] << 24) | (h[at + 1] << 16) | (h[at + 2] << 8) | h[at + 3]; };
  return {be(16), be(20)};
}

int count(const std::string& json, const std::string& name) {
  std::smatch m;
  if (!std::regex_search(json, m, std::regex("\"" + name + "\":([0-9]+)"))) return -1;
  return std::stoi(m[1]);
}

class ReportPage : public testing::Test {
 protected:
  void SetUp() override {
    if (std::system((std::string("command -v ") + IPS_CHROMIUM + " > /dev/null").c_str()) != 0)
      GTEST_SKIP() << IPS_CHROMIUM << " not installed (apt-get install chromium)";
    dir_ = fs::path(IPS_SCREENSHOT_DIR);
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    writeRun(dir_);
    ips::saveCalibration((dir_ / "walk.calib.yaml").string(), calibration());
    const std::string cmd = std::string(IPS_REPORT) + " --log " + (dir_ / "results.lcmlog").string() + " --images " +
                            (dir_ / "walk.lcmlog").string() + " --calib " + (dir_ / "walk.calib.yaml").string() +
                            " --out " + dir_.string() + " > " + (dir_ / "report.txt").string() + " 2>&1";
    const int status = std::system(cmd.c_str());
    ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "ips_report failed: see " << dir_ / "report.txt";
  }
  fs::path dir_;
};

TEST_F(ReportPage, ShowsWhatTheRecordingsHold) {
  const auto state = pageState(dir_ / "report.html");
  ASSERT_EQ(state.count("data-ready") ? state.at("data-ready") : "", "1") << "the page did not finish drawing";
  EXPECT_EQ(state.at("data-errors"), "[]") << "console errors on the page";
  // Top, side and end views, 3 position and 3 attitude error panels, NEES, tracker inliers, latency.
  EXPECT_EQ(state.at("data-charts-expected"), "12");
  EXPECT_EQ(state.at("data-charts-drawn"), "12");
  // Every pose of every estimator (fewer than the page's limit, so none left out).
  const std::string& traj = state.at("data-trajectory-points");
  EXPECT_EQ(count(traj, "ground truth"), kStateCount) << traj;
  EXPECT_EQ(count(traj, "EKF \\(FILTER_STATE\\)"), kStateCount) << traj;
  EXPECT_EQ(count(traj, "UKF \\(FILTER_STATE_UKF\\)"), kStateCount) << traj;
  EXPECT_EQ(count(traj, "tracker \\(camera 0, chained increments\\)"), kDeltaCount + 1) << traj;
  // Three examples, each the left image, E3D, truth and error map; colour bars beside the last three, with ticks.
  EXPECT_EQ(state.at("data-disparity-examples"), "3");
  EXPECT_EQ(state.at("data-disparity-images"), "12");
  EXPECT_EQ(state.at("data-colour-bars"), "9");
  EXPECT_GE(std::stoi(state.at("data-colour-bar-ticks")), 9 * 3);
  // The middle map triangulated: every valid pixel (the map is small, no subsampling) at depth f * B / d.
  EXPECT_EQ(state.at("data-webgl"), "1");
  EXPECT_EQ(std::stoi(state.at("data-cloud-points")), kHeight * (kWidth - kInvalidCols));
  EXPECT_NEAR(std::stod(state.at("data-cloud-median-depth")), kFocalPx * kBaselineM / kDisparityPx, 1e-3);
}

// The figures the page shows beside its charts: the filters' end error and position NEES against their analytic
// values (the drift d*t along x against sigma: NEES = (d*t/sigma)^2).
TEST_F(ReportPage, FilterFiguresMatchTheDrift) {
  std::ifstream in(dir_ / "report.json");
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string report = ss.str();
  double nees_sum = 0;
  for (int64_t t = kStartUs; t <= kEndUs; t += kStatePeriodUs)
    nees_sum += std::pow(kDriftMps * (t - kStartUs) * 1e-6 / kPositionSigmaM, 2);
  const double nees_mean = nees_sum / kStateCount, end_error = kDriftMps * (kEndUs - kStartUs) * 1e-6;
  const nlohmann::json filter = nlohmann::json::parse(report)["filters"][0];
  ASSERT_EQ(filter["channel"], "FILTER_STATE") << report;
  EXPECT_NEAR(filter["end_error_m"].get<double>(), end_error, 1e-4) << report;
  EXPECT_NEAR(filter["nees_position_mean"].get<double>(), nees_mean, 1e-3 * nees_mean) << report;
}

// The 3D view answers the mouse: a drag orbits the camera about its target, the wheel zooms (through chromedriver,
// as a user's input events; tests/report/report_page_orbit.py).
TEST_F(ReportPage, TheMapTurnsAndZoomsWithTheMouse) {
  if (std::system("/usr/bin/python3 -c 'import selenium' 2>/dev/null && test -x /usr/bin/chromedriver") != 0)
    GTEST_SKIP() << "python3-selenium or chromium-driver not installed";
  const std::string out =
      run("/usr/bin/python3 " + std::string(IPS_ORBIT_CHECK) + " --page " + (dir_ / "report.html").string() +
          " --screenshot " + (dir_ / "map_3d_turned.png").string() + " 2>&1; echo exit=$?");
  EXPECT_NE(out.find("exit=0"), std::string::npos) << out;
  EXPECT_NE(out.find("drag: camera"), std::string::npos) << out;
}

TEST_F(ReportPage, PicturesAreScreenshotsOfItsSections) {
  const std::string listed =
      run(std::string(IPS_RENDER_PICTURES) + " " + (dir_ / "report.html").string() + " " + dir_.string() + " 2>&1");
  const auto state = pageState(dir_ / "report.html");
  ASSERT_TRUE(state.count("data-sections")) << listed;
  const std::string& sections = state.at("data-sections");
  int pictures = 0;
  const std::regex section("\\{\"id\":\"([a-z0-9_]+)\",\"png\":\"([0-9]+)x([0-9]+)\"\\}");
  for (auto it = std::sregex_iterator(sections.begin(), sections.end(), section); it != std::sregex_iterator(); ++it) {
    const fs::path png = dir_ / ((*it)[1].str() + ".png");
    const auto [w, h] = pngSize(png);
    EXPECT_EQ(w, std::stoi((*it)[2])) << png << "\n" << listed;
    EXPECT_EQ(h, std::stoi((*it)[3])) << png;
    ++pictures;
  }
  // The main job's pictures by their names: figures, three trajectory views, errors, NEES, tracker, 3 disparity
  // examples, the 3D map.
  EXPECT_EQ(pictures, 11) << sections;
  for (const char* name : {"trajectory_top.png", "error_over_time.png", "disparity_30.png", "disparity_60.png",
                           "disparity_90.png", "map_3d.png"})
    EXPECT_TRUE(fs::exists(dir_ / name)) << name << "\n" << listed;
}

}  // namespace
