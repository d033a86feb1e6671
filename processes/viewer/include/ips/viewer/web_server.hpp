#pragma once
// The viewer's HTTP side (cpp-httplib): the page and its scripts, the JavaScript libraries from the machine's
// own Debian packages (nothing is fetched from outside at run time), the newest pictures and data of a
// LiveView, and a server-sent event stream per browser from the EventHub.
#include <memory>
#include <string>
#include <thread>

#include "ips/viewer/event_hub.hpp"
#include "ips/viewer/live_view.hpp"

namespace httplib {
class Server;
}

namespace ips::viewer {

struct WebServerParams {
  std::string bind_address = "127.0.0.1";                // localhost only unless told otherwise (see the README)
  int port = 8080;                                       // 0: any free port
  std::string page_dir;                                  // index.html, viewer.js, viewer.css
  std::string javascript_dir = "/usr/share/javascript";  // Debian's libjs-* packages: chart.js, three
  int event_streams = 8;    // browsers connected at once (EventHub's max_clients): a thread each
  int request_threads = 8;  // for the pictures and data the pages fetch
};

class WebServer {
 public:
  WebServer(const WebServerParams& params, LiveView& view, EventHub& hub);
  ~WebServer();
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;

  // Binds and starts serving in a thread of its own; returns the port. Throws std::runtime_error when the
  // address cannot be bound or a folder is missing.
  int start();
  void stop();

 private:
  WebServerParams params_;
  LiveView& view_;
  EventHub& hub_;
  std::unique_ptr<httplib::Server> server_;
  std::thread thread_;
};

// Seconds on a steady clock, the viewer's wall time for rate limits and staleness.
double wallSeconds();

}  // namespace ips::viewer
