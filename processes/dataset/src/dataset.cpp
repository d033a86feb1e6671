#include "ips/dataset/dataset.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "ips/config.hpp"
#include "ips/image_file.hpp"
#include "ips/tracker/euroc_calibration.hpp"

namespace fs = std::filesystem;

namespace ips::dataset {

namespace {

[[noreturn]] void fail(const std::string& path, size_t line, const std::string& what) {
  throw DatasetError(path + (line ? ":" + std::to_string(line) : std::string()) + ": " + what);
}

// The lines of a text file with their 1-based numbers, skipping empty lines and '#' comments.
std::vector<std::pair<size_t, std::string>> dataLines(const std::string& path) {
  std::ifstream in(path);
  if (!in) fail(path, 0, "cannot open (missing file?)");
  std::vector<std::pair<size_t, std::string>> lines;
  std::string line;
  for (size_t n = 1; std::getline(in, line); ++n) {
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t')) line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    lines.emplace_back(n, line);
  }
  return lines;
}

// Splits on commas or white space; every field must be a whole number (integers) or a whole real.
std::vector<std::string> fields(const std::string& line, char sep) {
  std::vector<std::string> out;
  if (sep == ',') {
    std::stringstream ss(line);
    std::string f;
    while (std::getline(ss, f, ',')) {
      f.erase(0, f.find_first_not_of(" \t"));
      f.erase(f.find_last_not_of(" \t") + 1);
      out.push_back(f);
    }
  } else {
    std::istringstream ss(line);
    std::string f;
    while (ss >> f) out.push_back(f);
  }
  return out;
}

int64_t parseInt(const std::string& s, const std::string& path, size_t line) {
  try {
    size_t used = 0;
    const long long v = std::stoll(s, &used);
    if (used == s.size()) return v;
  } catch (const std::exception&) {
  }
  fail(path, line, "'" + s + "' is not an integer");
}

double parseReal(const std::string& s, const std::string& path, size_t line) {
  try {
    size_t used = 0;
    const double v = std::stod(s, &used);
    if (used == s.size() && std::isfinite(v)) return v;
  } catch (const std::exception&) {
  }
  fail(path, line, "'" + s + "' is not a number");
}

int64_t nsToUs(int64_t ns) { return (ns + 500) / 1000; }

// Frames [first, last] of n; throws when the range is empty.
std::pair<size_t, size_t> frameRange(size_t n, const ReadOptions& o, const std::string& what) {
  if (o.first < 0) throw DatasetError("--first must be >= 0");
  const int64_t last = o.last < 0 ? static_cast<int64_t>(n) - 1 : std::min<int64_t>(o.last, n - 1);
  if (o.first > last)
    throw DatasetError(what + ": no frames in [" + std::to_string(o.first) + ", " + std::to_string(o.last) +
                       "] (the recording has " + std::to_string(n) + ")");
  return {static_cast<size_t>(o.first), static_cast<size_t>(last)};
}

void requireIncreasing(int64_t prev, int64_t now, const std::string& path, size_t line) {
  if (now <= prev) fail(path, line, "time stamp " + std::to_string(now) + " not after the previous one");
}

// EuRoC camera list: "t_ns,filename".
std::vector<std::pair<int64_t, std::string>> readCameraCsv(const std::string& folder) {
  const std::string path = folder + "/data.csv";
  std::vector<std::pair<int64_t, std::string>> rows;
  int64_t prev = INT64_MIN;
  for (const auto& [n, line] : dataLines(path)) {
    const auto f = fields(line, ',');
    if (f.size() != 2 || f[1].empty()) fail(path, n, "expected 'timestamp_ns,filename'");
    const int64_t t = parseInt(f[0], path, n);
    requireIncreasing(prev, t, path, n);
    prev = t;
    rows.emplace_back(t, folder + "/data/" + f[1]);
  }
  if (rows.empty()) fail(path, 0, "no frames");
  return rows;
}

// A TUM file "t tx ty tz qx qy qz qw" (t in seconds).
std::vector<GroundTruthPose> readTumPoses(const std::string& path) {
  std::vector<GroundTruthPose> out;
  int64_t prev = INT64_MIN;
  for (const auto& [n, line] : dataLines(path)) {
    const auto f = fields(line, ' ');
    if (f.size() != 8) fail(path, n, "expected 't tx ty tz qx qy qz qw' (8 numbers), got " + std::to_string(f.size()));
    double v[8];
    for (int i = 0; i < 8; ++i) v[i] = parseReal(f[i], path, n);
    GroundTruthPose g;
    g.utime = std::llround(v[0] * 1e6);
    requireIncreasing(prev, g.utime, path, n);
    prev = g.utime;
    g.position = Eigen::Vector3d(v[1], v[2], v[3]);
    g.orientation = Eigen::Quaterniond(v[7], v[4], v[5], v[6]);
    if (std::fabs(g.orientation.norm() - 1.0) > 1e-2) fail(path, n, "quaternion is not of unit length");
    g.orientation.normalize();
    out.push_back(g);
  }
  return out;
}

// EuRoC's state_groundtruth_estimate0/data.csv: t_ns, p xyz, q wxyz, v xyz, bw xyz, ba xyz (the last three
// groups optional), or the same first 8 columns of the per-frame files.
std::vector<GroundTruthPose> readEurocStateCsv(const std::string& path) {
  std::vector<GroundTruthPose> out;
  int64_t prev = INT64_MIN;
  for (const auto& [n, line] : dataLines(path)) {
    const auto f = fields(line, ',');
    if (f.size() != 8 && f.size() != 17)
      fail(path, n, "expected 8 or 17 comma-separated columns, got " + std::to_string(f.size()));
    GroundTruthPose g;
    g.utime = nsToUs(parseInt(f[0], path, n));
    requireIncreasing(prev, g.utime, path, n);
    prev = g.utime;
    double v[16];
    for (size_t i = 1; i < f.size(); ++i) v[i - 1] = parseReal(f[i], path, n);
    g.position = Eigen::Vector3d(v[0], v[1], v[2]);
    g.orientation = Eigen::Quaterniond(v[3], v[4], v[5], v[6]);
    if (std::fabs(g.orientation.norm() - 1.0) > 1e-2) fail(path, n, "quaternion is not of unit length");
    g.orientation.normalize();
    if (f.size() == 17) {
      g.has_state = true;
      g.velocity = Eigen::Vector3d(v[7], v[8], v[9]);
      g.gyro_bias = Eigen::Vector3d(v[10], v[11], v[12]);
      g.accel_bias = Eigen::Vector3d(v[13], v[14], v[15]);
    }
    out.push_back(g);
  }
  return out;
}

// Keeps the samples covering [t0, t1] plus one on each side (for interpolation at the ends).
template <class T>
std::vector<T> window(const std::vector<T>& all, int64_t t0, int64_t t1) {
  auto lo = std::lower_bound(all.begin(), all.end(), t0, [](const T& s, int64_t t) { return s.utime < t; });
  auto hi = std::upper_bound(all.begin(), all.end(), t1, [](int64_t t, const T& s) { return t < s.utime; });
  if (lo != all.begin()) --lo;
  if (hi != all.end()) ++hi;
  return std::vector<T>(lo, hi);
}

// The ground truth of a groundtruth/ folder: every TUM file (*.txt) and EuRoC state file (*.csv) in it is read;
// the one that covers the frames' time span wins, among those the one with the most samples in it (V1_01's
// official file starts a second after the first frames, its re-estimated csv covers them; MH_01's 200 Hz TUM
// file beats the per-frame csv).
std::vector<GroundTruthPose> bestGroundTruthIn(const std::string& folder, int64_t t0, int64_t t1, std::string* source) {
  std::vector<std::string> candidates;
  for (const auto& e : fs::directory_iterator(folder))
    if (e.path().extension() == ".txt" || e.path().extension() == ".csv") candidates.push_back(e.path().string());
  std::sort(candidates.begin(), candidates.end());
  std::vector<GroundTruthPose> best;
  std::pair<bool, size_t> best_score{false, 0};
  for (const auto& path : candidates) {
    auto gt = fs::path(path).extension() == ".txt" ? readTumPoses(path) : readEurocStateCsv(path);
    if (gt.empty()) continue;
    const bool covers = gt.front().utime <= t0 && gt.back().utime >= t1;
    const size_t inside = static_cast<size_t>(
        std::count_if(gt.begin(), gt.end(), [&](const GroundTruthPose& g) { return g.utime >= t0 && g.utime <= t1; }));
    if (best.empty() || std::make_pair(covers, inside) > best_score) {
      best = std::move(gt);
      best_score = {covers, inside};
      *source = path;
    }
  }
  return best;
}

}  // namespace

std::string detectFormat(const std::string& dir) {
  if (fs::exists(dir + "/mav0/cam0/data.csv")) return "euroc";
  if (fs::is_directory(dir + "/sequences")) return "kitti";
  throw DatasetError(dir +
                     ": neither an EuRoC ASL folder (mav0/cam0/data.csv) nor a KITTI odometry folder "
                     "(sequences/)");
}

Recording readEuroc(const std::string& dir, const ReadOptions& options) {
  Recording rec;
  rec.format = "euroc";
  const std::string mav = dir + "/mav0";
  try {
    rec.calib = tracker::calibrationFromEuroc(mav + "/cam0/sensor.yaml", mav + "/cam1/sensor.yaml");
  } catch (const ConfigError& e) {
    throw DatasetError(e.what());
  }
  const auto left = readCameraCsv(mav + "/cam0"), right = readCameraCsv(mav + "/cam1");
  // Both cameras are triggered together: the lists must name the same instants.
  if (left.size() != right.size())
    fail(mav + "/cam1/data.csv", 0, std::to_string(right.size()) + " frames, cam0 has " + std::to_string(left.size()));
  for (size_t i = 0; i < left.size(); ++i)
    if (left[i].first != right[i].first)
      fail(mav + "/cam1/data.csv", 0,
           "frame " + std::to_string(i) + " stamped " + std::to_string(right[i].first) + ", cam0's " +
               std::to_string(left[i].first));
  const auto [first, last] = frameRange(left.size(), options, mav + "/cam0/data.csv");
  for (size_t i = first; i <= last; ++i) {
    if (!fs::exists(left[i].second)) fail(left[i].second, 0, "image listed in data.csv is missing");
    if (!fs::exists(right[i].second)) fail(right[i].second, 0, "image listed in data.csv is missing");
    rec.frames.push_back({nsToUs(left[i].first), static_cast<int64_t>(i), left[i].second, right[i].second});
  }
  const int64_t t0 = rec.frames.front().utime, t1 = rec.frames.back().utime;

  const std::string imu_path = mav + "/imu0/data.csv";
  if (fs::exists(imu_path)) {
    std::vector<ImuSample> all;
    int64_t prev = INT64_MIN;
    for (const auto& [n, line] : dataLines(imu_path)) {
      const auto f = fields(line, ',');
      if (f.size() != 7) fail(imu_path, n, "expected 't_ns, gyro xyz, accel xyz' (7 columns)");
      ImuSample s;
      s.utime = nsToUs(parseInt(f[0], imu_path, n));
      requireIncreasing(prev, s.utime, imu_path, n);
      prev = s.utime;
      for (int a = 0; a < 3; ++a) {
        s.angular_rate[a] = parseReal(f[1 + a], imu_path, n);
        s.specific_force[a] = parseReal(f[4 + a], imu_path, n);
      }
      all.push_back(s);
    }
    rec.imu = window(all, t0, t1);
  }

  // Ground truth: --gt (TUM), else the ASL state estimate, else the best file in groundtruth/.
  std::vector<GroundTruthPose> gt;
  if (!options.gt_path.empty()) {
    rec.ground_truth_source = options.gt_path;
    gt = readTumPoses(options.gt_path);
  } else if (fs::exists(mav + "/state_groundtruth_estimate0/data.csv")) {
    rec.ground_truth_source = mav + "/state_groundtruth_estimate0/data.csv";
    gt = readEurocStateCsv(rec.ground_truth_source);
  } else if (fs::is_directory(dir + "/groundtruth")) {
    gt = bestGroundTruthIn(dir + "/groundtruth", t0, t1, &rec.ground_truth_source);
  }
  rec.ground_truth = window(gt, t0, t1);
  return rec;
}

Recording readKitti(const std::string& dir, const ReadOptions& options) {
  Recording rec;
  rec.format = "kitti";
  std::string seq = options.sequence;
  if (seq.empty()) {
    std::vector<std::string> names;
    if (fs::is_directory(dir + "/sequences"))
      for (const auto& e : fs::directory_iterator(dir + "/sequences"))
        if (e.is_directory()) names.push_back(e.path().filename().string());
    if (names.size() != 1)
      throw DatasetError(dir + "/sequences: " + std::to_string(names.size()) +
                         " sequence folders; name one with --sequence NN");
    seq = names.front();
  }
  const std::string sdir = dir + "/sequences/" + seq;
  if (!fs::is_directory(sdir)) fail(sdir, 0, "sequence folder missing");

  // calib.txt: "P0: 12 numbers" ... rectified projection matrices, P1 = K [I | -B e_x] * f.
  const std::string calib_path = sdir + "/calib.txt";
  std::map<std::string, Eigen::Matrix<double, 3, 4>> P;
  for (const auto& [n, line] : dataLines(calib_path)) {
    const auto f = fields(line, ' ');
    if (f.empty() || f[0].back() != ':') fail(calib_path, n, "expected 'NAME: values'");
    if (f.size() != 13) fail(calib_path, n, f[0] + " needs 12 numbers");
    Eigen::Matrix<double, 3, 4> m;
    for (int i = 0; i < 12; ++i) m(i / 4, i % 4) = parseReal(f[1 + i], calib_path, n);
    P[f[0].substr(0, f[0].size() - 1)] = m;
  }
  if (!P.count("P0") || !P.count("P1")) fail(calib_path, 0, "P0 and P1 are needed");
  const Eigen::Matrix<double, 3, 4>&P0 = P["P0"], &P1 = P["P1"];
  if (P0(0, 0) <= 0 || (P0.leftCols<3>() - P1.leftCols<3>()).norm() > 1e-6 || P0.col(3).norm() > 1e-9 || P1(0, 3) >= 0)
    fail(calib_path, 0, "P0/P1 are not a rectified left/right pair (same K, P0 without offset, P1(0,3) < 0)");

  const std::string times_path = sdir + "/times.txt";
  std::vector<int64_t> times;
  std::vector<size_t> time_lines;
  for (const auto& [n, line] : dataLines(times_path)) {
    const auto f = fields(line, ' ');
    if (f.size() != 1) fail(times_path, n, "expected one time in seconds");
    const int64_t t = kKittiClockOffsetUs + std::llround(parseReal(f[0], times_path, n) * 1e6);
    requireIncreasing(times.empty() ? INT64_MIN : times.back(), t, times_path, n);
    times.push_back(t);
    time_lines.push_back(n);
  }
  if (times.empty()) fail(times_path, 0, "no frames");
  const auto [first, last] = frameRange(times.size(), options, times_path);
  char name[32];
  for (size_t i = first; i <= last; ++i) {
    std::snprintf(name, sizeof name, "%06zu.png", i);
    StereoFrame fr{times[i], static_cast<int64_t>(i), sdir + "/image_0/" + name, sdir + "/image_1/" + name};
    if (!fs::exists(fr.left_path))
      fail(fr.left_path, 0, "image missing (times.txt line " + std::to_string(time_lines[i]) + ")");
    if (!fs::exists(fr.right_path))
      fail(fr.right_path, 0, "image missing (times.txt line " + std::to_string(time_lines[i]) + ")");
    rec.frames.push_back(fr);
  }
  // The size is the images' (calib.txt does not carry it).
  const cv::Mat first_image = cv::imread(rec.frames.front().left_path, cv::IMREAD_GRAYSCALE);
  if (first_image.empty()) fail(rec.frames.front().left_path, 0, "not a readable image");

  CameraIntrinsics k;
  k.width = first_image.cols;
  k.height = first_image.rows;
  k.K = P0.leftCols<3>();
  k.serial = "kitti_" + seq + "_image_0";
  rec.calib.cam0 = k;
  k.serial = "kitti_" + seq + "_image_1";
  rec.calib.cam1 = k;
  rec.calib.R_cam1_cam0.setIdentity();
  rec.calib.t_cam1_cam0 = Eigen::Vector3d(P1(0, 3) / P1(0, 0), 0, 0);  // P1(0,3) = -f B
  rec.calib.T_imu_cam0.setIdentity();                                  // no IMU: the body is camera 0

  const std::string poses_path = dir + "/poses/" + seq + ".txt";
  if (fs::exists(poses_path)) {
    rec.ground_truth_source = poses_path;
    std::vector<GroundTruthPose> gt;
    for (const auto& [n, line] : dataLines(poses_path)) {
      const auto f = fields(line, ' ');
      if (f.size() != 12) fail(poses_path, n, "expected 12 numbers (3x4 pose)");
      Eigen::Matrix<double, 3, 4> m;
      for (int i = 0; i < 12; ++i) m(i / 4, i % 4) = parseReal(f[i], poses_path, n);
      const size_t index = gt.size();
      if (index >= times.size()) fail(poses_path, n, "more poses than times.txt has frames");
      GroundTruthPose g;
      g.utime = times[index];
      g.position = m.col(3);
      Eigen::JacobiSVD<Eigen::Matrix3d> svd(m.leftCols<3>(), Eigen::ComputeFullU | Eigen::ComputeFullV);
      const Eigen::Matrix3d R = svd.matrixU() * svd.matrixV().transpose();
      if ((R - m.leftCols<3>()).norm() > 1e-3 || R.determinant() < 0) fail(poses_path, n, "not a rotation");
      g.orientation = Eigen::Quaterniond(R);
      gt.push_back(g);
    }
    rec.ground_truth = window(gt, rec.frames.front().utime, rec.frames.back().utime);
  }
  return rec;
}

Recording readRecording(const std::string& format, const std::string& dir, const ReadOptions& options) {
  if (format == "euroc") return readEuroc(dir, options);
  if (format == "kitti") return readKitti(dir, options);
  throw DatasetError("unknown format '" + format + "' (euroc or kitti)");
}

cv::Mat loadImage(const std::string& path, int width, int height) {
  cv::Mat img;
  try {
    img = loadGrey(path);
  } catch (const std::exception&) {
    fail(path, 0, "not a readable image");
  }
  if (img.cols != width || img.rows != height)
    fail(path, 0,
         "image is " + std::to_string(img.cols) + "x" + std::to_string(img.rows) + ", the calibration's " +
             std::to_string(width) + "x" + std::to_string(height));
  return img;
}

Eigen::Isometry3d cameraPose(const GroundTruthPose& body, const StereoCalibration& calib) {
  Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
  T_w_b.linear() = body.orientation.toRotationMatrix();
  T_w_b.translation() = body.position;
  return T_w_b * calib.T_imu_cam0;
}

}  // namespace ips::dataset
