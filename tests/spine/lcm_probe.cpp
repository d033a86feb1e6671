// lcm_probe: attacks the running system over LCM the way a faulty network or a malicious host would, for the
// process-level hostile-input test (probe_processes_test.sh).
//   --attack      waits for the live IMU and STEREO streams, then publishes on every channel a process reads:
//                 each valid sample message with every 4-byte window replaced by a hostile length, a 100-byte
//                 pair declaring 2 GB of pixels, stamps one hour ahead of the streams, NaN covariances and
//                 biases, and a sequence number near 2^63. Prints what it sent per kind.
//   --duplicate N relays every TRACKER_DELTA it hears N more times, byte for byte (a link that repeats
//                 packets), until --duration seconds have passed.
// It publishes raw bytes through lcm::LCM directly: the point is to send what the framework would refuse to.
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdio>
#include <ips/disparity_map_t.hpp>
#include <ips/filter_state_t.hpp>
#include <ips/health_t.hpp>
#include <ips/imu_sample_t.hpp>
#include <ips/stereo_pair_t.hpp>
#include <ips/stereo_time_t.hpp>
#include <ips/tilt_sample_t.hpp>
#include <ips/tracker_delta_t.hpp>
#include <lcm/lcm-cpp.hpp>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "ips/args.hpp"
#include "ips/framework/channels.hpp"
#include "ips/framework/image.hpp"
#include "ips/test_support/sample_messages.hpp"

namespace {

using ips::test_support::encodeMessage;
using Clock = std::chrono::steady_clock;

constexpr int64_t kHourUs = 3'600'000'000LL;

struct StreamsSeen {
  int64_t imu_utime = 0, stereo_utime = 0, delta_utime = 0;
  int32_t width = 0, height = 0;
};

class Listener {
 public:
  explicit Listener(StreamsSeen& seen) : seen_(seen) {}
  void onImu(const lcm::ReceiveBuffer*, const std::string&, const ips::imu_sample_t* m) {
    seen_.imu_utime = std::max(seen_.imu_utime, m->utime);
  }
  void onStereo(const lcm::ReceiveBuffer*, const std::string&, const ips::stereo_pair_t* m) {
    seen_.stereo_utime = std::max(seen_.stereo_utime, m->utime);
    seen_.width = m->width;
    seen_.height = m->height;
  }

 private:
  StreamsSeen& seen_;
};

class Sender {
 public:
  explicit Sender(lcm::LCM& lcm) : lcm_(lcm) {}

  void raw(const std::string& kind, const std::string& channel, const std::vector<uint8_t>& bytes) {
    lcm_.publish(channel, bytes.data(), static_cast<unsigned>(bytes.size()));
    ++sent_[kind];
    // A burst of thousands of datagrams would overflow the receivers' socket buffers and test the kernel, not
    // the processes: pace them.
    std::this_thread::sleep_for(std::chrono::microseconds(300));
  }

  template <class Msg>
  void message(const std::string& kind, const std::string& channel, const Msg& m) {
    raw(kind, channel, encodeMessage(m));
  }

  // Every 4-byte window after the type's fingerprint replaced by a hostile length.
  template <class Msg>
  void hostileLengths(const std::string& channel, const Msg& valid) {
    ips::test_support::forEachHostileLength(
        encodeMessage(valid),
        [&](const std::vector<uint8_t>& bad, size_t, int32_t) { raw("hostile_length", channel, bad); });
  }

  void print() const {
    for (const auto& kv : sent_) std::printf("sent %s=%lld\n", kv.first.c_str(), static_cast<long long>(kv.second));
  }

 private:
  lcm::LCM& lcm_;
  std::map<std::string, int64_t> sent_;
};

ips::imu_sample_t imuSample(int64_t utime, int64_t seq) {
  ips::imu_sample_t m{};
  m.utime = utime;
  m.seq = seq;
  m.specific_force[2] = 9.80665;
  return m;
}

ips::tracker_delta_t deltaSample(int64_t utime, int64_t utime_prev) {
  ips::tracker_delta_t d{};
  d.utime = utime;
  d.utime_prev = utime_prev;
  d.seq = 1;
  d.valid = 1;
  d.translation[0] = 5.0;  // five metres in one frame: fused, it would wreck the trajectory
  d.rotation[0] = 1.0;
  for (int i = 0; i < 6; ++i) d.covariance[i * 6 + i] = 1e-6;
  d.num_inliers = 200;
  return d;
}

void attack(lcm::LCM& lcm, double wait_s) {
  StreamsSeen seen;
  Listener listener(seen);
  lcm.subscribe(ips::channels::kImu, &Listener::onImu, &listener);
  lcm.subscribe(ips::channels::kStereo, &Listener::onStereo, &listener);
  const auto deadline = Clock::now() + std::chrono::duration<double>(wait_s);
  while ((seen.imu_utime == 0 || seen.stereo_utime == 0) && Clock::now() < deadline) lcm.handleTimeout(50);
  if (seen.imu_utime == 0 || seen.stereo_utime == 0)
    throw std::runtime_error("lcm_probe: no IMU or STEREO stream heard within " + std::to_string(wait_s) + " s");
  std::printf("streams at imu=%lld stereo=%lld us, pairs %dx%d\n", static_cast<long long>(seen.imu_utime),
              static_cast<long long>(seen.stereo_utime), seen.width, seen.height);

  namespace ch = ips::channels;
  Sender send(lcm);
  // Hostile lengths on every channel a process of the system reads.
  const cv::Mat tiny(2, 4, CV_8UC1, cv::Scalar(9));
  send.hostileLengths(ch::kStereo, ips::fw::makeStereoPair(seen.stereo_utime, 1, tiny, tiny, "L", "R"));
  send.hostileLengths(ch::kImu, imuSample(seen.imu_utime, 1));
  send.hostileLengths(ch::kTrackerDelta, deltaSample(seen.stereo_utime, seen.stereo_utime - 125'000));
  send.hostileLengths(ch::kFilterPrior, ips::test_support::sampleFilterState(seen.stereo_utime));
  send.hostileLengths(ch::kFilterState, ips::test_support::sampleFilterState(seen.stereo_utime));
  send.hostileLengths(ch::kDisparity, ips::test_support::sampleDisparityMap(seen.stereo_utime));
  send.hostileLengths("HEALTH_PROBE", ips::test_support::sampleHealth(seen.stereo_utime));
  // Messages cut short on the small channels the filter and the tracker read (they have no lengths to forge).
  for (const auto& [channel, bytes] :
       {std::pair<const char*, std::vector<uint8_t>>{ch::kImu, encodeMessage(imuSample(seen.imu_utime, 1))},
        {ch::kStereoTime, encodeMessage(ips::stereo_time_t{seen.stereo_utime, 1})},
        {ch::kFilterPriorNone, encodeMessage(ips::stereo_time_t{seen.stereo_utime, 1})},
        {ch::kTrackerDelta, encodeMessage(deltaSample(seen.stereo_utime, seen.stereo_utime - 125'000))}})
    send.raw("truncated", channel, std::vector<uint8_t>(bytes.begin(), bytes.begin() + bytes.size() / 2));

  // A 100-byte pair declaring 2 GB of pixels per image.
  ips::stereo_pair_t huge = ips::fw::makeStereoPair(seen.stereo_utime, 1, tiny, tiny);
  std::vector<uint8_t> bytes = encodeMessage(huge);
  for (size_t at = 8; at + 4 <= bytes.size(); ++at) {
    // data_size is the 4-byte field right before the left image's 8 bytes
    if (at + 4 + tiny.total() * 2 == bytes.size()) {
      ips::test_support::putBigEndian32(bytes, at, INT32_MAX);
    }
  }
  send.raw("data_size_2gb", ch::kStereo, bytes);

  // Stamps one hour ahead of the streams, in messages that are otherwise well formed.
  for (int i = 0; i < 3; ++i) {
    send.message("forged_stamp", ch::kImu, imuSample(seen.imu_utime + kHourUs + i * 5000, 1'000'000 + i));
    ips::tilt_sample_t tilt{};
    tilt.utime = seen.imu_utime + kHourUs + i * 10'000;
    tilt.seq = 1'000'000 + i;
    send.message("forged_stamp", ch::kTilt, tilt);
    send.message("forged_stamp", ch::kStereoTime,
                 ips::stereo_time_t{seen.stereo_utime + kHourUs + i * 125'000, 1'000'000 + i});
    if (seen.width > 0 && seen.height > 0) {
      const cv::Mat grey(seen.height, seen.width, CV_8UC1, cv::Scalar(128));
      send.message("forged_stamp", ch::kStereo,
                   ips::fw::makeStereoPair(seen.stereo_utime + kHourUs + i * 125'000, 1'000'000 + i, grey, grey));
    }
    send.message("forged_stamp", ch::kTrackerDelta,
                 deltaSample(seen.stereo_utime + kHourUs + (i + 1) * 125'000, seen.stereo_utime + kHourUs));
  }
  // A sequence number near 2^63 on a plausible stamp: a reset, not 9e18 lost messages.
  send.message("seq_jump", ch::kImu, imuSample(seen.imu_utime + 1, std::numeric_limits<int64_t>::max() - 1));

  // Non-finite values where validation must catch them.
  ips::filter_state_t prior = ips::test_support::sampleFilterState(seen.stereo_utime);
  prior.covariance[1][1] = std::nan("");
  send.message("nan", ch::kFilterPrior, prior);
  prior = ips::test_support::sampleFilterState(seen.stereo_utime);
  prior.gyro_bias[2] = std::nan("");
  send.message("nan", ch::kFilterPrior, prior);
  ips::filter_state_t state = ips::test_support::sampleFilterState(seen.stereo_utime);
  state.covariance[0][0] = std::numeric_limits<double>::infinity();
  send.message("nan", ch::kFilterState, state);
  ips::imu_sample_t imu = imuSample(seen.imu_utime, 2);
  imu.angular_rate[1] = std::nan("");
  send.message("nan", ch::kImu, imu);
  ips::tracker_delta_t delta = deltaSample(seen.stereo_utime, seen.stereo_utime - 125'000);
  delta.translation[1] = std::nan("");
  send.message("nan", ch::kTrackerDelta, delta);

  // Finite values no navigation state or delta can have: a zero quaternion, a position of 1e308 m, a covariance
  // with a negative direction (its diagonal positive).
  prior = ips::test_support::sampleFilterState(seen.stereo_utime);
  for (double& q : prior.orientation) q = 0;
  send.message("impossible", ch::kFilterPrior, prior);
  prior = ips::test_support::sampleFilterState(seen.stereo_utime);
  prior.position[0] = 1e308;
  send.message("impossible", ch::kFilterPrior, prior);
  delta = deltaSample(seen.stereo_utime + 1, seen.stereo_utime - 125'000);
  delta.translation[0] = 0.01;
  delta.covariance[1] = delta.covariance[6] = 2e-6;  // |correlation| 2 between tx and ty
  send.message("impossible", ch::kTrackerDelta, delta);
  send.print();
}

// A fresh system's first messages forged far ahead (before any real one): the stamp of a pair, a tilt sample and
// a delta an hour into the future, and a pair of the walk's size (--width, --height) likewise.
void forgeFirst(lcm::LCM& lcm, int width, int height) {
  namespace ch = ips::channels;
  Sender send(lcm);
  const int64_t far = 9'000'000'000'000'000;  // 9e15 us: year 2255
  send.message("forged_first", ch::kStereoTime, ips::stereo_time_t{far, 7});
  ips::tilt_sample_t tilt{};
  tilt.utime = far;
  tilt.seq = 7;
  send.message("forged_first", ch::kTilt, tilt);
  send.message("forged_first", ch::kTrackerDelta, deltaSample(far + 125'000, far));
  const cv::Mat grey(height, width, CV_8UC1, cv::Scalar(128));
  send.message("forged_first", ch::kStereo, ips::fw::makeStereoPair(far, 7, grey, grey));
  send.print();
}

class Repeater {
 public:
  Repeater(lcm::LCM& lcm, int copies) : lcm_(lcm), copies_(copies) {}
  void onMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    // Our own repeats come back to us: relay only what we have not sent.
    std::vector<uint8_t> bytes(static_cast<const uint8_t*>(rbuf->data),
                               static_cast<const uint8_t*>(rbuf->data) + rbuf->data_size);
    if (!relayed_.insert(bytes).second) return;
    for (int i = 0; i < copies_; ++i) lcm_.publish(channel, rbuf->data, rbuf->data_size);
    ++repeated_;
  }
  int64_t repeated() const { return repeated_; }

 private:
  lcm::LCM& lcm_;
  int copies_;
  int64_t repeated_ = 0;
  std::set<std::vector<uint8_t>> relayed_;
};

}  // namespace

int main(int argc, char** argv) {
  try {
    ips::Args args(argc, argv, "attack a running system over LCM (for the hostile-input process test)");
    args.option("--lcm-url", "URL", "LCM URL", "")
        .flag("--attack", "publish the hostile messages once the IMU and STEREO streams are heard")
        .option("--wait", "S", "how long to wait for the streams", "60")
        .option("--duplicate", "N", "relay every TRACKER_DELTA N more times", "0")
        .option("--duration", "S", "how long to relay", "30")
        .flag("--forge-first", "publish forged first messages at once (for a fresh system), then go on")
        .option("--width", "PX", "--forge-first: the pair's width", "640")
        .option("--height", "PX", "--forge-first: the pair's height", "480");
    if (!args.parse()) return 0;
    lcm::LCM lcm(args.get("--lcm-url"));
    if (!lcm.good()) throw std::runtime_error("lcm_probe: cannot open LCM at '" + args.get("--lcm-url") + "'");
    if (args.getFlag("--forge-first"))
      forgeFirst(lcm, static_cast<int>(args.getInt("--width")), static_cast<int>(args.getInt("--height")));
    if (args.getFlag("--attack")) attack(lcm, args.getDouble("--wait"));
    const int copies = static_cast<int>(args.getInt("--duplicate"));
    if (copies > 0) {
      Repeater repeater(lcm, copies);
      lcm.subscribe(ips::channels::kTrackerDelta, &Repeater::onMessage, &repeater);
      std::printf("ready\n");
      std::fflush(stdout);
      const auto end = Clock::now() + std::chrono::duration<double>(args.getDouble("--duration"));
      while (Clock::now() < end) lcm.handleTimeout(50);
      std::printf("repeated %lld deltas %d times each\n", static_cast<long long>(repeater.repeated()), copies);
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
}
