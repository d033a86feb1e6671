// fake_stereo_camera: two Aravis fake GigE Vision cameras (real GVCP/GVSP over UDP) serving known images, for
// running the camera process without hardware. Each camera serves its image (resized to the region the driver
// sets), with the frame's time stamp [us] in the first 8 bytes of row 0. Both expose at multiples of the frame
// period on the host clock, like two cameras on one trigger line.
#include <arv.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "ips/args.hpp"

namespace {

struct Source {
  cv::Mat image;  // mono8
  cv::Mat resized;
};

void fill(ArvBuffer* buffer, void* data, guint32, guint32, ArvPixelFormat) {
  auto* src = static_cast<Source*>(data);
  size_t size = 0;
  auto* pixels = static_cast<uint8_t*>(const_cast<void*>(arv_buffer_get_image_data(buffer, &size)));
  const int w = arv_buffer_get_image_width(buffer), h = arv_buffer_get_image_height(buffer);
  if (!pixels || w <= 0 || h <= 0) return;
  if (src->resized.cols != w || src->resized.rows != h)
    cv::resize(src->image, src->resized, cv::Size(w, h), 0, 0, cv::INTER_AREA);
  std::memcpy(pixels, src->resized.data, static_cast<size_t>(w) * h);
  const uint64_t stamp_us = arv_buffer_get_timestamp(buffer) / 1000;
  std::memcpy(pixels, &stamp_us, sizeof stamp_us);
}

volatile std::sig_atomic_t g_stop = 0;

}  // namespace

int main(int argc, char** argv) {
  try {
    ips::Args args(argc, argv, "Two Aravis fake GigE Vision cameras serving known images");
    args.option("--left-address", "IP", "address of the left camera (must exist on an interface)", "127.0.0.2")
        .option("--right-address", "IP", "address of the right camera", "127.0.0.3")
        .option("--left-serial", "S", "serial number of the left camera", "IPS-LEFT")
        .option("--right-serial", "S", "serial number of the right camera", "IPS-RIGHT")
        .required("--left-image", "PNG", "image the left camera serves")
        .required("--right-image", "PNG", "image the right camera serves")
        .option("--lost-ratio", "R", "share of stream packets each camera drops", "0")
        .option("--duration", "S", "run this long (0: until SIGINT/SIGTERM)", "0");
    if (!args.parse()) return 0;
    Source sources[2];
    const char* image_opt[2] = {"--left-image", "--right-image"};
    for (int i = 0; i < 2; ++i) {
      sources[i].image = cv::imread(args.get(image_opt[i]), cv::IMREAD_GRAYSCALE);
      if (sources[i].image.empty()) throw std::runtime_error("cannot read " + args.get(image_opt[i]));
    }
    const std::string address[2] = {args.get("--left-address"), args.get("--right-address")};
    const std::string serial[2] = {args.get("--left-serial"), args.get("--right-serial")};
    ArvGvFakeCamera* cams[2];
    for (int i = 0; i < 2; ++i) {
      cams[i] = arv_gv_fake_camera_new(address[i].c_str(), serial[i].c_str());
      if (!arv_gv_fake_camera_is_running(cams[i]))
        throw std::runtime_error("fake camera on " + address[i] + " did not start (address on an interface?)");
      arv_fake_camera_set_fill_pattern(arv_gv_fake_camera_get_fake_camera(cams[i]), fill, &sources[i]);
      g_object_set(cams[i], "gvsp-lost-ratio", args.getDouble("--lost-ratio"), nullptr);
    }
    std::signal(SIGINT, [](int) { g_stop = 1; });
    std::signal(SIGTERM, [](int) { g_stop = 1; });
    std::printf("ready %s=%s %s=%s\n", serial[0].c_str(), address[0].c_str(), serial[1].c_str(), address[1].c_str());
    std::fflush(stdout);
    const double duration = args.getDouble("--duration");
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(duration);
    while (!g_stop && (duration <= 0 || std::chrono::steady_clock::now() < end))
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    for (auto* c : cams) g_object_unref(c);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fake_stereo_camera: error: %s\n", e.what());
    return 1;
  }
}
