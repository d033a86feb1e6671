#include "ips/viewer/web_server.hpp"

#include <httplib.h>

#include <chrono>
#include <filesystem>
#include <stdexcept>

namespace ips::viewer {

double wallSeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

WebServer::WebServer(const WebServerParams& params, LiveView& view, EventHub& hub)
    : params_(params), view_(view), hub_(hub), server_(std::make_unique<httplib::Server>()) {}

WebServer::~WebServer() { stop(); }

int WebServer::start() {
  for (const std::string& dir :
       {params_.page_dir, params_.javascript_dir + "/chart.js", params_.javascript_dir + "/three"})
    if (!std::filesystem::is_directory(dir))
      throw std::runtime_error("viewer: folder " + dir +
                               " is missing (the page, or Debian's libjs-chart.js / libjs-three packages)");
  httplib::Server& svr = *server_;
  // Every browser's event stream holds a thread for as long as it is open; the rest serve requests.
  const int threads = params_.event_streams + params_.request_threads;
  svr.new_task_queue = [threads] { return new httplib::ThreadPool(threads); };
  svr.set_mount_point("/", params_.page_dir);
  svr.set_mount_point("/lib", params_.javascript_dir);
  svr.set_default_headers({{"Cache-Control", "no-store"}});

  auto blob = [](std::shared_ptr<const std::string> data, const char* type, httplib::Response& res) {
    if (!data) {
      res.status = 404;
      res.set_content("nothing received yet", "text/plain");
      return;
    }
    res.set_content(*data, type);
  };
  svr.Get("/api/status.json", [this](const httplib::Request&, httplib::Response& res) {
    res.set_content(view_.statusJson(wallSeconds()), "application/json");
  });
  svr.Get("/api/trajectory.json", [this](const httplib::Request&, httplib::Response& res) {
    res.set_content(view_.trajectoryJson(), "application/json");
  });
  svr.Get("/api/left.jpg",
          [this, blob](const httplib::Request&, httplib::Response& res) { blob(view_.leftJpeg(), "image/jpeg", res); });
  svr.Get("/api/right.jpg", [this, blob](const httplib::Request&, httplib::Response& res) {
    blob(view_.rightJpeg(), "image/jpeg", res);
  });
  svr.Get("/api/disparity.png", [this, blob](const httplib::Request&, httplib::Response& res) {
    blob(view_.disparityPng(), "image/png", res);
  });
  svr.Get("/api/colourbar.png",
          [colour_bar = LiveView::colourBarPng()](const httplib::Request&, httplib::Response& res) {
            res.set_content(*colour_bar, "image/png");
          });
  svr.Get("/api/cloud.bin", [this, blob](const httplib::Request&, httplib::Response& res) {
    blob(view_.cloud(), "application/octet-stream", res);
  });
  svr.Get("/api/map.bin", [this, blob](const httplib::Request&, httplib::Response& res) {
    blob(view_.map(), "application/octet-stream", res);
  });
  svr.Get("/events", [this](const httplib::Request&, httplib::Response& res) {
    std::shared_ptr<EventHub::Client> client = hub_.connect();
    if (!client) {
      res.status = 503;
      res.set_content("the viewer serves its maximum number of browsers", "text/plain");
      return;
    }
    res.set_header("X-Accel-Buffering", "no");
    res.set_chunked_content_provider(
        "text/event-stream",
        [client](size_t, httplib::DataSink& sink) {
          std::string text;
          if (!client->next(&text, 1.0)) {
            sink.done();
            return true;
          }
          // A comment line keeps idle connections open through proxies and lets a closed browser be noticed.
          if (text.empty()) text = ": idle\n\n";
          return sink.write(text.data(), text.size());
        },
        [this, client](bool) { hub_.disconnect(client); });
  });

  const int port = params_.port == 0 ? svr.bind_to_any_port(params_.bind_address)
                                     : (svr.bind_to_port(params_.bind_address, params_.port) ? params_.port : -1);
  if (port <= 0)
    throw std::runtime_error("viewer: cannot listen on " + params_.bind_address + ":" + std::to_string(params_.port) +
                             " (in use, or not an address of this machine)");
  thread_ = std::thread([this] { server_->listen_after_bind(); });
  return port;
}

void WebServer::stop() {
  hub_.close();
  if (server_) server_->stop();
  if (thread_.joinable()) thread_.join();
}

}  // namespace ips::viewer
