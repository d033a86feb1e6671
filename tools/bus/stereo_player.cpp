// stereo_player: publishes stereo pairs read from image files on STEREO, stamped from the files (EuRoC
// data.csv times) or at a fixed rate. A stand-in for the camera driver when replaying recorded image folders,
// and the source of the spine's transport tests.
#include <zlib.h>

#include <chrono>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <thread>

#include "ips/framework/channels.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/node.hpp"
#include "ips/framework/process.hpp"

namespace {

struct Frame {
  int64_t utime;
  std::string left, right;
};

// EuRoC ASL layout: <dir>/cam0/data.csv with "timestamp [ns],filename", images in cam0/data, cam1/data.
std::vector<Frame> readEuroc(const std::string& mav0) {
  std::ifstream csv(mav0 + "/cam0/data.csv");
  if (!csv) throw std::runtime_error("cannot read " + mav0 + "/cam0/data.csv");
  std::vector<Frame> frames;
  std::string line;
  for (int n = 1; std::getline(csv, line); ++n) {
    if (line.empty() || line[0] == '#') continue;
    std::stringstream ss(line);
    std::string t, name;
    std::getline(ss, t, ',');
    std::getline(ss, name);
    while (!name.empty() && (name.back() == '\r' || name.back() == ' ')) name.pop_back();
    size_t used = 0;
    long long ns = -1;
    try {
      ns = std::stoll(t, &used);
    } catch (const std::exception&) {
    }
    if (ns < 0 || used != t.size() || name.empty())
      throw std::runtime_error(mav0 + "/cam0/data.csv:" + std::to_string(n) +
                               ": expected 'timestamp_ns,filename', got '" + line + "'");
    frames.push_back({ns / 1000, mav0 + "/cam0/data/" + name, mav0 + "/cam1/data/" + name});
  }
  return frames;
}

uint32_t checksum(const ips::stereo_pair_t& m) {
  uLong a = adler32(0L, Z_NULL, 0);
  a = adler32(a, m.left.data(), static_cast<uInt>(m.left.size()));
  a = adler32(a, m.right.data(), static_cast<uInt>(m.right.size()));
  return static_cast<uint32_t>(a);
}

}  // namespace

int main(int argc, char** argv) {
  return ips::fw::guardedMain("stereo_player", [&]() {
    ips::Args args(argc, argv, "publish stereo pairs from image files on STEREO");
    args.option("--euroc", "MAV0_DIR", "an EuRoC mav0 folder (cam0/data.csv, cam0/data, cam1/data)")
        .option("--left", "PNG", "one left image (with --right): published --count times")
        .option("--right", "PNG", "the right image")
        .option("--size", "WxH", "scale every image to this size, e.g. 1360x1024")
        .option("--rate", "HZ", "publish rate; with --euroc the recorded stamps are kept but paced at this rate", "8")
        .option("--count", "N", "number of pairs to publish (0: all frames once)", "0")
        .option("--start-utime", "US", "stamp of the first pair when images carry none", "1000000")
        .option("--channel", "NAME", "channel", ips::channels::kStereo)
        .option("--wait-subscriber", "S", "seconds to wait before the first pair (let receivers start)", "0");
    ips::fw::addBusOptions(args);
    if (!args.parse()) return 0;
    ips::fw::applyCommonOptions(args);

    std::vector<Frame> frames;
    if (args.has("--euroc"))
      frames = readEuroc(args.get("--euroc"));
    else if (args.has("--left") && args.has("--right"))
      frames.push_back({0, args.get("--left"), args.get("--right")});
    else
      throw ips::ArgError("give --euroc DIR or --left and --right");
    if (frames.empty()) throw std::runtime_error("no frames");

    cv::Size size;
    if (args.has("--size") && std::sscanf(args.get("--size").c_str(), "%dx%d", &size.width, &size.height) != 2)
      throw ips::ArgError("--size must be WxH");
    const double rate = args.getDouble("--rate");
    if (!(rate >= 0.01 && rate <= 1000)) throw ips::ArgError("--rate must be in [0.01, 1000] Hz");
    long long count = args.getInt("--count");
    if (count <= 0) count = static_cast<long long>(frames.size());
    const int64_t period_us = static_cast<int64_t>(1e6 / rate);

    ips::fw::Node node("stereo_player", args.get("--lcm-url"));
    std::this_thread::sleep_for(std::chrono::duration<double>(args.getDouble("--wait-subscriber")));

    uint64_t sum = 0;
    auto next = std::chrono::steady_clock::now();
    const int64_t start_utime = args.getInt("--start-utime");
    cv::Mat cached_left, cached_right;
    for (long long i = 0; i < count && !ips::fw::stopRequested(); ++i) {
      const Frame& f = frames[i % frames.size()];
      if (frames.size() > 1 || cached_left.empty()) {
        cached_left = cv::imread(f.left, cv::IMREAD_GRAYSCALE);
        cached_right = cv::imread(f.right, cv::IMREAD_GRAYSCALE);
        if (cached_left.empty() || cached_right.empty())
          throw std::runtime_error("cannot read " + f.left + " / " + f.right);
        if (size.area() > 0) {
          cv::resize(cached_left, cached_left, size, 0, 0, cv::INTER_LINEAR);
          cv::resize(cached_right, cached_right, size, 0, 0, cv::INTER_LINEAR);
        }
      }
      const int64_t utime =
          f.utime > 0 && static_cast<size_t>(i) < frames.size() ? f.utime : start_utime + i * period_us;
      ips::stereo_pair_t msg = ips::fw::makeStereoPair(utime, i, cached_left, cached_right);
      sum += checksum(msg);
      std::this_thread::sleep_until(next);
      if (args.get("--channel") == ips::channels::kStereo)
        node.publish(ips::channels::kStereoTime, ips::fw::stereoTimeOf(msg));
      node.publish(args.get("--channel"), msg);
      next += std::chrono::microseconds(period_us);
    }
    node.publishHealth(1.0);
    std::printf("published=%lld checksum=%llu\n", count, static_cast<unsigned long long>(sum));
    return 0;
  });
}
