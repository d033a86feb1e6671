#include "ips/dataset/dataset.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "ips/calib/formats.hpp"
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
std::vector<InertialState> readTumPoses(const std::string& path) {
  std::vector<InertialState> out;
  int64_t prev = INT64_MIN;
  for (const auto& [n, line] : dataLines(path)) {
    const auto f = fields(line, ' ');
    if (f.size() != 8) fail(path, n, "expected 't tx ty tz qx qy qz qw' (8 numbers), got " + std::to_string(f.size()));
    double v[8];
    for (int i = 0; i < 8; ++i) v[i] = parseReal(f[i], path, n);
    InertialState g;
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
// *has_state: every row has the last three groups.
std::vector<InertialState> readEurocStateCsv(const std::string& path, bool* has_state) {
  std::vector<InertialState> out;
  *has_state = true;
  int64_t prev = INT64_MIN;
  for (const auto& [n, line] : dataLines(path)) {
    const auto f = fields(line, ',');
    if (f.size() != 8 && f.size() != 17)
      fail(path, n, "expected 8 or 17 comma-separated columns, got " + std::to_string(f.size()));
    InertialState g;
    g.utime = nsToUs(parseInt(f[0], path, n));
    requireIncreasing(prev, g.utime, path, n);
    prev = g.utime;
    double v[16];
    for (size_t i = 1; i < f.size(); ++i) v[i - 1] = parseReal(f[i], path, n);
    g.position = Eigen::Vector3d(v[0], v[1], v[2]);
    g.orientation = Eigen::Quaterniond(v[3], v[4], v[5], v[6]);
    if (std::fabs(g.orientation.norm() - 1.0) > 1e-2) fail(path, n, "quaternion is not of unit length");
    g.orientation.normalize();
    *has_state = *has_state && f.size() == 17;
    if (f.size() == 17) {
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
std::vector<InertialState> bestGroundTruthIn(const std::string& folder, int64_t t0, int64_t t1, std::string* source,
                                             bool* has_state) {
  std::vector<std::string> candidates;
  for (const auto& e : fs::directory_iterator(folder))
    if (e.path().extension() == ".txt" || e.path().extension() == ".csv") candidates.push_back(e.path().string());
  std::sort(candidates.begin(), candidates.end());
  std::vector<InertialState> best;
  std::pair<bool, size_t> best_score{false, 0};
  for (const auto& path : candidates) {
    bool state = false;
    auto gt = fs::path(path).extension() == ".txt" ? readTumPoses(path) : readEurocStateCsv(path, &state);
    if (gt.empty()) continue;
    const bool covers = gt.front().utime <= t0 && gt.back().utime >= t1;
    const size_t inside = static_cast<size_t>(
        std::count_if(gt.begin(), gt.end(), [&](const InertialState& g) { return g.utime >= t0 && g.utime <= t1; }));
    if (best.empty() || std::make_pair(covers, inside) > best_score) {
      best = std::move(gt);
      best_score = {covers, inside};
      *source = path;
      *has_state = state;
    }
  }
  return best;
}

}  // namespace

std::string detectFormat(const std::string& dir) {
  if (fs::exists(dir + "/mav0/cam0/data.csv")) return "euroc";
  if (fs::is_directory(dir + "/sequences")) return "kitti";
  if (fs::exists(dir + "/oxts/timestamps.txt") && fs::is_directory(dir + "/image_00")) return "kitti_raw";
  throw DatasetError(dir +
                     ": neither an EuRoC ASL folder (mav0/cam0/data.csv), a KITTI odometry folder (sequences/) nor "
                     "a KITTI raw drive (image_00/, oxts/)");
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
  if (options.imu && fs::exists(imu_path)) {
    try {
      rec.calib.imu = calib::readImuNoise(mav + "/imu0/sensor.yaml");
    } catch (const ConfigError& e) {
      throw DatasetError(e.what());
    }
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
    rec.imu = options.whole_recording ? std::move(all) : window(all, t0, t1);
  }

  // Ground truth: --gt (TUM), else the ASL state estimate, else the best file in groundtruth/.
  std::vector<InertialState> gt;
  if (!options.gt_path.empty()) {
    rec.ground_truth_source = options.gt_path;
    gt = readTumPoses(options.gt_path);
  } else if (fs::exists(mav + "/state_groundtruth_estimate0/data.csv")) {
    rec.ground_truth_source = mav + "/state_groundtruth_estimate0/data.csv";
    gt = readEurocStateCsv(rec.ground_truth_source, &rec.ground_truth_has_state);
  } else if (fs::is_directory(dir + "/groundtruth")) {
    gt = bestGroundTruthIn(dir + "/groundtruth", t0, t1, &rec.ground_truth_source, &rec.ground_truth_has_state);
  }
  rec.ground_truth = options.whole_recording ? std::move(gt) : window(gt, t0, t1);
  rec.ground_truth_has_state = rec.ground_truth_has_state && !rec.ground_truth.empty();
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
    std::vector<InertialState> gt;
    for (const auto& [n, line] : dataLines(poses_path)) {
      const auto f = fields(line, ' ');
      if (f.size() != 12) fail(poses_path, n, "expected 12 numbers (3x4 pose)");
      Eigen::Matrix<double, 3, 4> m;
      for (int i = 0; i < 12; ++i) m(i / 4, i % 4) = parseReal(f[i], poses_path, n);
      const size_t index = gt.size();
      if (index >= times.size()) fail(poses_path, n, "more poses than times.txt has frames");
      InertialState g;
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

// ---- KITTI raw ----------------------------------------------------------------------------------------------

namespace {

// "NAME: numbers" lines of a KITTI calibration file (calib_time and other text lines are skipped).
std::map<std::string, std::vector<double>> kittiCalibFile(const std::string& path) {
  std::map<std::string, std::vector<double>> out;
  for (const auto& [n, line] : dataLines(path)) {
    const size_t colon = line.find(':');
    if (colon == std::string::npos) fail(path, n, "expected 'NAME: values'");
    const std::string name = line.substr(0, colon);
    if (name == "calib_time") continue;
    std::vector<double> values;
    for (const auto& f : fields(line.substr(colon + 1), ' ')) values.push_back(parseReal(f, path, n));
    out[name] = values;
  }
  return out;
}

const std::vector<double>& need(const std::map<std::string, std::vector<double>>& m, const std::string& path,
                                const std::string& key, size_t count) {
  const auto it = m.find(key);
  if (it == m.end()) fail(path, 0, "key '" + key + "' missing");
  if (it->second.size() != count) fail(path, 0, "key '" + key + "' needs " + std::to_string(count) + " numbers");
  return it->second;
}

Eigen::Matrix3d rotationOf(const std::vector<double>& v, const std::string& path, const std::string& key) {
  Eigen::Matrix3d R;
  for (int i = 0; i < 9; ++i) R(i / 3, i % 3) = v[static_cast<size_t>(i)];
  if ((R * R.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-3 || R.determinant() < 0)
    fail(path, 0, "key '" + key + "' is not a rotation");
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  return svd.matrixU() * svd.matrixV().transpose();
}

// "2011-09-26 13:02:25.964389445" (the drive's local time) as microseconds since the epoch, the date taken as UTC:
// only differences matter, and both sensors' files use the same clock.
int64_t kittiTimestampUs(const std::string& text, const std::string& path, size_t line) {
  int y = 0, mo = 0, d = 0, h = 0, mi = 0;
  char frac[16] = {0};
  int sec = 0;
  if (std::sscanf(text.c_str(), "%d-%d-%d %d:%d:%d.%15[0-9]", &y, &mo, &d, &h, &mi, &sec, frac) < 6 || mo < 1 ||
      mo > 12 || d < 1 || d > 31 || h > 23 || mi > 59 || sec > 60)
    fail(path, line, "'" + text + "' is not a time 'YYYY-MM-DD hh:mm:ss.fraction'");
  // Days since 1970-01-01 (proleptic Gregorian), without the C library's time zone.
  const int yy = y - (mo <= 2), era = (yy >= 0 ? yy : yy - 399) / 400, yoe = yy - era * 400;
  const int doy = (153 * (mo + (mo > 2 ? -3 : 9)) + 2) / 5 + d - 1, doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  const int64_t days = static_cast<int64_t>(era) * 146097 + doe - 719468;
  std::string f(frac);
  f.resize(6, '0');
  return ((days * 24 + h) * 60 + mi) * 60'000'000LL + sec * 1'000'000LL + std::stoll(f);
}

std::vector<int64_t> kittiTimestamps(const std::string& path) {
  std::vector<int64_t> out;
  for (const auto& [n, line] : dataLines(path)) {
    const int64_t t = kittiTimestampUs(line, path, n);
    requireIncreasing(out.empty() ? INT64_MIN : out.back(), t, path, n);
    out.push_back(t);
  }
  if (out.empty()) fail(path, 0, "no time stamps");
  return out;
}

std::string findCalibFile(const std::string& dir, const std::string& name) {
  for (const std::string& p : {dir + "/" + name, fs::path(dir).parent_path().string() + "/" + name})
    if (fs::exists(p)) return p;
  fail(dir + "/" + name, 0, "missing (looked in the drive's folder and its parent)");
}

}  // namespace

ImuDescription oxtsInsDescription(const std::vector<ImuSample>& samples, double rate_hz) {
  // The OXTS RT3003's outputs are its GNSS-aided INS's: bias-compensated, so the turn-on biases are what that
  // compensation leaves (0.01 deg/s, 1 mg), and the biases hardly walk over a drive. Their noise is the recording's
  // own: the synced drives hold one snapshot per 0.1 s of the car's vibrating body, whose spread about the motion is
  // far above the sensors' white noise. It is measured here, per axis, from each sample against the mean of its two
  // neighbours (white noise of sigma gives 1.5 sigma^2 there; the motion's curvature between them adds little).
  ImuDescription d;
  d.model = "OXTS RT3003 GPS/INS (KITTI raw oxts: its INS outputs; noise measured from the drive)";
  d.rate_hz = rate_hz;
  d.gyro_bias_sigma = 0.01 * M_PI / 180;
  d.accel_bias_sigma = 0.01;
  d.gyro_random_walk = 1e-5;
  d.accel_random_walk = 1e-4;
  auto density = [&](const Eigen::Vector3d ImuSample::*field, double floor) {
    double sum = 0;
    size_t n = 0;
    for (size_t k = 1; k + 1 < samples.size(); ++k, ++n)
      sum += (samples[k].*field - 0.5 * (samples[k - 1].*field + samples[k + 1].*field)).squaredNorm() / 3.0;
    const double sigma = n ? std::sqrt(sum / static_cast<double>(n) / 1.5) : 0;
    return std::max(floor, sigma / std::sqrt(rate_hz));
  };
  // Floors: the inertial sensors' own white noise (0.2 deg/sqrt(h), 0.5 mg/sqrt(Hz) class).
  d.gyro_noise_density = density(&ImuSample::angular_rate, 0.2 * M_PI / 180 / 60);
  d.accel_noise_density = density(&ImuSample::specific_force, 0.005);
  return d;
}

Recording readKittiRaw(const std::string& dir, const ReadOptions& options) {
  Recording rec;
  rec.format = "kitti_raw";
  const std::string cam_path = findCalibFile(dir, "calib_cam_to_cam.txt");
  const std::string imu_velo_path = findCalibFile(dir, "calib_imu_to_velo.txt");
  const std::string velo_cam_path = findCalibFile(dir, "calib_velo_to_cam.txt");
  const auto cam = kittiCalibFile(cam_path), imu_velo = kittiCalibFile(imu_velo_path),
             velo_cam = kittiCalibFile(velo_cam_path);

  // Frames: image_00 (left grey) and image_01 (right grey), each with its own timestamps.txt; a pair is one index.
  const std::vector<int64_t> t_left = kittiTimestamps(dir + "/image_00/timestamps.txt");
  const std::vector<int64_t> t_right = kittiTimestamps(dir + "/image_01/timestamps.txt");
  if (t_left.size() != t_right.size())
    fail(dir + "/image_01/timestamps.txt", 0,
         std::to_string(t_right.size()) + " frames, image_00 has " + std::to_string(t_left.size()));
  const auto [first, last] = frameRange(t_left.size(), options, dir + "/image_00/timestamps.txt");
  char name[32];
  for (size_t i = first; i <= last; ++i) {
    std::snprintf(name, sizeof name, "%010zu.png", i);
    StereoFrame f{t_left[i], static_cast<int64_t>(i), dir + "/image_00/data/" + name, dir + "/image_01/data/" + name};
    if (!fs::exists(f.left_path)) fail(f.left_path, 0, "image listed in timestamps.txt is missing");
    if (!fs::exists(f.right_path)) fail(f.right_path, 0, "image listed in timestamps.txt is missing");
    // The cameras are triggered together by the laser scanner; their stamps differ by the capture's jitter.
    if (std::llabs(t_right[i] - t_left[i]) > 5000)
      fail(dir + "/image_01/timestamps.txt", i + 1, "frame stamped more than 5 ms from image_00's");
    rec.frames.push_back(f);
  }

  // Cameras: rectified drives (the images have S_rect_00's size) as the rectified pair, raw ones as calibrated.
  const cv::Mat first_image = cv::imread(rec.frames.front().left_path, cv::IMREAD_GRAYSCALE);
  if (first_image.empty()) fail(rec.frames.front().left_path, 0, "not a readable image");
  const auto& s_rect = need(cam, cam_path, "S_rect_00", 2);
  const bool rectified = std::lround(s_rect[0]) == first_image.cols && std::lround(s_rect[1]) == first_image.rows;
  Eigen::Matrix3d R_rect0_cam0 = Eigen::Matrix3d::Identity();
  if (rectified) {
    const auto& p0 = need(cam, cam_path, "P_rect_00", 12);
    const auto& p1 = need(cam, cam_path, "P_rect_01", 12);
    CameraIntrinsics k;
    k.width = first_image.cols;
    k.height = first_image.rows;
    k.K << p0[0], p0[1], p0[2], p0[4], p0[5], p0[6], p0[8], p0[9], p0[10];
    if (!(k.K(0, 0) > 0) || std::fabs(p1[0] - p0[0]) > 1e-6 || !(p1[3] < 0))
      fail(cam_path, 0, "P_rect_00 / P_rect_01 are not a rectified left/right pair");
    k.serial = "kitti_raw_image_00";
    rec.calib.cam0 = k;
    k.serial = "kitti_raw_image_01";
    rec.calib.cam1 = k;
    rec.calib.R_cam1_cam0.setIdentity();
    rec.calib.t_cam1_cam0 = Eigen::Vector3d(p1[3] / p1[0], 0, 0);  // P1(0,3) = -f B
    R_rect0_cam0 = rotationOf(need(cam, cam_path, "R_rect_00", 9), cam_path, "R_rect_00");
  } else {
    for (int c = 0; c < 2; ++c) {
      const std::string i = "0" + std::to_string(c);
      const auto& K = need(cam, cam_path, "K_" + i, 9);
      const auto& D = need(cam, cam_path, "D_" + i, 5);
      const auto& S = need(cam, cam_path, "S_" + i, 2);
      CameraIntrinsics k;
      k.width = static_cast<int>(std::lround(S[0]));
      k.height = static_cast<int>(std::lround(S[1]));
      for (int j = 0; j < 9; ++j) k.K(j / 3, j % 3) = K[static_cast<size_t>(j)];
      for (int j = 0; j < 5; ++j) k.distortion(j) = D[static_cast<size_t>(j)];
      k.serial = "kitti_raw_image_" + i;
      (c == 0 ? rec.calib.cam0 : rec.calib.cam1) = k;
    }
    // x_i = R_0i x_0 + T_0i (camera 0 to camera i).
    const Eigen::Matrix3d R00 = rotationOf(need(cam, cam_path, "R_00", 9), cam_path, "R_00");
    const Eigen::Matrix3d R01 = rotationOf(need(cam, cam_path, "R_01", 9), cam_path, "R_01");
    const auto& T00 = need(cam, cam_path, "T_00", 3);
    const auto& T01 = need(cam, cam_path, "T_01", 3);
    rec.calib.R_cam1_cam0 = R01 * R00.transpose();
    rec.calib.t_cam1_cam0 =
        Eigen::Vector3d(T01[0], T01[1], T01[2]) - rec.calib.R_cam1_cam0 * Eigen::Vector3d(T00[0], T00[1], T00[2]);
    if (rec.calib.cam0.width != first_image.cols || rec.calib.cam0.height != first_image.rows)
      fail(rec.frames.front().left_path, 0, "image size is neither S_00's nor S_rect_00's");
  }
  // The IMU (OXTS) to camera 0: x_velo = R x_imu + T, x_cam0 = R x_velo + T, then the rectification's rotation.
  auto rigid = [&](const std::map<std::string, std::vector<double>>& m, const std::string& path) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = rotationOf(need(m, path, "R", 9), path, "R");
    const auto& t = need(m, path, "T", 3);
    T.translation() = Eigen::Vector3d(t[0], t[1], t[2]);
    return T;
  };
  Eigen::Isometry3d T_rect_cam0 = Eigen::Isometry3d::Identity();
  T_rect_cam0.linear() = R_rect0_cam0;
  rec.calib.T_imu_cam0 = (T_rect_cam0 * rigid(velo_cam, velo_cam_path) * rigid(imu_velo, imu_velo_path)).inverse();

  // OXTS: one file per sample, the 30 values of oxts/dataformat.txt.
  const std::vector<int64_t> t_oxts = kittiTimestamps(dir + "/oxts/timestamps.txt");
  std::vector<ImuSample> imu_all;
  std::vector<InertialState> gt_all;
  double scale = 0, lat0 = 0;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  for (size_t k = 0; k < t_oxts.size(); ++k) {
    std::snprintf(name, sizeof name, "%010zu.txt", k);
    const std::string path = dir + "/oxts/data/" + name;
    const auto lines = dataLines(path);
    if (lines.size() != 1) fail(path, 0, "expected one line of 30 values");
    const auto f = fields(lines[0].second, ' ');
    if (f.size() != 30)
      fail(path, lines[0].first, "expected 30 values (oxts/dataformat.txt), got " + std::to_string(f.size()));
    double v[30];
    for (int i = 0; i < 30; ++i) v[i] = parseReal(f[static_cast<size_t>(i)], path, lines[0].first);
    const double lat = v[0], lon = v[1], alt = v[2], roll = v[3], pitch = v[4], yaw = v[5];
    if (std::fabs(lat) > 85 || std::fabs(lon) > 180) fail(path, lines[0].first, "latitude or longitude out of range");
    // The devkit's Mercator projection, scaled at the first sample's latitude.
    if (k == 0) lat0 = lat, scale = std::cos(lat0 * M_PI / 180);
    constexpr double kEarthRadius = 6378137.0;
    const Eigen::Vector3d p(scale * lon * M_PI * kEarthRadius / 180,
                            scale * kEarthRadius * std::log(std::tan((90 + lat) * M_PI / 360)), alt);
    if (k == 0) origin = p;
    InertialState g;
    g.utime = t_oxts[k];
    g.position = p - origin;  // metres from the first sample, x east, y north, z up
    g.orientation = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                    Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                    Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX());
    gt_all.push_back(g);
    ImuSample s;
    s.utime = t_oxts[k];
    s.specific_force = Eigen::Vector3d(v[11], v[12], v[13]);  // ax ay az: forward, left, up
    s.angular_rate = Eigen::Vector3d(v[17], v[18], v[19]);    // wx wy wz
    imu_all.push_back(s);
  }
  const int64_t t0 = rec.frames.front().utime, t1 = rec.frames.back().utime;
  rec.ground_truth = window(gt_all, t0, t1);
  rec.ground_truth_source = dir + "/oxts";
  if (options.imu) {
    rec.imu = window(imu_all, t0, t1);
    if (t_oxts.size() < 3) fail(dir + "/oxts/timestamps.txt", 0, "fewer than three OXTS samples");
    const double rate_hz =
        1e6 * static_cast<double>(t_oxts.size() - 1) / static_cast<double>(t_oxts.back() - t_oxts.front());
    rec.calib.imu = oxtsInsDescription(imu_all, rate_hz);
  }
  return rec;
}

Recording readRecording(const std::string& format, const std::string& dir, const ReadOptions& options) {
  if (format == "euroc") return readEuroc(dir, options);
  if (format == "kitti") return readKitti(dir, options);
  if (format == "kitti_raw") return readKittiRaw(dir, options);
  throw DatasetError("unknown format '" + format + "' (euroc, kitti or kitti_raw)");
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

Eigen::Isometry3d cameraPose(const InertialState& body, const StereoCalibration& calib) {
  Eigen::Isometry3d T_w_b = Eigen::Isometry3d::Identity();
  T_w_b.linear() = body.orientation.toRotationMatrix();
  T_w_b.translation() = body.position;
  return T_w_b * calib.T_imu_cam0;
}

}  // namespace ips::dataset
