// viewer: the running system in a browser. Subscribes to the bus (images, disparity maps, filter states,
// ground truth, the mapper's points, every process's health) and serves a live page on --port; the page
// updates by itself. The library (ips_viewer) knows nothing of LCM: this file only turns messages into its
// plain inputs.
#include <iostream>
#include <ips/disparity_map_t.hpp>
#include <ips/filter_state_t.hpp>
#include <ips/ground_truth_t.hpp>
#include <ips/health_t.hpp>
#include <ips/point_cloud_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <map>

#include "ips/config.hpp"
#include "ips/data_dir.hpp"
#include "ips/framework/channels.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/message_poses.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/process.hpp"
#include "ips/framework/validate.hpp"
#include "ips/viewer/live_view.hpp"
#include "ips/viewer/web_server.hpp"

#ifndef IPS_VIEWER_PAGE_DIR
#define IPS_VIEWER_PAGE_DIR ""
#endif

namespace {

ips::viewer::DisparityFrame toFrame(const ips::disparity_map_t& m) {
  ips::viewer::DisparityFrame f;
  f.utime = m.utime;
  f.seq = m.seq;
  f.disparity = ips::fw::disparityImage(m);
  f.min_disparity = m.min_disparity;
  f.max_disparity = m.min_disparity + m.num_disparities;
  f.focal_px = m.focal_px;
  f.cx = m.cx;
  f.cy = m.cy;
  f.baseline_m = m.baseline_m;
  return f;
}

ips::viewer::PoseSample toPose(int64_t utime, const ips::fw::BodyPose& b) {
  ips::viewer::PoseSample p;
  p.utime = utime;
  p.position = b.T_world_body.translation();
  p.orientation = Eigen::Quaterniond(b.T_world_body.linear());
  p.position_cov = b.covariance.topLeftCorner<3, 3>();
  return p;
}

ips::viewer::HealthReport toReport(const ips::health_t& h) {
  ips::viewer::HealthReport r;
  r.process = h.process;
  r.host = h.host;
  r.pid = h.pid;
  r.utime = h.utime;
  r.input_rate_hz = h.input_rate_hz;
  r.output_rate_hz = h.output_rate_hz;
  r.latency_ms = h.latency_ms;
  r.queue_length = h.queue_length;
  r.received = h.received;
  r.published = h.published;
  r.dropped = h.dropped;
  r.bad = h.bad;
  for (int i = 0; i < h.num_counters; ++i) r.counters.emplace_back(h.counter_names[i], h.counter_values[i]);
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  return ips::fw::guardedMain("viewer", [&] {
    ips::Args args(argc, argv, "viewer: a live view of the running system in the browser, served on --port");
    ips::fw::addCommonOptions(args, "config/viewer.yaml");
    args.option("--port", "N", "port of the page (0: any free port)", "8080")
        .option("--bind", "ADDRESS",
                "address to listen on: 127.0.0.1 serves this machine only, 0.0.0.0 every network the machine is on",
                "127.0.0.1")
        .option("--page-dir", "DIR", "the page's files (default: PREFIX/share/ips/viewer/web when installed)",
                ips::installedFile("viewer/web", IPS_VIEWER_PAGE_DIR));
    if (!args.parse()) return 0;
    ips::fw::applyCommonOptions(args);
    const ips::Config cfg(args.get("--config"));
    const ips::viewer::ViewerParams params = ips::viewer::loadViewerParams(cfg);
    if (ips::fw::configChecked(args, cfg)) return 0;

    ips::fw::Node node("viewer", ips::fw::resolveLcmUrl(args.get("--lcm-url")));
    ips::viewer::EventHub hub(params.client_queue_events, params.max_clients);
    ips::viewer::LiveView view(params, hub);
    namespace ch = ips::channels;
    using ips::viewer::wallSeconds;

    // Every stream's stamps checked as the processes check theirs: one forged stamp an hour ahead must not
    // stretch a trajectory across the page or replace the picture.
    std::map<std::string, ips::fw::StreamOrder> pose_order;
    auto inOrder = [&](const std::string& stream, int64_t utime) {
      return ips::fw::admitInOrder(pose_order[stream], utime, 0, node.health(), stream, node.arrivalUs());
    };
    ips::fw::StreamOrder stereo_order;
    node.subscribe<ips::stereo_pair_t>(ch::kStereo, [&](const ips::stereo_pair_t& m) {
      node.health().received(m.utime);
      const ips::fw::Verdict v = ips::fw::validate(m);
      if (!v.ok()) return node.health().bad(v.reason, v.detail);
      if (!ips::fw::admitInOrder(stereo_order, m.utime, m.seq, node.health(), "stereo", node.arrivalUs())) return;
      node.health().accepted();
      view.onStereo(m.utime, m.seq, ips::fw::mono8Copy(ips::fw::leftImage(m)),
                    ips::fw::mono8Copy(ips::fw::rightImage(m)), wallSeconds());
    });
    node.subscribe<ips::disparity_map_t>(ch::kDisparity, [&](const ips::disparity_map_t& m) {
      node.health().received(m.utime);
      const ips::fw::Verdict v = ips::fw::validate(m);
      if (!v.ok()) return node.health().bad(v.reason, v.detail);
      node.health().accepted();
      view.onDisparity(toFrame(m), wallSeconds());
    });
    // The a-posteriori states of every filter: FILTER_STATE (EKF) and FILTER_STATE_<NAME> (a second filter).
    node.subscribeWithChannel<ips::filter_state_t>(
        std::string(ch::kFilterState) + "(_.*)?", [&](const ips::filter_state_t& m, const std::string& channel) {
          node.health().received(m.utime);
          const ips::fw::Verdict v = ips::fw::validate(m);
          if (!v.ok()) return node.health().bad(v.reason, v.detail);
          if (!inOrder(channel, m.utime)) return;
          node.health().accepted();
          view.onPose(m.filter_type == ips::filter_state_t::FILTER_UKF ? "UKF" : "EKF",
                      toPose(m.utime, ips::fw::bodyPose(m)));
        });
    node.subscribe<ips::ground_truth_t>(ch::kGtPose, [&](const ips::ground_truth_t& m) {
      node.health().received(m.utime);
      ips::fw::BodyPose b;
      if (!ips::fw::bodyPose(m, &b))
        return node.health().bad("nan", "a ground-truth pose that is not finite or not a rotation");
      if (!inOrder(ch::kGtPose, m.utime)) return;
      node.health().accepted();
      view.onPose(ips::viewer::LiveView::kTruth, toPose(m.utime, b));
    });
    node.subscribe<ips::point_cloud_t>(ch::kPoints, [&](const ips::point_cloud_t& m) {
      node.health().received(m.utime);
      if (m.frame != "world") return node.health().dropped("points_not_in_world_frame");
      std::vector<Eigen::Vector3f> pts;
      pts.reserve(m.num_points);
      for (int i = 0; i < m.num_points; ++i) {
        const Eigen::Vector3f p(m.points[i][0], m.points[i][1], m.points[i][2]);
        if (p.allFinite()) pts.push_back(p);
      }
      if (static_cast<int>(pts.size()) < m.num_points) node.health().bad("nan", "map points that are not finite");
      node.health().accepted();
      view.onPoints(m.utime, pts);
    });
    node.subscribeWithChannel<ips::health_t>(
        std::string(ch::kHealthPrefix) + ".*",
        [&](const ips::health_t& h, const std::string& channel) {
          const ips::fw::Verdict v = ips::fw::validate(h, channel);
          if (!v.ok()) return node.health().bad(v.reason, v.detail);
          view.onHealth(toReport(h), wallSeconds());
        },
        /*drop_repeats=*/false);  // an idle process reports alike twice

    ips::viewer::WebServerParams web;
    web.bind_address = args.get("--bind");
    web.port = static_cast<int>(args.getInt("--port"));
    web.page_dir = args.get("--page-dir");
    web.event_streams = params.max_clients;
    ips::viewer::WebServer server(web, view, hub);
    const int port = server.start();
    // The address the main job and the deployment print for the operator.
    std::cout << "viewer: serving http://" << (web.bind_address == "0.0.0.0" ? "<this machine>" : web.bind_address)
              << ":" << port << "/" << std::endl;
    const int rc = node.run([&] {
      view.tick(wallSeconds());
      node.health().set("browsers", hub.clients());
      node.health().set("browser_events_dropped", hub.dropped());
      node.health().set("browsers_refused", hub.refused());
      node.health().set("images_encoded", view.imagesEncoded());
      node.health().set("images_skipped_rate_limit", view.imagesSkipped());
    });
    server.stop();
    return rc;
  });
}
