#pragma once
// What the browser shows, kept up to date from plain inputs (no LCM, no HTTP): the newest images as JPEG, the
// newest disparity map colour-mapped (PNG, invalid pixels marked) and as a point cloud, the trajectories of the
// estimators and of the ground truth, the georeferenced points of the mapper, and one health row per process.
// The adapter (processes/viewer/main.cpp) feeds it from the bus; the web server reads it and forwards the
// events it broadcasts. Every method is thread-safe.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "ips/config.hpp"
#include "ips/viewer/event_hub.hpp"

namespace ips::viewer {

struct ViewerParams {
  // Images are encoded at most this often [Hz]: a browser on the vehicle network gets a picture it can follow
  // (a 752 x 480 JPEG is about 40 KB, so 4 Hz is about 160 KB/s per browser) and the encoder stays a small
  // share of a core whatever the camera rate.
  double image_max_rate_hz = 4.0;
  int jpeg_quality = 80;
  // A trajectory point is kept every this many seconds of stamp time per estimator (10 Hz is finer than a
  // top view of a walk can show) ...
  double trajectory_min_interval_s = 0.1;
  // ... and at most this many per estimator: beyond it every second point is dropped (a day at 10 Hz fits).
  int trajectory_max_points = 20000;
  // New trajectory points and the health table go to the browsers this often [s].
  double push_period_s = 0.5;
  // A process whose health message has not arrived for this long is shown as stopped: processes report
  // once per second, so three missed reports.
  double health_stale_after_s = 3.0;
  // The disparity map as a 3D cloud: every n-th pixel in both directions, up to a range [m].
  int cloud_pixel_step = 4;
  double cloud_max_range_m = 40.0;
  // Points of the mapper (POINTS) kept for the 3D view; the oldest go first.
  int map_max_points = 300000;
  // Events one browser may have pending before its oldest are dropped, and browsers served at once.
  int client_queue_events = 64;
  int max_clients = 8;
};
// Reads the optional keys of config/viewer.yaml ("viewer/..."); ConfigError names a bad key.
ViewerParams loadViewerParams(const Config& cfg);

// One process's health report as the viewer needs it.
struct HealthReport {
  std::string process, host;
  int pid = 0;
  int64_t utime = 0;
  double input_rate_hz = 0, output_rate_hz = 0, latency_ms = 0;
  int queue_length = 0;
  int64_t received = 0, published = 0, dropped = 0, bad = 0;
  std::vector<std::pair<std::string, int64_t>> counters;
};

// A pose of an estimator ("EKF", "UKF") or of the ground truth ("truth") in the world frame.
struct PoseSample {
  int64_t utime = 0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
  Eigen::Matrix3d position_cov = Eigen::Matrix3d::Zero();  // zero for the ground truth
};

// A disparity map of the rectified left image: disparity [px], NaN where invalid.
struct DisparityFrame {
  int64_t utime = 0, seq = 0;
  cv::Mat disparity;                            // CV_32FC1
  double min_disparity = 0, max_disparity = 0;  // the searched range: the colour scale
  double focal_px = 0, cx = 0, cy = 0, baseline_m = 0;
};

class LiveView {
 public:
  static constexpr const char* kTruth = "truth";

  LiveView(const ViewerParams& params, EventHub& hub);

  // Inputs. `wall_s`: the viewer's own clock [s], for rate limits and staleness only (what is shown never
  // depends on it: the figures come from the messages).
  void onStereo(int64_t utime, int64_t seq, const cv::Mat& left, const cv::Mat& right, double wall_s);
  void onDisparity(const DisparityFrame& frame, double wall_s);
  void onPose(const std::string& source, const PoseSample& pose);
  void onPoints(int64_t utime, const std::vector<Eigen::Vector3f>& world_points);
  void onHealth(const HealthReport& report, double wall_s);
  // Broadcasts what is due (trajectory points, health table); called often (every 100 ms) by the adapter.
  void tick(double wall_s);

  // For the web server (copies or shared immutable buffers; empty when nothing arrived yet). The pictures are
  // encoded on the first request for each pair or map, on the web server's thread: the bus thread only copies.
  std::shared_ptr<const std::string> leftJpeg();
  std::shared_ptr<const std::string> rightJpeg();
  std::shared_ptr<const std::string> disparityPng();
  std::shared_ptr<const std::string> cloud() const;  // float32 x, y, z per point, camera frame (z forward)
  std::shared_ptr<const std::string> map() const;    // float32 x, y, z per point, world frame
  std::string statusJson(double wall_s) const;       // health table, images, counts
  // The colour scale of disparityPng(), from the smallest searched disparity (left) to the largest (right).
  static std::shared_ptr<const std::string> colourBarPng();
  std::string trajectoryJson() const;  // every kept point of every source

  // Counters for the viewer's own health message.
  int64_t imagesEncoded() const;  // taken for the page (each is encoded when a browser asks for it)
  int64_t imagesSkipped() const;  // arrived while the last encoding was more recent than the rate allows

 private:
  struct Track {
    std::vector<PoseSample> points;
    size_t sent = 0;  // points already broadcast
    bool aligned = false;
    Eigen::Isometry3d world_from_estimate = Eigen::Isometry3d::Identity();
  };
  struct HealthEntry {
    HealthReport report;
    double last_wall_s = 0;
  };
  PoseSample alignedPose(const Track& track, const PoseSample& p) const;
  std::string healthJsonLocked(double wall_s) const;
  // The picture of the newest input `raw` (of sequence `seq`): the cached one if it is of that input, else
  // encode(*raw), made outside the lock and cached.
  template <class Raw, class Encode>
  std::shared_ptr<const std::string> onDemand(const std::shared_ptr<const Raw> LiveView::*raw,
                                              std::shared_ptr<const std::string> LiveView::*cache,
                                              int64_t LiveView::*cache_seq, int64_t LiveView::*seq,
                                              const Encode& encode);

  const ViewerParams params_;
  EventHub& hub_;
  mutable std::mutex mutex_;
  std::shared_ptr<const std::string> left_jpeg_, right_jpeg_, disparity_png_, cloud_, map_;
  std::shared_ptr<const cv::Mat> left_raw_, right_raw_;  // of the newest pair taken
  std::shared_ptr<const DisparityFrame> disparity_raw_;  // the newest map taken
  int64_t left_jpeg_seq_ = -1, right_jpeg_seq_ = -1, disparity_png_seq_ = -1;
  int64_t image_seq_ = -1, image_utime_ = 0, disparity_seq_ = -1, disparity_utime_ = 0;
  double disparity_valid_pct_ = 0, disparity_min_ = 0, disparity_max_ = 0;
  double last_image_wall_s_ = -1e9, last_disparity_wall_s_ = -1e9;
  double last_push_wall_s_ = -1e9;
  int64_t images_encoded_ = 0, images_skipped_ = 0;
  int64_t trajectory_generation_ = 0;  // bumped when kept points are thinned or re-aligned: browsers reload
  std::map<std::string, Track> tracks_;
  std::map<std::string, HealthEntry> health_;
  std::vector<Eigen::Vector3f> map_points_;  // ring of the newest map_max_points
  size_t map_next_ = 0;
  int64_t map_received_ = 0;
  bool map_changed_ = false;
};

}  // namespace ips::viewer
