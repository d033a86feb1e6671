// The viewer's library against analytic references: the bounded event queues of slow browsers, the
// estimators put on the ground truth at their first pose, the kept trajectory points, the disparity picture's
// colours and invalid marks, the 3D points of a disparity, the rate of encoded pictures, stopped processes;
// and the web server over real HTTP (page, Debian's JavaScript libraries, data, the event stream).
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "ips/viewer/event_hub.hpp"
#include "ips/viewer/live_view.hpp"
#include "ips/viewer/web_server.hpp"
// After Eigen: httplib brings <resolv.h>, whose `_res` macro breaks Eigen's headers.
#include <httplib.h>

using ips::viewer::EventHub;
using ips::viewer::LiveView;
using ips::viewer::PoseSample;
using ips::viewer::ViewerParams;
using nlohmann::json;

namespace {

int countEvents(const std::string& text, const std::string& name) {
  int n = 0;
  for (size_t at = text.find("event: " + name + "\n"); at != std::string::npos;
       at = text.find("event: " + name + "\n", at + 1))
    ++n;
  return n;
}

PoseSample pose(double t, const Eigen::Vector3d& p, double yaw) {
  PoseSample s;
  s.utime = static_cast<int64_t>(std::llround(t * 1e6));
  s.position = p;
  s.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  return s;
}

}  // namespace

TEST(EventHub, AStalledClientLosesItsOldestEventsCountedAndOthersLoseNothing) {
  EventHub hub(3, 2);
  auto stalled = hub.connect(), reader = hub.connect();
  ASSERT_TRUE(stalled && reader);
  EXPECT_EQ(hub.connect(), nullptr) << "a third browser beyond max_clients 2";
  EXPECT_EQ(hub.refused(), 1);
  std::string text;
  for (int i = 0; i < 5; ++i) {
    hub.broadcast("n", std::to_string(i));
    ASSERT_TRUE(reader->next(&text, 0.0));
    EXPECT_EQ(text, "event: n\ndata: " + std::to_string(i) + "\n\n");
  }
  ASSERT_TRUE(stalled->next(&text, 0.0));
  EXPECT_EQ(text, "event: n\ndata: 2\n\nevent: n\ndata: 3\n\nevent: n\ndata: 4\n\n");
  EXPECT_EQ(stalled->dropped(), 2);
  EXPECT_EQ(reader->dropped(), 0);
  EXPECT_EQ(hub.dropped(), 2);
  hub.disconnect(stalled);
  EXPECT_EQ(hub.clients(), 1);
  hub.close();
  EXPECT_FALSE(reader->next(&text, 1.0)) << "a closed hub ends every stream at once";
}

TEST(LiveView, AnEstimatorIsPutOnTheGroundTruthAtItsFirstPose) {
  EventHub hub(1000, 1);
  ViewerParams params;
  LiveView view(params, hub);
  // The estimator's world frame is the truth's turned by 30 degrees and moved by (5, -2, 1).
  Eigen::Isometry3d est_from_truth = Eigen::Isometry3d::Identity();
  est_from_truth.linear() = Eigen::AngleAxisd(M_PI / 6, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  est_from_truth.translation() = Eigen::Vector3d(5, -2, 1);
  for (int i = 0; i <= 20; ++i) {
    const double t = 10 + 0.1 * i;
    const PoseSample truth = pose(t, Eigen::Vector3d(t, 0.5 * t, 0), 0.2 * t);
    view.onPose(LiveView::kTruth, truth);
    PoseSample est = truth;
    est.position = est_from_truth * truth.position;
    est.orientation = Eigen::Quaterniond(est_from_truth.linear()) * truth.orientation;
    est.position_cov = Eigen::Vector3d(0.04, 0.01, 0.09).asDiagonal();
    view.onPose("EKF", est);
  }
  view.tick(0);
  const json traj = json::parse(view.trajectoryJson());
  const auto& ekf = traj["sources"]["EKF"]["points"];
  const auto& truth = traj["sources"]["truth"]["points"];
  ASSERT_EQ(ekf.size(), 21u);
  ASSERT_EQ(truth.size(), 21u);
  EXPECT_TRUE(traj["sources"]["EKF"]["aligned"].get<bool>());
  for (size_t i = 0; i < ekf.size(); ++i)
    for (int k = 1; k <= 3; ++k) EXPECT_NEAR(ekf[i][k].get<double>(), truth[i][k].get<double>(), 2e-3);
  // The covariance turned into the truth's frame: its trace stays, x and y mix by the 30 degrees.
  const Eigen::Matrix2d R = Eigen::Rotation2Dd(-M_PI / 6).toRotationMatrix();
  const Eigen::Matrix2d cov = R * Eigen::Vector2d(0.04, 0.01).asDiagonal() * R.transpose();
  EXPECT_NEAR(ekf[5][4].get<double>(), cov(0, 0), 1e-9);
  EXPECT_NEAR(ekf[5][5].get<double>(), cov(0, 1), 1e-9);
  EXPECT_NEAR(ekf[5][6].get<double>(), cov(1, 1), 1e-9);
}

TEST(LiveView, KeepsOnePointPerIntervalThinsBeyondTheBoundAndStartsOverWhenTimeGoesBack) {
  EventHub hub(1000, 1);
  auto client = hub.connect();
  ViewerParams params;
  params.trajectory_min_interval_s = 0.1;
  params.trajectory_max_points = 50;
  LiveView view(params, hub);
  for (int i = 0; i < 200; ++i) view.onPose("EKF", pose(0.01 * i, Eigen::Vector3d(i, 0, 0), 0));  // 100 Hz, 2 s
  view.tick(0);
  EXPECT_EQ(json::parse(view.trajectoryJson())["sources"]["EKF"]["points"].size(), 20u);
  std::string text;
  client->next(&text, 0);
  EXPECT_EQ(countEvents(text, "trajectory"), 1);
  EXPECT_NE(text.find("\"from\":0"), std::string::npos);

  for (int i = 200; i < 600; ++i) view.onPose("EKF", pose(0.01 * i, Eigen::Vector3d(i, 0, 0), 0));
  const json after = json::parse(view.statusJson(0));
  EXPECT_LE(after["tracks"]["EKF"]["points"].get<int>(), 50);
  EXPECT_GE(after["tracks"]["EKF"]["points"].get<int>(), 25);
  EXPECT_GT(after["trajectory_generation"].get<int>(), 0) << "thinning tells browsers to reload";

  const int generation = after["trajectory_generation"].get<int>();
  view.onPose("EKF", pose(0.5, Eigen::Vector3d(0, 0, 0), 0));  // a replay from the start
  const json restarted = json::parse(view.statusJson(0));
  EXPECT_EQ(restarted["tracks"]["EKF"]["points"].get<int>(), 1);
  EXPECT_EQ(restarted["trajectory_generation"].get<int>(), generation + 1);
}

TEST(LiveView, DisparityPictureMarksInvalidPixelsAndItsCloudIsTheTriangulation) {
  EventHub hub(1000, 1);
  ViewerParams params;
  params.cloud_pixel_step = 1;
  params.cloud_max_range_m = 100;
  LiveView view(params, hub);
  ips::viewer::DisparityFrame f;
  f.seq = 7;
  f.disparity = cv::Mat(40, 60, CV_32FC1);
  for (int r = 0; r < 40; ++r)
    for (int c = 0; c < 60; ++c) f.disparity.at<float>(r, c) = c;  // 0 .. 59 left to right
  f.disparity(cv::Rect(10, 10, 5, 5)).setTo(NAN);
  f.min_disparity = 0;
  f.max_disparity = 64;
  f.focal_px = 500, f.cx = 30, f.cy = 20, f.baseline_m = 0.2;
  view.onDisparity(f, 0);
  auto png = view.disparityPng();
  ASSERT_TRUE(png);
  const cv::Mat colour = cv::imdecode(std::vector<uchar>(png->begin(), png->end()), cv::IMREAD_COLOR);
  ASSERT_EQ(colour.size(), cv::Size(60, 40));
  EXPECT_EQ(colour.at<cv::Vec3b>(12, 12), cv::Vec3b(255, 0, 255)) << "invalid: magenta";
  // A valid pixel has the turbo colour of its disparity on the searched range.
  cv::Mat level(1, 1, CV_8U, cv::Scalar(std::round(40 * 255.0 / 64))), expected;
  cv::applyColorMap(level, expected, cv::COLORMAP_TURBO);
  EXPECT_EQ(colour.at<cv::Vec3b>(30, 40), expected.at<cv::Vec3b>(0, 0));
  int magenta = 0;
  for (int r = 0; r < 40; ++r)
    for (int c = 0; c < 60; ++c) magenta += colour.at<cv::Vec3b>(r, c) == cv::Vec3b(255, 0, 255);
  EXPECT_EQ(magenta, 25);

  // Cloud: every pixel with a positive disparity (column 0 has none, 25 are invalid), z = f b / d.
  auto cloud = view.cloud();
  ASSERT_TRUE(cloud);
  ASSERT_EQ(cloud->size(), (40 * 59 - 25) * 3 * sizeof(float));
  const float* p = reinterpret_cast<const float*>(cloud->data());
  // The first point is row 0, column 1: d = 1.
  EXPECT_NEAR(p[2], 500 * 0.2 / 1, 1e-4);
  EXPECT_NEAR(p[0], (1 - 30) * 100.0 / 500, 1e-4);
  EXPECT_NEAR(p[1], (0 - 20) * 100.0 / 500, 1e-4);
  const json status = json::parse(view.statusJson(0));
  EXPECT_NEAR(status["disparity"]["valid_pct"].get<double>(), 100.0 * (2400 - 25) / 2400, 0.01);
}

TEST(LiveView, PicturesAreEncodedAtMostAtTheConfiguredRate) {
  EventHub hub(1000, 1);
  ViewerParams params;
  params.image_max_rate_hz = 4;  // one every 0.25 s
  LiveView view(params, hub);
  const cv::Mat image(48, 64, CV_8UC1, cv::Scalar(100));
  for (int i = 0; i < 10; ++i) view.onStereo(i * 50000, i, image, image, 0.1 * i);
  // Encoded at 0, 0.3, 0.6 and 0.9 s.
  EXPECT_EQ(view.imagesEncoded(), 4);
  EXPECT_EQ(view.imagesSkipped(), 6);
  EXPECT_TRUE(view.leftJpeg());
  EXPECT_TRUE(view.rightJpeg()) << "the right image of the newest encoded pair, encoded on request";
  view.onStereo(11 * 50000, 11, image, image, 1.5);
  EXPECT_EQ(json::parse(view.statusJson(0))["image"]["seq"].get<int>(), 11);
}

// The bus thread only copies a pair; the picture is encoded on the first request for it, served again from the cache
// until a newer pair is taken, and shows that pair.
TEST(LiveView, PicturesAreEncodedOnRequestOncePerPairAndShowTheNewest) {
  EventHub hub(1000, 1);
  LiveView view(ViewerParams{}, hub);
  EXPECT_FALSE(view.leftJpeg()) << "nothing arrived yet";
  const cv::Mat dark(48, 64, CV_8UC1, cv::Scalar(40)), bright(48, 64, CV_8UC1, cv::Scalar(200));
  view.onStereo(0, 1, dark, bright, 0.0);
  const auto left = view.leftJpeg();
  ASSERT_TRUE(left);
  EXPECT_EQ(view.leftJpeg(), left) << "one encoding per pair";
  const auto decodedMean = [](const std::shared_ptr<const std::string>& jpeg) {
    return cv::mean(cv::imdecode(std::vector<uchar>(jpeg->begin(), jpeg->end()), cv::IMREAD_GRAYSCALE))[0];
  };
  EXPECT_NEAR(decodedMean(left), 40, 2);
  EXPECT_NEAR(decodedMean(view.rightJpeg()), 200, 2);
  view.onStereo(1000000, 2, bright, dark, 1.0);
  EXPECT_NE(view.leftJpeg(), left);
  EXPECT_NEAR(decodedMean(view.leftJpeg()), 200, 2);

  ips::viewer::DisparityFrame f;
  f.seq = 5;
  f.disparity = cv::Mat(24, 32, CV_32FC1, cv::Scalar(10.0f));
  f.max_disparity = 20;
  view.onDisparity(f, 0.0);
  const auto png = view.disparityPng();
  ASSERT_TRUE(png);
  EXPECT_EQ(view.disparityPng(), png);
  EXPECT_EQ(cv::imdecode(std::vector<uchar>(png->begin(), png->end()), cv::IMREAD_COLOR).size(), f.disparity.size());
}

TEST(LiveView, AProcessWhoseReportsStopIsMarkedStale) {
  EventHub hub(1000, 1);
  ViewerParams params;
  params.health_stale_after_s = 3;
  LiveView view(params, hub);
  ips::viewer::HealthReport r;
  r.process = "tracker";
  r.bad = 2;
  r.counters = {{"decode_error", 2}};
  view.onHealth(r, 100.0);
  r.process = "e3d";
  view.onHealth(r, 102.0);
  const json early = json::parse(view.statusJson(102.5))["health"]["rows"];
  ASSERT_EQ(early.size(), 2u);
  EXPECT_EQ(early[1]["process"], "tracker");
  EXPECT_FALSE(early[1]["stale"].get<bool>());
  EXPECT_EQ(early[1]["counters"]["decode_error"].get<int>(), 2);
  const json late = json::parse(view.statusJson(104.0))["health"]["rows"];
  EXPECT_FALSE(late[0]["stale"].get<bool>()) << "e3d reported 2 s ago";
  EXPECT_TRUE(late[1]["stale"].get<bool>()) << "tracker reported 4 s ago";
}

TEST(WebServer, ServesThePageTheLibrariesTheDataAndTheEventStream) {
  EventHub hub(64, 2);
  ViewerParams params;
  LiveView view(params, hub);
  ips::viewer::WebServerParams web;
  web.port = 0;
  web.page_dir = IPS_VIEWER_PAGE_DIR;
  ips::viewer::WebServer server(web, view, hub);
  const int port = server.start();
  ASSERT_GT(port, 0);
  httplib::Client http("127.0.0.1", port);
  for (const char* path : {"/", "/viewer.js", "/lib/chart.js/chart.min.js", "/lib/three/three.min.js",
                           "/lib/three/examples/js/controls/OrbitControls.js", "/api/colourbar.png"}) {
    auto res = http.Get(path);
    ASSERT_TRUE(res) << path;
    EXPECT_EQ(res->status, 200) << path;
    EXPECT_GT(res->body.size(), 100u) << path;
  }
  auto none = http.Get("/api/left.jpg");
  ASSERT_TRUE(none);
  EXPECT_EQ(none->status, 404) << "no picture before the first image";
  const cv::Mat image(48, 64, CV_8UC1, cv::Scalar(100));
  view.onStereo(1000000, 3, image, image, 0);
  auto jpeg = http.Get("/api/left.jpg");
  ASSERT_TRUE(jpeg);
  EXPECT_EQ(jpeg->status, 200);
  EXPECT_EQ(cv::imdecode(std::vector<uchar>(jpeg->body.begin(), jpeg->body.end()), cv::IMREAD_GRAYSCALE).size(),
            image.size());

  // The event stream: what is broadcast after connecting arrives.
  std::string received;
  std::thread stream([&] {
    httplib::Client sse("127.0.0.1", port);
    sse.Get("/events", [&](const char* data, size_t n) {
      received.append(data, n);
      return received.find("event: image") == std::string::npos;  // stop once the image event came
    });
  });
  while (hub.clients() == 0) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  view.onStereo(2000000, 4, image, image, 10);
  stream.join();
  EXPECT_NE(received.find("event: image\ndata: {\"seq\":4,\"utime\":2000000}"), std::string::npos) << received;
  server.stop();
}
