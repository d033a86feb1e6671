#include "ips/viewer/live_view.hpp"

#include <cmath>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace ips::viewer {

using nlohmann::json;

ViewerParams loadViewerParams(const Config& cfg) {
  ViewerParams p;
  p.image_max_rate_hz = cfg.getDouble("viewer/image_max_rate_hz", p.image_max_rate_hz);
  p.jpeg_quality = cfg.getInt("viewer/jpeg_quality", p.jpeg_quality);
  p.trajectory_min_interval_s = cfg.getDouble("viewer/trajectory_min_interval_s", p.trajectory_min_interval_s);
  p.trajectory_max_points = cfg.getInt("viewer/trajectory_max_points", p.trajectory_max_points);
  p.push_period_s = cfg.getDouble("viewer/push_period_s", p.push_period_s);
  p.health_stale_after_s = cfg.getDouble("viewer/health_stale_after_s", p.health_stale_after_s);
  p.cloud_pixel_step = cfg.getInt("viewer/cloud_pixel_step", p.cloud_pixel_step);
  p.cloud_max_range_m = cfg.getDouble("viewer/cloud_max_range_m", p.cloud_max_range_m);
  p.map_max_points = cfg.getInt("viewer/map_max_points", p.map_max_points);
  p.client_queue_events = cfg.getInt("viewer/client_queue_events", p.client_queue_events);
  p.max_clients = cfg.getInt("viewer/max_clients", p.max_clients);
  if (!(p.image_max_rate_hz > 0 && p.jpeg_quality >= 1 && p.jpeg_quality <= 100 && p.trajectory_min_interval_s >= 0 &&
        p.trajectory_max_points >= 2 && p.push_period_s > 0 && p.health_stale_after_s > 0 && p.cloud_pixel_step >= 1 &&
        p.cloud_max_range_m > 0 && p.map_max_points >= 1 && p.client_queue_events >= 1 && p.max_clients >= 1))
    throw ConfigError(cfg.path() +
                      ": viewer/ keys out of range (rates, periods and ranges > 0, jpeg_quality 1..100, counts >= 1, "
                      "trajectory_max_points >= 2)");
  return p;
}

namespace {

std::shared_ptr<const std::string> encode(const std::string& ext, const cv::Mat& image, const std::vector<int>& opts) {
  std::vector<uchar> bytes;
  cv::imencode(ext, image, bytes, opts);
  return std::make_shared<const std::string>(bytes.begin(), bytes.end());
}

std::shared_ptr<const std::string> floatsBlob(const std::vector<Eigen::Vector3f>& points) {
  auto blob = std::make_shared<std::string>(points.size() * 3 * sizeof(float), '\0');
  float* out = reinterpret_cast<float*>(blob->data());
  for (const auto& p : points) *out++ = p.x(), *out++ = p.y(), *out++ = p.z();
  return blob;
}

// Rounds for the page: millimetres and microseconds are more than a browser can show.
double rounded(double v, double unit) { return std::round(v / unit) * unit; }

// [t s, x, y, z m, var x, cov xy, var y m^2]: what the top view with its uncertainty ellipse needs.
json pointJson(const PoseSample& p) {
  return json::array({rounded(p.utime * 1e-6, 1e-3), rounded(p.position.x(), 1e-3), rounded(p.position.y(), 1e-3),
                      rounded(p.position.z(), 1e-3), p.position_cov(0, 0), p.position_cov(0, 1), p.position_cov(1, 1)});
}

// The map coloured on the turbo scale over the searched range, invalid pixels magenta.
std::shared_ptr<const std::string> disparityPicture(const DisparityFrame& f) {
  cv::Mat invalid(f.disparity.size(), CV_8U);  // NaN (OpenCV's comparisons do not single NaN out)
  for (int r = 0; r < f.disparity.rows; ++r)
    for (int c = 0; c < f.disparity.cols; ++c)
      invalid.at<uchar>(r, c) = std::isnan(f.disparity.at<float>(r, c)) ? 255 : 0;
  const double span = std::max(1e-6, f.max_disparity - f.min_disparity);
  cv::Mat scaled;
  f.disparity.convertTo(scaled, CV_8U, 255.0 / span, -255.0 * f.min_disparity / span);
  cv::Mat colour;
  cv::applyColorMap(scaled, colour, cv::COLORMAP_TURBO);
  // Magenta is in no part of the turbo scale, so a marked pixel cannot be read as a disparity.
  colour.setTo(cv::Scalar(255, 0, 255), invalid);
  // PNG, not JPEG: the marks of invalid pixels stay exact.
  return encode(".png", colour, {cv::IMWRITE_PNG_COMPRESSION, 1});
}

}  // namespace

LiveView::LiveView(const ViewerParams& params, EventHub& hub) : params_(params), hub_(hub) {}

void LiveView::onStereo(int64_t utime, int64_t seq, const cv::Mat& left, const cv::Mat& right, double wall_s) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (wall_s - last_image_wall_s_ < 1.0 / params_.image_max_rate_hz) {
      ++images_skipped_;
      return;
    }
    last_image_wall_s_ = wall_s;
  }
  // Kept raw and encoded when a browser asks for it (leftJpeg, rightJpeg), on the web server's thread: the bus thread
  // of a loaded machine only copies, and nothing is encoded while no page is open.
  auto left_copy = std::make_shared<const cv::Mat>(left.clone());
  auto right_copy = std::make_shared<const cv::Mat>(right.clone());
  std::lock_guard<std::mutex> lock(mutex_);
  left_raw_ = left_copy;
  right_raw_ = right_copy;
  image_seq_ = seq;
  image_utime_ = utime;
  ++images_encoded_;
  hub_.broadcast("image", json{{"seq", seq}, {"utime", utime}}.dump());
}

std::shared_ptr<const std::string> LiveView::colourBarPng() {
  cv::Mat ramp(1, 256, CV_8U);
  for (int i = 0; i < 256; ++i) ramp.at<uchar>(0, i) = static_cast<uchar>(i);
  cv::Mat colour;
  cv::applyColorMap(ramp, colour, cv::COLORMAP_TURBO);
  return encode(".png", colour, {});
}

void LiveView::onDisparity(const DisparityFrame& f, double wall_s) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (wall_s - last_disparity_wall_s_ < 1.0 / params_.image_max_rate_hz) {
      ++images_skipped_;
      return;
    }
    last_disparity_wall_s_ = wall_s;
  }
  std::vector<Eigen::Vector3f> points;
  const int step = params_.cloud_pixel_step;
  for (int v = 0; v < f.disparity.rows; v += step)
    for (int u = 0; u < f.disparity.cols; u += step) {
      const float d = f.disparity.at<float>(v, u);
      if (!(d > 0)) continue;
      const double z = f.focal_px * f.baseline_m / d;
      if (z > params_.cloud_max_range_m) continue;
      points.emplace_back((u - f.cx) * z / f.focal_px, (v - f.cy) * z / f.focal_px, z);
    }
  int valid = 0;
  for (int r = 0; r < f.disparity.rows; ++r)
    for (int c = 0; c < f.disparity.cols; ++c) valid += std::isnan(f.disparity.at<float>(r, c)) ? 0 : 1;
  const double valid_pct = f.disparity.empty() ? 0 : 100.0 * valid / double(f.disparity.total());
  // The picture is drawn when a browser asks for it (disparityPng).
  auto frame = std::make_shared<DisparityFrame>(f);
  frame->disparity = f.disparity.clone();
  auto cloud = floatsBlob(points);

  std::lock_guard<std::mutex> lock(mutex_);
  disparity_raw_ = frame;
  cloud_ = cloud;
  disparity_seq_ = f.seq;
  disparity_utime_ = f.utime;
  disparity_valid_pct_ = valid_pct;
  disparity_min_ = f.min_disparity;
  disparity_max_ = f.max_disparity;
  ++images_encoded_;
  hub_.broadcast("disparity", json{{"seq", f.seq},
                                   {"utime", f.utime},
                                   {"min", f.min_disparity},
                                   {"max", f.max_disparity},
                                   {"valid_pct", rounded(valid_pct, 0.01)},
                                   {"cloud_points", points.size()}}
                                  .dump());
}

void LiveView::onPose(const std::string& source, const PoseSample& pose) {
  std::lock_guard<std::mutex> lock(mutex_);
  Track& track = tracks_[source];
  if (!track.points.empty()) {
    const int64_t last = track.points.back().utime;
    if (pose.utime < last) {
      // Time went back: a log replayed again from its start. The view starts over with it.
      track = Track{};
      ++trajectory_generation_;
    } else if (pose.utime - last < std::llround(params_.trajectory_min_interval_s * 1e6)) {
      return;
    }
  }
  if (track.points.empty() && source != kTruth) {
    // Estimators start in their own world frame; with the ground truth on the bus the first pose is put on it
    // (as the report aligns the first pose), so both can be compared at a glance.
    const auto truth = tracks_.find(kTruth);
    if (truth != tracks_.end() && !truth->second.points.empty()) {
      const PoseSample* nearest = nullptr;
      for (const PoseSample& t : truth->second.points)
        if (!nearest || std::abs(t.utime - pose.utime) < std::abs(nearest->utime - pose.utime)) nearest = &t;
      if (std::abs(nearest->utime - pose.utime) * 1e-6 <= params_.trajectory_min_interval_s) {
        // Yaw and position only, as the report aligns: roll and pitch are the filter's own (gravity makes
        // them observable), so a tilt error stays visible.
        auto yaw = [](const Eigen::Quaterniond& q) {
          const Eigen::Vector3d x = q * Eigen::Vector3d::UnitX();
          return std::atan2(x.y(), x.x());
        };
        const Eigen::Matrix3d R =
            Eigen::AngleAxisd(yaw(nearest->orientation) - yaw(pose.orientation), Eigen::Vector3d::UnitZ())
                .toRotationMatrix();
        track.world_from_estimate.linear() = R;
        track.world_from_estimate.translation() = nearest->position - R * pose.position;
        track.aligned = true;
      }
    }
  }
  track.points.push_back(pose);
  if (static_cast<int>(track.points.size()) > params_.trajectory_max_points) {
    std::vector<PoseSample> thinned;
    for (size_t i = 0; i < track.points.size(); i += 2) thinned.push_back(track.points[i]);
    track.points.swap(thinned);
    track.sent = track.points.size();
    ++trajectory_generation_;
  }
}

void LiveView::onPoints(int64_t, const std::vector<Eigen::Vector3f>& world_points) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& p : world_points) {
    if (static_cast<int>(map_points_.size()) < params_.map_max_points) {
      map_points_.push_back(p);
    } else {
      map_points_[map_next_] = p;
      map_next_ = (map_next_ + 1) % map_points_.size();
    }
  }
  map_received_ += static_cast<int64_t>(world_points.size());
  map_changed_ = true;
}

void LiveView::onHealth(const HealthReport& report, double wall_s) {
  std::lock_guard<std::mutex> lock(mutex_);
  health_[report.process] = HealthEntry{report, wall_s};
}

PoseSample LiveView::alignedPose(const Track& track, const PoseSample& p) const {
  if (!track.aligned) return p;
  PoseSample a = p;
  a.position = track.world_from_estimate * p.position;
  a.orientation = Eigen::Quaterniond(track.world_from_estimate.linear() * p.orientation.toRotationMatrix());
  const Eigen::Matrix3d R = track.world_from_estimate.linear();
  a.position_cov = R * p.position_cov * R.transpose();
  return a;
}

void LiveView::tick(double wall_s) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (wall_s - last_push_wall_s_ < params_.push_period_s) return;
  last_push_wall_s_ = wall_s;
  json sources = json::object();
  for (auto& [name, track] : tracks_) {
    if (track.sent >= track.points.size()) continue;
    json pts = json::array();
    for (size_t i = track.sent; i < track.points.size(); ++i)
      pts.push_back(pointJson(alignedPose(track, track.points[i])));
    sources[name] = json{{"from", track.sent}, {"aligned", track.aligned}, {"points", pts}};
    track.sent = track.points.size();
  }
  if (!sources.empty())
    hub_.broadcast("trajectory", json{{"generation", trajectory_generation_}, {"sources", sources}}.dump());
  hub_.broadcast("health", healthJsonLocked(wall_s));
  if (map_changed_) {
    map_ = floatsBlob(map_points_);
    map_changed_ = false;
    hub_.broadcast("map", json{{"points", map_points_.size()}, {"received", map_received_}}.dump());
  }
}

std::string LiveView::healthJsonLocked(double wall_s) const {
  json rows = json::array();
  for (const auto& [name, entry] : health_) {
    const HealthReport& r = entry.report;
    json counters = json::object();
    for (const auto& [k, v] : r.counters) counters[k] = v;
    const double age = wall_s - entry.last_wall_s;
    rows.push_back(json{{"process", r.process},
                        {"host", r.host},
                        {"pid", r.pid},
                        {"utime", r.utime},
                        {"input_rate_hz", rounded(r.input_rate_hz, 0.01)},
                        {"output_rate_hz", rounded(r.output_rate_hz, 0.01)},
                        {"latency_ms", rounded(r.latency_ms, 0.01)},
                        {"queue_length", r.queue_length},
                        {"received", r.received},
                        {"published", r.published},
                        {"dropped", r.dropped},
                        {"bad", r.bad},
                        {"counters", counters},
                        {"age_s", rounded(age, 0.1)},
                        {"stale", age > params_.health_stale_after_s}});
  }
  return json{{"rows", rows}, {"stale_after_s", params_.health_stale_after_s}}.dump();
}

std::string LiveView::statusJson(double wall_s) const {
  std::lock_guard<std::mutex> lock(mutex_);
  json tracks = json::object();
  for (const auto& [name, track] : tracks_)
    tracks[name] = json{{"points", track.points.size()}, {"aligned", track.aligned}};
  return json{{"health", json::parse(healthJsonLocked(wall_s))},
              {"image", {{"seq", image_seq_}, {"utime", image_utime_}}},
              {"disparity",
               {{"seq", disparity_seq_},
                {"utime", disparity_utime_},
                {"min", disparity_min_},
                {"max", disparity_max_},
                {"valid_pct", rounded(disparity_valid_pct_, 0.01)}}},
              {"trajectory_generation", trajectory_generation_},
              {"tracks", tracks},
              {"map_points", map_points_.size()},
              {"clients", hub_.clients()}}
      .dump();
}

std::string LiveView::trajectoryJson() const {
  std::lock_guard<std::mutex> lock(mutex_);
  json sources = json::object();
  for (const auto& [name, track] : tracks_) {
    json pts = json::array();
    // Up to `sent`: later points reach the browser with the next trajectory event, which continues from here.
    for (size_t i = 0; i < track.sent; ++i) pts.push_back(pointJson(alignedPose(track, track.points[i])));
    sources[name] = json{{"from", 0}, {"aligned", track.aligned}, {"points", pts}};
  }
  return json{{"generation", trajectory_generation_}, {"sources", sources}}.dump();
}

template <class Raw, class Encode>
std::shared_ptr<const std::string> LiveView::onDemand(const std::shared_ptr<const Raw> LiveView::*raw,
                                                      std::shared_ptr<const std::string> LiveView::*cache,
                                                      int64_t LiveView::*cache_seq, int64_t LiveView::*seq,
                                                      const Encode& encode) {
  std::shared_ptr<const Raw> input;
  int64_t input_seq;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!(this->*raw) || this->*cache_seq == this->*seq) return this->*cache;
    input = this->*raw;
    input_seq = this->*seq;
  }
  // Outside the lock: the bus thread goes on taking inputs meanwhile.
  std::shared_ptr<const std::string> picture = encode(*input);
  std::lock_guard<std::mutex> lock(mutex_);
  this->*cache = picture;
  this->*cache_seq = input_seq;
  return picture;
}

std::shared_ptr<const std::string> LiveView::leftJpeg() {
  return onDemand(&LiveView::left_raw_, &LiveView::left_jpeg_, &LiveView::left_jpeg_seq_, &LiveView::image_seq_,
                  [this](const cv::Mat& m) {
                    return encode(".jpg", m, {cv::IMWRITE_JPEG_QUALITY, params_.jpeg_quality});
                  });
}
std::shared_ptr<const std::string> LiveView::rightJpeg() {
  return onDemand(&LiveView::right_raw_, &LiveView::right_jpeg_, &LiveView::right_jpeg_seq_, &LiveView::image_seq_,
                  [this](const cv::Mat& m) {
                    return encode(".jpg", m, {cv::IMWRITE_JPEG_QUALITY, params_.jpeg_quality});
                  });
}
std::shared_ptr<const std::string> LiveView::disparityPng() {
  return onDemand(&LiveView::disparity_raw_, &LiveView::disparity_png_, &LiveView::disparity_png_seq_,
                  &LiveView::disparity_seq_, [](const DisparityFrame& f) { return disparityPicture(f); });
}
std::shared_ptr<const std::string> LiveView::cloud() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return cloud_;
}
std::shared_ptr<const std::string> LiveView::map() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return map_;
}
int64_t LiveView::imagesEncoded() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return images_encoded_;
}
int64_t LiveView::imagesSkipped() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return images_skipped_;
}

}  // namespace ips::viewer
